"""Forward-dynamics runs (free or pinned base, driven joints) through scipy's ``solve_ivp``.

The state is [p_free, ṗ_free, z, ż, servo integrals]; the coupled equations of
`dynamics.forward.ForwardSystem` (nonlinear in the rigid coordinates, first order in z) give
its rate. The `Solution`'s coordinates are [p_free, z], its ``extra`` the servo integrals.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.forward import ForwardSystem
from ..errors import SimulationError
from .ode import Stalled, integrate_ivp
from .solution import Progress, Solution

DEFAULT_METHOD = "DOP853"  # "lawson", "magnus" (prescribed-joint integrators) do not apply here
MAX_STEP_OUTPUTS = 10  # longest step, in output intervals (simulation.dt_out)


def integrate_forward(system: ForwardSystem, t_out: np.ndarray, rtol: float, atol: float,
                      method: str = DEFAULT_METHOD, on_progress: Progress | None = None
                      ) -> Solution:
    """Coordinates [p_free, z], their rates and accelerations at t_out from the system's
    initial state; the servo integrals as ``extra``.

    The step is limited to MAX_STEP_OUTPUTS output intervals: while nothing moves the error
    estimate is zero and the step would otherwise grow past the start of an input."""
    nu, n = len(system.free), system.n

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        parts = split_state(system, y[None])
        pdd, zdd, rates = system.accelerations(np.array([t]), *parts)
        if on_progress is not None:
            on_progress(t)
        return np.concatenate([y[nu:2 * nu], pdd[0], y[2 * nu + n:2 * nu + 2 * n], zdd[0],
                               rates[0]])

    max_step = MAX_STEP_OUTPUTS * float(np.min(np.diff(t_out))) if t_out.size > 1 else np.inf
    try:
        y, evaluations = integrate_ivp(rhs, system.initial_state(), t_out, rtol, atol, method,
                                       max_step)
    except Stalled as exc:
        raise SimulationError(_stall_message(system, exc.t)) from None
    p_free, pd_free, z, zd, integral = split_state(system, y)
    pdd_free, zdd, _ = system.accelerations(t_out, p_free, pd_free, z, zd, integral)
    return Solution(t_out, np.hstack([p_free, z]), np.hstack([pd_free, zd]),
                    np.hstack([pdd_free, zdd]), method, {"rhs_evaluations": evaluations},
                    extra=integral)


def split_state(system: ForwardSystem, y: np.ndarray) -> tuple[np.ndarray, ...]:
    """p_free, ṗ_free, z, ż, integrals from states (nt, ·)."""
    nu, n = len(system.free), system.n
    cuts = np.cumsum([nu, nu, n, n])
    return tuple(np.split(y, cuts, axis=1))


def _stall_message(system: ForwardSystem, t: float) -> str:
    hint = ("; the paper's model (geometric_stiffening = false) is not energy-consistent and "
            "can blow up when a light link swings fast: set geometric_stiffening = true"
            if not system.geometric_stiffening else
            "; the first-order model may be outside its range (large deflections), or a servo "
            "loop is very stiff: try method = \"Radau\"")
    return f"the forward run stalled at t = {t:.6g} s (the time step collapsed){hint}"
