"""Forward runs of closed loops on the geometrically nonlinear model: the compiled Radau IIA
integrator (`radau.py`) on the loops' rates (`dynamics/_nonlinear_loops_numba.py`: the
tree's residual with the constraint forces, on states projected onto the exact closures),
then the output states projected again, with their accelerations and constraint forces.
Sampled controllers drive the actuators as on the first-order loops (`loops.integrate_loops`):
the integrator holds their voltages in the input rows, which the model's residual reads."""

from __future__ import annotations

import numpy as np

from ..dynamics.forward_kernel import breakpoints, inputs, voltage_columns
from ..dynamics.nonlinear_loops import NonlinearLoopSystem, closed_states
from ..errors import SimulationError, StoppedRun, UnstableLoop
from .forward import stop_reason
from .gauss_sampled import SampledLoop
from .loops import LoopRun
from .radau import RadauStop, integrate_radau
from .solution import LOCAL_CONTROL, Accuracy, Progress, Solution

METHOD = "radau5"


def error_groups(loops: NonlinearLoopSystem) -> np.ndarray:
    """The error group of each component of [y, ẏ] (Radau IIA weighs each error against its
    group's peak): the elastic coordinates by link, each free joint angle its own, each servo
    integral its own; the rates likewise."""
    s = loops.system
    links = np.repeat(np.arange(len(s.modal)), [d.n for d in s.modal])
    one = np.concatenate([links, len(s.modal) + np.arange(s.nu + s.ns)])
    return np.concatenate([one, one.max(initial=-1) + 1 + one])


def integrate_nonlinear_loops(loops: NonlinearLoopSystem, t_out: np.ndarray, rtol: float,
                              atol: float, on_progress: Progress | None = None,
                              loop: SampledLoop | None = None) -> LoopRun:
    """Integrate the closed mechanism from its closed initial state (`NonlinearLoopSystem.y0`):
    the Solution's coordinates are [p_free, q] (the nonlinear forward path's order), the servo
    integrals its ``extra``; ``loop``: sampled controllers driving the actuators, reading
    their sensors as rows over q (y's first n entries). Each step is sized from the largest
    of the last accepted errors (`integrate_radau`'s ``recent``, as the first-order loops):
    the coupler's undamped vibration makes the estimate swing with its phase, and a step
    sized from the last error alone was rejected one in five times."""
    system = loops.system
    y0 = loops.y0
    n, nu, ny = system.n, system.nu, system.n_y
    held = voltage_columns(system.loads) if loop is not None else slice(0, 0)
    try:
        states, stats = integrate_radau(
            loops.data, loops.workspace(), y0, t_out, lambda t: inputs(system.loads, t),
            breakpoints(system.loads), rtol, atol, error_groups(loops), np.inf,
            on_progress=on_progress, loop=loop, held=held, z=slice(0, n), recent=True,
            box=system.free_travels())
    except RadauStop as exc:
        if exc.why == "box":  # the run's travel check names it (simulation/nonlinear_forward)
            raise StoppedRun(f"the closed-loop run stopped at t = {exc.t:.6g} s: "
                             f"{stop_reason(exc)}", exc.t, exc.states, exc.y, True) from None
        if loop is not None:
            raise UnstableLoop(exc.t, stop_reason(exc)) from None
        raise StoppedRun(  # with its last state: a travel left before is named instead
            f"the closed-loop run stopped at t = {exc.t:.6g} s ({exc.why}): the mechanism may "
            "have reached a singular configuration (a toggle position)", exc.t, exc.states,
            exc.y) from None
    u = inputs(system.loads, t_out)
    if loop is not None:
        u[:, held] = loop.held_voltages(t_out)
    closed, acc, lam, joint, residual = closed_states(loops, t_out, states, u)
    if not np.all(np.isfinite(residual)):
        at = float(t_out[np.argmax(~np.isfinite(residual))])
        raise SimulationError(f"the closed loops could not be closed at t = {at:.6g} s: "
                              "the mechanism reached a singular configuration")
    y, v = closed[:, :ny], closed[:, ny:]
    order = np.r_[n:n + nu, 0:n]
    solution = Solution(t_out, y[:, order], v[:, order], acc[:, order], METHOD, stats,
                        extra=v[:, n + nu:], accuracy=Accuracy(rtol, None, LOCAL_CONTROL))
    return LoopRun(solution, lam, joint, residual)
