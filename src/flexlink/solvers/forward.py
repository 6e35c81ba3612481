"""Forward-dynamics runs (free or pinned base, driven joints): the compiled Lawson loop
(``method = "lawson"``, `forward_lawson.py`) or classical RK4 loop (``"rk4"``,
`forward_rk4.py`) — a run's "lawson" or "magnus" maps to the one `compiled_method` picks —
or scipy's ``solve_ivp`` (DOP853, Radau, …: the tight-tolerance reference).

The state is [p_free, ṗ_free, z, ż, servo integrals]; the coupled equations of
`dynamics.forward.ForwardSystem` (nonlinear in the rigid coordinates, first order in z) give
its rate — through the compiled kernel (`dynamics/_forward_numba.py`, tested against the
numpy equations to round-off) unless ``compiled=False``. The `Solution`'s coordinates are
[p_free, z], its ``extra`` the servo integrals.
"""

from __future__ import annotations

import numpy as np

from ..dynamics import forward_kernel
from ..dynamics.forward import ForwardSystem
from ..errors import SimulationError, UnstableLoop
from .forward_lawson import integrate_forward_lawson
from .forward_rk4 import BlowUp, integrate_forward_rk4
from .gauss_sampled import SampledLoop
from .ode import Stalled, integrate_ivp
from .solution import SCIPY, Accuracy, Progress, Solution

DEFAULT_METHOD = "DOP853"  # of integrate_forward: the reference
FAST_METHOD = "compiled"  # what a run's "lawson" or "magnus" maps to: see compiled_method
COMPILED = {"lawson": integrate_forward_lawson, "rk4": integrate_forward_rk4}
MAX_STEP_OUTPUTS = 10  # longest step, in output intervals (simulation.dt_out)


def integrate_forward(system: ForwardSystem, t_out: np.ndarray, rtol: float, atol: float,
                      method: str = DEFAULT_METHOD, on_progress: Progress | None = None,
                      compiled: bool = True, loop: SampledLoop | None = None) -> Solution:
    """Coordinates [p_free, z], their rates and accelerations at t_out from the system's
    initial state; the servo integrals as ``extra``. ``method``: "lawson" or "rk4" (compiled
    loops), FAST_METHOD (the one `compiled_method` picks) or a solve_ivp method, whose
    right-hand side is the compiled kernel or (``compiled=False``) the numpy ForwardSystem.

    solve_ivp's step is limited to MAX_STEP_OUTPUTS output intervals: while nothing moves the
    error estimate is zero and the step would otherwise grow past the start of an input.

    ``loop``: sampled controllers driving the actuators, compiled loops only
    (`forward_sampled.py`); a blow-up is then reported as an unstable closed loop."""
    if method == FAST_METHOD:
        method = compiled_method(system)
    if loop is not None and method not in COMPILED:
        raise ValueError(f"controllers on a forward run need a compiled integrator: method = "
                         f"{method!r} cannot hold sampled voltages; use \"lawson\" or \"rk4\"")
    if method in COMPILED:
        try:
            return COMPILED[method](system, t_out, rtol, atol, on_progress, loop)
        except BlowUp as exc:
            if loop is not None:
                raise UnstableLoop(exc.t, "the state grew without bound") from None
            raise SimulationError(_stall_message(system, exc.t, "the state grew without "
                                                 "bound")) from None
    nu, n = len(system.free), system.n
    if compiled:
        from ..dynamics._forward_numba import rates as kernel
        from ..dynamics._forward_numba import workspace

        data = forward_kernel.pack(system)
        work = workspace(data, len(system.servos))

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        if on_progress is not None:
            on_progress(t)
        if compiled:
            dy = np.empty_like(y)
            kernel(data, work, forward_kernel.inputs(system, np.array([t]))[0], y, dy)
            return dy
        parts = split_state(system, y[None])
        pdd, zdd, rates = system.accelerations(np.array([t]), *parts)
        return np.concatenate([y[nu:2 * nu], pdd[0], y[2 * nu + n:2 * nu + 2 * n], zdd[0],
                               rates[0]])

    max_step = MAX_STEP_OUTPUTS * float(np.min(np.diff(t_out))) if t_out.size > 1 else np.inf
    try:
        y, evaluations = integrate_ivp(rhs, system.initial_state(), t_out, rtol, atol, method,
                                       max_step)
    except Stalled as exc:
        raise SimulationError(_stall_message(system, exc.t, "the time step collapsed")) from None
    p_free, pd_free, z, zd, integral = split_state(system, y)
    pdd_free, zdd, _ = system.accelerations(t_out, p_free, pd_free, z, zd, integral)
    return Solution(t_out, np.hstack([p_free, z]), np.hstack([pd_free, zd]),
                    np.hstack([pdd_free, zdd]), method, {"rhs_evaluations": evaluations},
                    extra=integral, accuracy=Accuracy(rtol, None, SCIPY))


def compiled_method(system: ForwardSystem) -> str:
    """The compiled loop for a run (ARCHITECTURE.md): "lawson" when every joint is prescribed
    (a free or pinned base moved by its loads: slow inputs, the appendages' top modes followed
    over many periods, 8 steps per output where RK4 needs 32 on the satellite slew), "rk4"
    when a joint is driven (servo torques and references change within the interval the
    Jacobian is frozen for, and the Lawson remainder, seen through the oscillating factor,
    costs it 40× in error constant against RK4 on the servo-driven paper arm)."""
    return "lawson" if not system.driven else "rk4"


def split_state(system: ForwardSystem, y: np.ndarray) -> tuple[np.ndarray, ...]:
    """p_free, ṗ_free, z, ż, integrals from states (nt, ·)."""
    nu, n = len(system.free), system.n
    cuts = np.cumsum([nu, nu, n, n])
    return tuple(np.split(y, cuts, axis=1))


def _stall_message(system: ForwardSystem, t: float, why: str) -> str:
    hint = ("; the paper's model (geometric_stiffening = false) is not energy-consistent and "
            "can blow up when a light link swings fast: set geometric_stiffening = true"
            if not system.geometric_stiffening else
            "; the first-order model may be outside its range (large deflections), or a servo "
            "loop is very stiff: try method = \"Radau\"")
    return f"the forward run stalled at t = {t:.6g} s ({why}){hint}"
