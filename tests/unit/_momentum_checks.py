"""What the tests of the compiled momentum (dynamics/_momentum_numba.py) compute to check it:
its components at a state, the numpy `dynamics.forward.momentum` at the same state, and the
rate of the compiled first moment S = ∫r dm along the motion."""

from __future__ import annotations

from typing import Any

import numpy as np

from flexlink.dynamics._forward_numba import rates as kernel
from flexlink.dynamics._forward_numba import workspace
from flexlink.dynamics._momentum_numba import _state, components
from flexlink.dynamics.forward import ForwardSystem, momentum
from flexlink.dynamics.forward_kernel import inputs, pack
from flexlink.dynamics.momentum_projection import projection


def packed(system: ForwardSystem) -> tuple[Any, Any, Any]:
    """The compiled kernel's data, a workspace and the momentum projection of ``system``."""
    d = pack(system)
    return d, workspace(d, 0), projection(system, d, 0.0, inputs(system, np.zeros(1)).shape[1])


def compiled_components(system: ForwardSystem, d: Any, w: Any, pj: Any, t: float,
                        y: np.ndarray) -> np.ndarray:
    """The compiled kernel's components at time ``t`` (s) and state ``y``: linear momentum
    x, y (kg·m/s), angular momentum (kg·m²/s), first moment S x, y (kg·m)."""
    out = np.zeros(5)
    _state(d, w, inputs(system, np.array([t]))[0], y)
    components(d, w, pj, w.pd, out)
    return out


def numpy_momentum(system: ForwardSystem, t: float, y: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`dynamics.forward.momentum` at time ``t`` (s) and state ``y``: the linear (1×2) and
    angular (1,) momentum, and the rigid rates (1×n_rigid) they came from."""
    nu, n = len(system.free), system.n
    p, pd, _ = system.rigid_state(np.array([t]), y[None, :nu], y[None, nu:2 * nu],
                                  np.zeros((1, nu)))
    lin, ang = momentum(system, p, pd, y[None, 2 * nu:2 * nu + n],
                        y[None, 2 * nu + n:2 * nu + 2 * n])
    return lin, ang, pd


def first_moment_rate(system: ForwardSystem, d: Any, w: Any, pj: Any, t: float,
                      y: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """dS/dt (kg·m/s) at ``t`` (s) and ``y`` along the motion: central differences of the
    compiled S, the positions moved with their rates over ±``eps`` s."""
    nu, n = len(system.free), system.n
    rates = np.empty_like(y)
    kernel(d, w, inputs(system, np.array([t]))[0], y, rates)
    moments = []
    for sign in (1.0, -1.0):
        ys = y.copy()
        ys[:nu] += sign * eps * rates[:nu]  # positions move with their rates
        ys[2 * nu:2 * nu + n] += sign * eps * rates[2 * nu:2 * nu + n]
        moments.append(compiled_components(system, d, w, pj, t + sign * eps, ys)[3:5])
    return (moments[0] - moments[1]) / (2 * eps)
