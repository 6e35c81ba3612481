"""Gauss collocation for the nonlinear model with rigid coordinates (free or pinned base,
driven joints): the two-stage method of `gauss.py` (docs/nonlinear.md §4) on the residual of
`dynamics.nonlinear_forward.NonlinearForwardSystem`, whose unknowns y = [q, p_free, σ] add the
free rigid coordinates and the servo integrals (σ̇ the integral) to the elastic coordinates.

The stage residuals now include the applied forces (drive torques, servo laws, base loads),
which depend on the stage's rigid state; the finite-difference iteration matrix carries
their derivatives (the servo's stiffness) as it carries K. The compiled loop
(`_gauss_forward_numba.py`) is the default; the numpy loop reuses gauss.py's Newton and is the
reference the tests compare it with.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..dynamics.nonlinear_forward import NonlinearForwardSystem, StageInputs
from ..errors import SimulationError
from .gauss import (
    COEFFS,
    COEFFS2,
    FIRST_STEP,
    NEWTON_MAX,
    NODES,
    RATE_FLOOR,
    ROUND_OFF,
    WEIGHTS,
    WEIGHTS2,
    _Newton,
    hermite_quintic,
)
from .solution import FIXED_STEP, Accuracy, Solution
from .threads import single_threaded

CHUNK = 400  # steps per compiled call, between progress reports
# Newton's stopping tolerance (relative to the largest stage acceleration), 10× gauss.py's:
# the rigid coordinates carry conserved momenta, and the iteration error of each step adds up
# as a random walk (measured over 10 s of a spinning free base: momentum constant to 4.6e-9
# at 1e-9, 1.2e-9 at 1e-10, for no measurable cost — one iteration at most).
NEWTON_TOL_FORWARD = 1e-10


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
        _compiled_loop(system, y, v, X, h, inp, on_progress, t_ends, newton_tol)
    else:
        newton = _Newton(_StageResidual(system), h, newton_tol,  # type: ignore[arg-type]
                         running_peak=True, floor=ROUND_OFF * system.max_frequency**2,
                         elastic=system.n)
        rows = _Rows(t_stage, inp)
        with single_threaded():
            for i in range(steps):
                if i > 0:
                    X = X + (X[1] - X[0]) / (NODES[1] - NODES[0])
                X = newton.solve(y[i], v[i], X, rows[2 * i:2 * i + 2])  # type: ignore[arg-type]
                v[i + 1] = v[i] + h * (WEIGHTS @ X)
                y[i + 1] = y[i] + h * v[i] + h**2 * (WEIGHTS2 @ X)
                if on_progress is not None and i % 50 == 0:
                    on_progress(float(t_ends[i + 1]))
    if not (np.all(np.isfinite(y)) and np.all(np.isfinite(v))):
        raise SimulationError("the nonlinear forward integration produced non-finite values")
    return t_ends, y, v


def _compiled_loop(system: NonlinearForwardSystem, y: np.ndarray, v: np.ndarray, X: np.ndarray,
                   h: float, inp: StageInputs, on_progress: Callable[[float], None] | None,
                   t_ends: np.ndarray, newton_tol: float) -> None:
    """Run the numba step loop over y, v in place, in chunks of CHUNK steps."""
    from ._gauss_forward_numba import gauss_forward_loop  # numba: only when used

    data, loads = system.packed()
    steps = y.shape[0] - 1
    peak = np.zeros(1)  # the run's largest stage acceleration, across chunks
    for start in range(0, steps, CHUNK):
        end = min(start + CHUNK, steps)
        stage = slice(2 * start, 2 * end)
        failed, _, _ = gauss_forward_loop(
            y[start:end + 1], v[start:end + 1], X, h,
            *(np.ascontiguousarray(a[stage], dtype=float) for a in inp), data, loads,
            NODES, COEFFS, COEFFS2, WEIGHTS, WEIGHTS2, newton_tol, NEWTON_MAX, start > 0, peak,
            ROUND_OFF * system.max_frequency**2)
        if failed >= 0:
            raise SimulationError(
                f"the nonlinear step at t = {t_ends[start + failed]:.4g} s did not converge in "
                f"{NEWTON_MAX} Newton iterations (h = {h:.3g} s): reduce the step")
        if on_progress is not None:
            on_progress(float(t_ends[end]))


def solve_nonlinear_forward(
    system: NonlinearForwardSystem, t_out: np.ndarray, rtol: float, step: float | None = None,
    on_progress: Callable[[float], None] | None = None, atol: float = 0.0,
) -> Solution:
    """Coordinates [p_free, q], rates and accelerations at t_out (the first-order forward
    path's order), the servo integrals as ``extra``, method "gauss", with its step
    statistics, the tolerance asked for and the error estimate reached.

    With ``step`` given: uniform steps of at most that (s). Otherwise adaptive steps
    (gauss_steps.py) as solve_nonlinear's, the local error measured against the peak so far
    of each group (elastic q, free rigid p) and of its rates; steps end at the inputs'
    breakpoints (bang-bang switches, table samples, ends of reference moves)."""
    t_end = float(t_out[-1])
    n, nu = system.n, system.nu

    def solution(t_nodes: np.ndarray, y: np.ndarray, v: np.ndarray, stats: dict[str, float],
                 accuracy: Accuracy) -> Solution:
        y, v, a = hermite_quintic(t_nodes, y, v, system.accelerations(t_nodes, y, v), t_out)
        order = np.r_[n:n + nu, 0:n]
        return Solution(t_out, y[:, order], v[:, order], a[:, order], "gauss", stats,
                        extra=v[:, n + nu:], accuracy=accuracy)

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
    from ._gauss_forward_numba import gauss_forward_doubling
    from .gauss_steps import DOUBLING_STAGES, Batch, step_doubling

    n_y, n, nu = system.n_y, system.n, system.nu
    data, loads = system.packed()
    group = np.full(n_y, -1, dtype=np.int64)  # the servo integrals set no step
    group[:n] = 0
    group[n:n + nu] = 1
    peak_q, peak_v = np.zeros(2), np.zeros(2)
    inverse = np.zeros((2, 2 * n_y, 2 * n_y))
    have = np.zeros(2, dtype=np.int64)
    counts = np.zeros(2, dtype=np.int64)
    peak_a = np.zeros(1)  # the run's largest stage acceleration (solve_stages)

    def advance(t0: float, H: float, count: int, y0: np.ndarray, v0: np.ndarray,
                X: np.ndarray, h_prev: float, new_step: bool) -> Batch:
        inp = system.stage_inputs(
            (t0 + H * (np.arange(count)[:, None] + DOUBLING_STAGES[None, :])).ravel())
        y = np.empty((count + 1, n_y))
        v = np.empty((count + 1, n_y))
        y[0], v[0] = y0, v0
        errors = np.zeros(count)
        if new_step:
            have[:] = 0
        status, k = gauss_forward_doubling(
            y, v, X, h_prev, H, *(np.ascontiguousarray(a, dtype=float) for a in inp), data,
            loads, NODES, COEFFS, COEFFS2, WEIGHTS, WEIGHTS2, NEWTON_TOL_FORWARD, NEWTON_MAX,
            ROUND_OFF * system.max_frequency**2, group, peak_q, peak_v, rtol, atol,
            RATE_FLOOR * system.max_frequency, errors, inverse, have, counts, peak_a)
        return Batch(int(status), y[:k + 1], v[:k + 1], errors, counts)

    y0, v0 = system.initial_state()
    X = np.repeat(system.accelerations(np.zeros(1), y0[None], v0[None]), 2, axis=0)
    record = step_doubling(advance, y0, v0, X, t_end, breakpoints(system.loads), FIRST_STEP,
                           on_progress)
    if not (np.all(np.isfinite(record.y)) and np.all(np.isfinite(record.v))):
        raise SimulationError("the nonlinear forward integration produced non-finite values")
    return record
