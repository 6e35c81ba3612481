"""Static equilibrium as the initial state (``[simulation] initial = "equilibrium"``).

Every model finds its start the same way: the unknowns (elastic coordinates, and the angle or
integral of each servo that holds a joint) are moved until the accelerations of the held
coordinates vanish at rest, by Newton's method with a finite-difference Jacobian
(`solve`). The first-order model with prescribed joints is linear in z and solves
K z = f directly (`FirstOrderSystem.equilibrium`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np

from ..errors import SimulationError

ITERATIONS = 50
STEP = 1e-7  # finite-difference step, relative to max(1, |x|)
# Accelerations left, relative to those at the start, above which the start is no
# equilibrium: Newton's steps also vanish where the unknowns no longer move the
# accelerations (a servo at its torque limit or saturated), the residual does not. Below
# ROUND_OFF of the accelerations a unit change of the unknowns makes, they are round-off
# (a start already in equilibrium: a hanging link).
RESIDUAL = 1e-6
ROUND_OFF = 1e-10


def solve(residuals: Callable[[np.ndarray], np.ndarray], x0: np.ndarray,
          watched: Sequence[Unheld] = ()) -> np.ndarray:
    """x with residuals(x) = 0 from x0: ``residuals`` maps a batch (b, m) of unknowns to
    (b, k) accelerations (k ≥ m: least squares), evaluated at once for the Jacobian's
    columns, followed by the accelerations of the ``watched`` coordinates (the joints
    nothing holds), which must vanish at the solution too (`check_unheld`). A
    SimulationError when the iteration does not settle (no equilibrium: a servo too weak
    for the load, a standing link past its buckling load)."""
    x = np.asarray(x0, dtype=float).copy()
    k = len(watched)
    held = residuals if not k else (lambda xs: residuals(xs)[:, :-k])
    x = _newton(held, x)
    if k:
        check_unheld(residuals, np.asarray(x0, dtype=float), x, watched)
    return x


def _newton(residuals: Callable[[np.ndarray], np.ndarray], x: np.ndarray) -> np.ndarray:
    x0 = x.copy()
    m = x.size
    if m == 0:
        return x
    scale = max(1.0, float(np.abs(x).max()))
    step = np.full(m, np.inf)
    first, jacobian = None, np.zeros((0, 0))
    for _ in range(ITERATIONS):
        h = STEP * np.maximum(1.0, np.abs(x))
        trial = np.repeat(x[None], m + 1, 0)
        trial[np.arange(1, m + 1), np.arange(m)] += h
        r = residuals(trial)
        if first is None:
            first = float(np.abs(r[0]).max()) if r.shape[1] else 0.0
        jacobian = (r[1:] - r[0]).T / h
        step = np.linalg.lstsq(jacobian, r[0], rcond=None)[0]
        x -= step
        scale = max(scale, float(np.abs(x).max()))
        if np.abs(step).max() <= 1e-12 * scale:
            break
    r = residuals(x[None])[0]
    left = float(np.abs(r).max()) if r.size else 0.0
    unit = float(np.abs(jacobian).max()) * max(1.0, float(np.abs(x0).max())) \
        if jacobian.size else 0.0
    if (not np.all(np.isfinite(x)) or np.abs(step).max() > 1e-8 * scale
            or not left <= max(RESIDUAL * (first or 0.0), ROUND_OFF * unit)):
        raise SimulationError(
            'simulation.initial = "equilibrium": no static equilibrium found at t = 0 '
            f"(accelerations left up to {left:.3g}); a servo may be too weak for "
            "the load (torque_limit, saturation), or a standing link past its buckling load; "
            'use initial = "rest"')
    return x


class Unheld(NamedTuple):
    """A rigid coordinate that no servo, spring or prescribed motion holds at the start: the
    joint's place in the scenario (``joints[k]``, or its motor) and the unit of its
    acceleration."""

    name: str
    unit: str  # "rad/s²" or "m/s²"


# Accelerations of unheld joints at the solution below this (rad/s², m/s²) are round-off: a
# drift of 1e-9 rad/s² turns a joint 5e-7 rad in 30 s.
UNHELD_FLOOR = 1e-9


def check_unheld(residuals: Callable[[np.ndarray], np.ndarray], x0: np.ndarray, x: np.ndarray,
                 watched: Sequence[Unheld]) -> None:
    """Refuses a start whose unheld joints (the last len(watched) columns of ``residuals``)
    accelerate at the equilibrium x of the held ones: no static equilibrium exists (an
    inverted arm on a free pin, a torque that does not balance the load), and the run would
    start moving, not at rest."""
    r = residuals(np.stack([x0, x]))
    k = len(watched)
    start, left = np.abs(r[0]), np.abs(r[1, -k:])
    bound = max(UNHELD_FLOOR, RESIDUAL * float(start.max()))
    worst = int(np.argmax(left))
    if not np.all(np.isfinite(left)) or left[worst] > bound:
        name, unit = watched[worst]
        raise SimulationError(
            'simulation.initial = "equilibrium": no static equilibrium at t = 0: '
            f"{name}, held by no servo, spring or prescribed motion, starts accelerating at "
            f"{left[worst]:.3g} {unit} under the loads at t = 0 (gravity, torques, forces). "
            "Hold it (a servo, or a prescribed motion), balance its load, or use "
            'initial = "rest"')
