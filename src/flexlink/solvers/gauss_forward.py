"""Gauss collocation for the nonlinear model with rigid coordinates (free or pinned base,
driven joints): the two-stage method of `gauss.py` (docs/nonlinear.md §4) on the residual of
`dynamics.nonlinear_forward.NonlinearForwardSystem`, whose unknowns y = [q, p_free, σ] add the
free rigid coordinates and the servo integrals (σ̇ the integral) to the elastic coordinates.

The stage residuals now include the applied forces (drive torques, servo laws, base loads),
which depend on the stage's rigid state; the finite-difference iteration matrix carries
their derivatives (the servo's stiffness) as it carries K. The compiled loops are gauss.py's
(`_gauss_numba.py`, reached with this model's `NonlinearForwardData`) and the default; the
numpy loop reuses gauss.py's Newton and is the reference the tests compare them with.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..dynamics.nonlinear_forward import NonlinearForwardSystem
from ..dynamics.nonlinear_kernel import StageInputs, stage_rows
from ..errors import SimulationError, StoppedRun
from .gauss import (
    FIRST_STEP,
    NEWTON_MAX,
    NODES,
    RATE_FLOOR,
    ROUND_OFF,
    _Newton,
    end_accelerations,
    fixed_steps,
    hermite_quintic,
    interpolated_nodes,
    numpy_fixed_steps,
)
from .gauss_steps import newton_settings
from .solution import FIXED_STEP, Accuracy, Solution

# Newton's stopping tolerance (relative to the largest stage acceleration), 10× gauss.py's:
# the rigid coordinates carry conserved momenta, and the iteration error of each step adds up
# as a random walk (measured over 10 s of a spinning free base: momentum constant to 4.6e-9
# at 1e-9, 1.2e-9 at 1e-10, for no measurable cost — one iteration at most).
NEWTON_TOL_FORWARD = 1e-10
# Without base coordinates (a fixed hub: driven joints, sliders) no momentum is conserved
# whose drift would add up, and Newton stops as gauss.py's at a thousandth of the step's
# tolerance: on the slider cases of benchmarks/slider_vs_fe.py a fifth to a quarter fewer
# CPU seconds, every channel's error unchanged to its second digit. So does a cart, whose one
# base coordinate is its travel: its momentum along the rail drifts by 1e-9–2e-9 N·s over
# the 2 s of Case 23's slider on a free 1 kg cart (2e-10 at 1e-10), each channel's error
# against the converged run unchanged to its second digit (hub rate 3.0e-4, tip 4.3e-6 of
# their peaks with 4 modes) but the cart's travel, 9e-9 → 1e-8 with 4 modes and 3e-9 →
# 1.2e-8 with 6 (its model error 1.5e-4), for a quarter fewer Newton iterations.
NEWTON_SHARE_OF_RTOL = 1e-3


def forward_newton_tol(system: NonlinearForwardSystem, rtol: float) -> float:
    """Newton's stopping tolerance of an error-controlled forward run at ``rtol``: a
    share of it without base coordinates other than a cart's travel, else
    NEWTON_TOL_FORWARD."""
    if system.n_base and system.rail is None:
        return NEWTON_TOL_FORWARD
    return max(NEWTON_TOL_FORWARD, NEWTON_SHARE_OF_RTOL * rtol)


class _Rows:
    """Stage times and inputs, indexable like gauss.py's NodeInputs."""

    def __init__(self, t: np.ndarray, inp: StageInputs) -> None:
        self.t, self.inp = t, inp

    def __getitem__(self, index: int | slice | np.ndarray) -> _Rows:
        return _Rows(self.t[index], StageInputs(*(x[index] for x in self.inp)))


class _StageResidual:
    """The system seen by gauss.py's numpy Newton: n unknowns, residual(Q, V, X, rows)."""

    def __init__(self, system: NonlinearForwardSystem) -> None:
        self.system, self.n = system, system.n_y

    def residual(self, Q: np.ndarray, V: np.ndarray, X: np.ndarray, rows: _Rows) -> np.ndarray:
        return self.system.residual(rows.t, Q, V, X, rows.inp)


def integrate_gauss_forward(
    system: NonlinearForwardSystem, t_end: float, step: float,
    on_progress: Callable[[float], None] | None = None, compiled: bool = True,
    newton_tol: float = NEWTON_TOL_FORWARD,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step ends t (m+1,), y and ẏ there (m+1, n_y) from the system's initial state; uniform
    steps ≤ step (s). ``compiled``: the numba loop, or the numpy one it is tested against."""
    steps = max(1, int(np.ceil(t_end / step - 1e-9)))
    h = t_end / steps
    t_ends = np.arange(steps + 1) * h
    t_stage = (t_ends[:-1, None] + NODES[None, :] * h).ravel()
    inp = system.stage_inputs(t_stage)
    y = np.zeros((steps + 1, system.n_y))
    v = np.zeros_like(y)
    y[0], v[0] = system.initial_state()
    X = np.repeat(system.accelerations(np.zeros(1), y[:1], v[:1], compiled), 2, axis=0)
    if compiled:
        y[1:] = np.nan  # the rows a failed step did not reach
        try:
            fixed_steps(system.kernel_data(), stage_rows(*inp), y, v, X, h,
                        newton_settings(newton_tol, NEWTON_MAX,
                                        ROUND_OFF * system.max_frequency**2, True),
                        t_ends, on_progress,
                        lambda start, end: check_travels(system, t_ends[start + 1:end + 1],
                                                         y[start + 1:end + 1]))
        except np.linalg.LinAlgError as exc:
            raise singular_stop(system, exc, t_ends, y) from None
    else:
        newton = _Newton(_StageResidual(system), h, newton_tol,  # type: ignore[arg-type]
                         running_peak=True, floor=ROUND_OFF * system.max_frequency**2,
                         elastic=system.n)
        numpy_fixed_steps(newton, y, v, X, h, _Rows(t_stage, inp), t_ends, on_progress)
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(v))):
        raise SimulationError("the nonlinear forward integration produced non-finite values")
    return t_ends, y, v


def check_travels(system: NonlinearForwardSystem, t: np.ndarray, y: np.ndarray) -> None:
    """StoppedRun at the first of the step ends t (s), y (·, n_y) where a cart or a slider
    is outside its travel (`NonlinearForwardSystem.free_travels`): the run stops there, and
    its travel check names the field (simulation/nonlinear_forward.py)."""
    columns, lo, hi = system.free_travels()
    if columns.size == 0 or y.shape[0] == 0:
        return
    s = y[:, columns]
    out = np.flatnonzero(np.any(~((s >= lo) & (s <= hi)), axis=1))
    if out.size:
        i = int(out[0])
        raise StoppedRun(f"the nonlinear run stopped at t = {t[i]:.6g} s: a cart or a slider "
                         "left its travel", float(t[i]), None, y[i].copy(), True)


def singular_stop(system: NonlinearForwardSystem, exc: Exception, t: np.ndarray,
                  y: np.ndarray) -> StoppedRun:
    """The run stopped where its equations became singular, with the last step end it
    reached (of the step ends t (s), y (·, n_y), NaN where not reached); StoppedRun of the
    travel left at an earlier of them, if one was (`check_travels`)."""
    reached = np.flatnonzero(np.all(np.isfinite(y), axis=1))
    last = int(reached[-1]) if reached.size else 0
    check_travels(system, t[:last + 1], y[:last + 1])
    return StoppedRun(
        f"the nonlinear run failed after t = {t[last]:.6g} s: its equations became singular "
        f"({exc}); the state left the range where the model holds. Check for loads, gains or "
        "drive forces far too large, or a cart or slider driven far past its travel",
        float(t[last]), None, y[last].copy())


def node_solution(system: NonlinearForwardSystem, t_nodes: np.ndarray, y: np.ndarray,
                  v: np.ndarray, t_out: np.ndarray, stats: dict[str, float] | None = None,
                  accuracy: Accuracy | None = None) -> Solution:
    """The Solution at t_out from the step ends t_nodes, y, ẏ there (n_y unknowns): the
    quintic Hermite interpolant with the equations' accelerations at the step ends
    (`end_accelerations` at the loads' breakpoints), coordinates reordered [p_free, q],
    the servo integrals as ``extra``."""
    from ..dynamics.forward_kernel import breakpoints

    n, nu = system.n, system.nu
    a = np.zeros_like(y)
    used = interpolated_nodes(t_nodes, t_out)  # the others' accelerations are not read
    a[used] = system.accelerations(t_nodes[used], y[used], v[used])
    a_end = end_accelerations(system.accelerations, t_nodes, y, v, a,
                              breakpoints(system.loads))
    y, v, a = hermite_quintic(t_nodes, y, v, a, t_out, a_end)
    order = np.r_[n:n + nu, 0:n]
    return Solution(t_out, y[:, order], v[:, order], a[:, order], "gauss", stats or {},
                    extra=v[:, n + nu:], accuracy=accuracy)


def solve_nonlinear_forward(
    system: NonlinearForwardSystem, t_out: np.ndarray, rtol: float, step: float | None = None,
    on_progress: Callable[[float], None] | None = None, atol: float = 0.0,
    step_ends: list | None = None,
) -> Solution:
    """Coordinates [p_free, q], rates and accelerations at t_out (the first-order forward
    path's order), the servo integrals as ``extra``, method "gauss", with its step
    statistics, the tolerance asked for and the error estimate reached.

    With ``step`` given: uniform steps of at most that (s). Otherwise adaptive steps
    (gauss_steps.py) as solve_nonlinear's, the local error measured against the peak so far
    of each group (elastic q, free rigid p) and of its rates; steps end at the inputs'
    breakpoints (bang-bang switches, table samples, ends of reference moves). ``step_ends``
    as `gauss.solve_nonlinear`'s."""
    t_end = float(t_out[-1])

    def solution(t_nodes: np.ndarray, y: np.ndarray, v: np.ndarray, stats: dict[str, float],
                 accuracy: Accuracy) -> Solution:
        if step_ends is not None:
            step_ends.append((t_nodes, y, v, 1 if step is not None else 2))
        return node_solution(system, t_nodes, y, v, t_out, stats, accuracy)

    if step is not None:
        t_nodes, y, v = integrate_gauss_forward(system, t_end, step, on_progress)
        return solution(t_nodes, y, v, {"time_step_s": float(t_nodes[1] - t_nodes[0])},
                        Accuracy(rtol, None, FIXED_STEP))
    record = integrate_forward_adaptive(system, t_end, rtol, atol, on_progress)
    return solution(record.t, record.y, record.v, record.stats(), record.accuracy(rtol))


def integrate_forward_adaptive(system: NonlinearForwardSystem, t_end: float, rtol: float,
                               atol: float = 0.0,
                               on_progress: Callable[[float], None] | None = None) -> Any:
    """Step ends from the system's initial state to t_end (s) with error-controlled steps
    (gauss_steps.step_doubling on the compiled loop): a gauss_steps.StepRecord."""
    from ..dynamics.forward_kernel import breakpoints
    from .gauss_steps import (
        DOUBLING_STAGES,
        FORWARD_CHECK_EVERY,
        FORWARD_SLOW_CONTRACTION,
        Batch,
        DoublingLoop,
        step_control,
        step_doubling,
    )

    n_y, n, nu = system.n_y, system.n, system.nu
    group = np.full(n_y, -1, dtype=np.int64)  # the servo integrals set no step
    group[:n] = 0
    group[n:n + nu] = 1
    doubling = DoublingLoop(
        system.kernel_data(), n_y,
        newton_settings(forward_newton_tol(system, rtol), NEWTON_MAX,
                        ROUND_OFF * system.max_frequency**2, True, FORWARD_SLOW_CONTRACTION,
                        shared_partials=True),
        step_control(group, rtol, atol, RATE_FLOOR * system.max_frequency),
        FORWARD_CHECK_EVERY)

    longest: list[StageInputs] = []  # the longest batch's rows so far: shorter ones reuse them

    def advance(t0: float, H: float, count: int, y0: np.ndarray, v0: np.ndarray,
                X: np.ndarray, h_prev: float, new_step: bool) -> Batch:
        inp = stage_rows(*system.stage_inputs(
            (t0 + H * (np.arange(count)[:, None] + DOUBLING_STAGES[None, :])).ravel(),
            reuse=longest[0] if longest else None))
        if not longest or inp.u.shape[0] > longest[0].u.shape[0]:
            longest[:] = [inp]
        try:
            batch = doubling.batch(inp, y0, v0, X, h_prev, H, count, new_step)
        except np.linalg.LinAlgError as exc:  # the batch's step ends reached: NaN after
            raise singular_stop(system, exc, t0 + H * np.arange(count + 1),
                                doubling.reached) from None
        check_travels(system, t0 + H * np.arange(1, batch.y.shape[0]), batch.y[1:])
        return batch

    y0, v0 = system.initial_state()
    X = np.repeat(system.accelerations(np.zeros(1), y0[None], v0[None]), 2, axis=0)
    record = step_doubling(advance, y0, v0, X, t_end, breakpoints(system.loads), FIRST_STEP,
                           doubling.control, on_progress)
    if not (np.all(np.isfinite(record.y)) and np.all(np.isfinite(record.v))):
        raise SimulationError("the nonlinear forward integration produced non-finite values")
    return record
