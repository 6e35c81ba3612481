"""Forward runs of closed loops: the compiled Radau IIA integrator (`radau.py`) on the
loops' rates (`dynamics/_loops_numba.py`: the tree's equations with the constraint forces,
on states projected onto the closures), then the output states projected again, with the
constraint forces at the outputs."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.forward_kernel import breakpoints, inputs, voltage_columns
from ..dynamics.loops import LoopSystem, closed_states
from ..errors import SimulationError, StoppedRun, UnstableLoop
from .forward import deflection_bounds, error_groups, stop_reason
from .gauss_sampled import SampledLoop
from .radau import RadauStop, integrate_radau
from .solution import LOCAL_CONTROL, Accuracy, Progress, Solution

METHOD = "radau5"


@dataclass(frozen=True)
class LoopRun:
    """A closed-loop run: the Solution (coordinates [p_free, z]), the multipliers λ
    (nt, n_c; N), their torques on the joints' rows (nt, N; N·m) and the largest closure
    residual |Φ| of each output state (nt,; m)."""

    solution: Solution
    multipliers: np.ndarray
    joint_forces: np.ndarray
    residual: np.ndarray


def integrate_loops(loops: LoopSystem, t_out: np.ndarray, rtol: float, atol: float,
                    on_progress: Progress | None = None, loop: SampledLoop | None = None,
                    steps: list | None = None) -> LoopRun:
    """Integrate the closed mechanism from its closed initial state (`LoopSystem.y0`);
    ``loop``: sampled controllers driving the actuators (the integrator stops at each
    sample and holds their voltages in the input rows, as on the tree's forward path);
    ``steps``: a list that receives the accepted steps (`radau.integrate_radau`)."""
    system = loops.system
    y0 = loops.y0
    nu, n = len(system.free), system.n
    groups = error_groups(system, y0.size)
    held = voltage_columns(system) if loop is not None else slice(0, 0)
    try:
        states, stats = integrate_radau(
            loops.data, loops.workspace(y0.size), y0, t_out, lambda t: inputs(system, t),
            breakpoints(system), rtol, atol, groups, np.inf, on_progress=on_progress,
            loop=loop, held=held, z=slice(2 * nu, 2 * nu + n), steps=steps, recent=True,
            box=system.free_travels(), bounds=deflection_bounds(system, y0.size))
    except RadauStop as exc:
        if loop is not None and exc.why != "box":
            raise UnstableLoop(exc.t, stop_reason(exc)) from None
        raise StoppedRun(
            f"the closed-loop run stopped at t = {exc.t:.6g} s ({exc.why}): the mechanism may "
            "have reached a singular configuration (a toggle position) or left the "
            "first-order model's range", exc.t, exc.states, exc.y,
            exc.why == "box") from None
    u = inputs(system, t_out)
    if loop is not None:
        u[:, held] = loop.held_voltages(t_out)
    return loop_run(loops, t_out, states, stats, rtol, u)


def loop_run(loops: LoopSystem, t_out: np.ndarray, states: np.ndarray, stats: dict,
             rtol: float, u: np.ndarray | None = None) -> LoopRun:
    """The LoopRun from the integrated states at t_out: projected onto the closures, with
    their multipliers and rates; ``u``: the inputs at t_out (default the system's, without
    held controller voltages)."""
    system = loops.system
    nu, n = len(system.free), system.n
    if u is None:
        u = inputs(system, t_out)
    closed, rates, lam, joint, residual = closed_states(loops, t_out, states, u)
    if not np.all(np.isfinite(residual)):
        at = float(t_out[np.argmax(~np.isfinite(residual))])
        raise SimulationError(f"the closed loops could not be closed at t = {at:.6g} s: "
                              "the mechanism reached a singular configuration")
    p, pd = closed[:, :nu], closed[:, nu:2 * nu]
    z, zd = closed[:, 2 * nu:2 * nu + n], closed[:, 2 * nu + n:2 * nu + 2 * n]
    solution = Solution(t_out, np.hstack([p, z]), np.hstack([pd, zd]),
                        np.hstack([rates[:, nu:2 * nu], rates[:, 2 * nu + n:2 * nu + 2 * n]]),
                        METHOD, stats, extra=closed[:, 2 * nu + 2 * n:],
                        accuracy=Accuracy(rtol, None, LOCAL_CONTROL))
    return LoopRun(solution, lam, joint, residual)
