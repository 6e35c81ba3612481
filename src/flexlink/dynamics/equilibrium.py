"""Static equilibrium as the initial state (``[simulation] initial = "equilibrium"``).

Every model finds its start the same way: the unknowns (elastic coordinates, and the angle or
integral of each servo that holds a joint) are moved until the accelerations of the held
coordinates vanish at rest, by Newton's method with a finite-difference Jacobian
(`solve`). The first-order model with prescribed joints is linear in z and solves
K z = f directly (`FirstOrderSystem.equilibrium`).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import SimulationError

ITERATIONS = 50
STEP = 1e-7  # finite-difference step, relative to max(1, |x|)


def solve(residuals: Callable[[np.ndarray], np.ndarray], x0: np.ndarray) -> np.ndarray:
    """x with residuals(x) = 0 from x0: ``residuals`` maps a batch (b, m) of unknowns to
    (b, k) accelerations (k ≥ m: least squares), evaluated at once for the Jacobian's
    columns. A SimulationError when the iteration does not settle (no equilibrium: a servo
    too weak for the load, a standing link past its buckling load)."""
    x = np.asarray(x0, dtype=float).copy()
    m = x.size
    if m == 0:
        return x
    scale = max(1.0, float(np.abs(x).max()))
    step = np.full(m, np.inf)
    for _ in range(ITERATIONS):
        h = STEP * np.maximum(1.0, np.abs(x))
        trial = np.repeat(x[None], m + 1, 0)
        trial[np.arange(1, m + 1), np.arange(m)] += h
        r = residuals(trial)
        jacobian = (r[1:] - r[0]).T / h
        step = np.linalg.lstsq(jacobian, r[0], rcond=None)[0]
        x -= step
        scale = max(scale, float(np.abs(x).max()))
        if np.abs(step).max() <= 1e-12 * scale:
            break
    if not np.all(np.isfinite(x)) or np.abs(step).max() > 1e-8 * scale:
        r = residuals(x[None])[0]
        raise SimulationError(
            'simulation.initial = "equilibrium": no static equilibrium found at t = 0 '
            f"(accelerations left up to {np.abs(r).max():.3g}); a servo may be too weak for "
            "the load (torque_limit, saturation), or a standing link past its buckling load; "
            'use initial = "rest"')
    return x
