"""The default forward-dynamics integrator: Lawson's integrating-factor RK4 with the Jacobian
frozen while the rigid configuration stays put, compiled, on a fixed grid with Richardson
error control (ARCHITECTURE.md, "Why the solver looks like this").

The grid is that of `forward_rk4.py` — outputs plus every input breakpoint — at a level ℓ:
2^ℓ equal steps per node interval, or (ℓ = −1) one step over two node intervals wherever the
node between them is neither a breakpoint nor an end. The run at level ℓ is compared with
the run at ℓ − 1 on the outputs both reach (error ≈ difference / 15, fourth order), ℓ raised
until each state group agrees within atol + rtol · its peak. ℓ starts at 0: the exponential
carries the stiff modes, so no step is bound by stability, and the coarse run of the first
comparison takes two output intervals per step (at 1 when breakpoints leave few to merge).
"""

from __future__ import annotations

import numpy as np

from ..dynamics.forward import ForwardSystem
from ..dynamics.forward_kernel import ForwardData, breakpoints, inputs, pack, voltage_columns
from ..errors import SimulationError
from .forward_rk4 import BlowUp, forward_solution, runs_agree, runs_error
from .forward_sampled import inner_nodes, run_steps
from .gauss_sampled import SampledLoop
from .solution import RICHARDSON, Accuracy, Progress, Solution

_MAX_LEVEL = 8
# The Jacobian is refreshed when a free rigid coordinate has moved by more than _DP (rad or
# m) or its rate by more than _DPD (rad/s or m/s) since it was taken: the coefficients of
# the elastic equations depend on the configuration and (centrifugal, Coriolis) the rates.
_DP = 0.05
_DPD = 0.5


def integrate_forward_lawson(system: ForwardSystem, t_out: np.ndarray, rtol: float,
                             atol: float, on_progress: Progress | None = None,
                             loop: SampledLoop | None = None) -> Solution:
    """Coordinates [p_free, z], their rates and accelerations at t_out from the system's
    initial state; the servo integrals as ``extra`` (the contract of solvers.forward).
    ``loop``: sampled controllers driving the actuators (`forward_sampled.py`; their sample
    instants are nodes no step straddles); each pass of the error control runs them afresh."""
    from ..dynamics._forward_numba import workspace

    data = pack(system)
    work = workspace(data, len(system.servos))
    inner = inner_nodes(loop, t_out, breakpoints(system))
    nodes = np.union1d(t_out, inner)
    record = np.full(nodes.size, -1, dtype=np.int64)
    record[np.searchsorted(nodes, t_out)] = np.arange(t_out.size)
    hard = np.zeros(nodes.size, dtype=bool)  # nodes a step may not straddle
    hard[np.searchsorted(nodes, inner)] = True
    hard[[0, -1]] = True
    if loop is not None:  # the samples that fell on outputs too
        hard[np.searchsorted(nodes, loop.grid[:-1] - 1e-9 * max(1.0, float(t_out[-1])))] = True
    y0 = system.initial_state()
    level = 0 if _merges(nodes, hard) else 1
    coarse, _ = _run(data, work, y0, system, nodes, record, hard, t_out.size, level - 1,
                     None, loop)
    while level <= _MAX_LEVEL:
        fine, refreshes = _run(data, work, y0, system, nodes, record, hard, t_out.size, level,
                               on_progress, loop)
        if isinstance(fine, BlowUp) and isinstance(coarse, BlowUp) \
                and abs(fine.t - coarse.t) <= 0.05 * fine.t:
            raise fine  # the same time at two step sizes: the model, not the steps
        if not isinstance(fine, BlowUp) and not isinstance(coarse, BlowUp):
            both = np.isfinite(coarse[:, 0])
            if runs_agree(system, fine[both], coarse[both], rtol, atol):
                solution = forward_solution(
                    data, work, system, t_out, fine, 2 ** level, loop, method="lawson",
                    accuracy=Accuracy(rtol, runs_error(system, fine[both], coarse[both]),
                                      RICHARDSON))
                solution.stats.update(jacobian_refreshes=refreshes)
                return solution
        coarse = fine
        level += 1
    if isinstance(coarse, BlowUp):
        raise coarse
    raise SimulationError(
        f"the forward run did not reach rtol = {rtol:g}, atol = {atol:g} with {2 ** _MAX_LEVEL} "
        "steps per output interval; loosen the tolerances or use method = \"Radau\"")


def _merges(nodes: np.ndarray, hard: np.ndarray) -> bool:
    """Whether level −1 merges (nearly) every pair of node intervals: only then does its
    comparison with level 0 estimate the error of every step (an input tabulated at every
    output, the torque replay, leaves nothing to merge)."""
    return grid(nodes, hard, -1)[1].size <= 0.51 * (nodes.size - 1) + 1


def grid(nodes: np.ndarray, hard: np.ndarray, level: int) -> tuple[np.ndarray, np.ndarray,
                                                                   np.ndarray]:
    """Step starts (s), lengths (s) and, per step, the node it ends on, at ``level``: 2^level
    equal steps per node interval, or (level −1) two node intervals per step where the
    node between them is not ``hard``."""
    if level >= 0:
        substeps = 2 ** level
        width = np.diff(nodes)
        starts = (nodes[:-1, None] + width[:, None] * (np.arange(substeps) / substeps)).ravel()
        ends = np.full((nodes.size - 1, substeps), -1, dtype=np.int64)
        ends[:, -1] = np.arange(1, nodes.size)
        return starts, np.repeat(width / substeps, substeps), ends.ravel()
    kept = [0]
    i = 0
    last = nodes.size - 1
    while i < last:
        i = i + 2 if i + 2 <= last and not hard[i + 1] else i + 1
        kept.append(i)
    at = np.array(kept, dtype=np.int64)
    return nodes[at[:-1]], np.diff(nodes[at]), at[1:]


def _run(data: ForwardData, work: tuple, y0: np.ndarray, system: ForwardSystem,
         nodes: np.ndarray, record: np.ndarray, hard: np.ndarray, n_out: int, level: int,
         on_progress: Progress | None, loop: SampledLoop | None = None
         ) -> tuple[np.ndarray | BlowUp, int]:
    """States at the outputs (n_out, len(y0); NaN rows at outputs the grid steps over) and
    the number of Jacobian refreshes, or the BlowUp."""
    from ._forward_lawson_numba import lawson_steps

    starts, h, ends = grid(nodes, hard, level)
    # Stage inputs read just inside the step: a jump on a node is taken from the right side.
    inside = 1e-9 * h
    times = np.stack([starts + inside, starts + 0.5 * h, starts + h - inside], 1)
    u = inputs(system, times.ravel()).reshape(times.shape + (-1,))
    step_record = np.where(ends >= 0, record[np.maximum(ends, 0)], -1)
    states = np.full((n_out, y0.size), np.nan)
    states[0] = y0
    y = y0.copy()
    m = y0.size
    nu = len(system.free)
    frozen = np.full(m, np.nan)
    L, E = np.empty((m, m)), np.empty((m, m))
    c, g = np.empty(m), np.empty(m)
    counters = np.zeros(3)
    bad = run_steps(lambda a, b: lawson_steps(data, work, y, u, h, step_record, a, b, states,
                                              nu, _DP, _DPD, frozen, L, c, E, g, counters),
                    y, starts, h, u, on_progress, loop, voltage_columns(system),
                    slice(2 * nu, 2 * nu + system.n))
    return (BlowUp(float(starts[bad])) if bad >= 0 else states), int(counters[0])
