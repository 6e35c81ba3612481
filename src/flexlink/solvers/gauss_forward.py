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

import numpy as np

from ..dynamics.nonlinear_forward import NonlinearForwardSystem, StageInputs
from ..errors import SimulationError
from .gauss import (
    COEFFS,
    COEFFS2,
    NEWTON_MAX,
    NODES,
    RATE_FLOOR,
    ROUND_OFF,
    WEIGHTS,
    WEIGHTS2,
    _Newton,
    hermite_quintic,
)
from .solution import Solution
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
                         ROUND_OFF * system.max_frequency**2, system.n)
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
    for start in range(0, steps, CHUNK):
        end = min(start + CHUNK, steps)
        stage = slice(2 * start, 2 * end)
        failed, _, _ = gauss_forward_loop(
            y[start:end + 1], v[start:end + 1], X, h,
            *(np.ascontiguousarray(a[stage], dtype=float) for a in inp), data, loads,
            NODES, COEFFS, COEFFS2, WEIGHTS, WEIGHTS2, newton_tol, NEWTON_MAX, start > 0,
            ROUND_OFF * system.max_frequency**2)
        if failed >= 0:
            raise SimulationError(
                f"the nonlinear step at t = {t_ends[start + failed]:.4g} s did not converge in "
                f"{NEWTON_MAX} Newton iterations (h = {h:.3g} s): reduce the step")
        if on_progress is not None:
            on_progress(float(t_ends[end]))


def solve_nonlinear_forward(
    system: NonlinearForwardSystem, t_out: np.ndarray, rtol: float, step: float | None = None,
    on_progress: Callable[[float], None] | None = None, max_halvings: int = 6,
) -> Solution:
    """Coordinates [p_free, q], rates and accelerations at t_out (the first-order forward
    path's order), the servo integrals as ``extra``, method "gauss", the step (s) in stats.

    Step control as solve_nonlinear's, the error of the finer run |difference| / 15 measured
    against the peak of each group (elastic q, free rigid p) and of its rates."""
    t_end = float(t_out[-1])
    n, nu = system.n, system.nu

    def run(h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t_nodes, y, v = integrate_gauss_forward(system, t_end, h, on_progress)
        a = system.accelerations(t_nodes, y, v)
        return hermite_quintic(t_nodes, y, v, a, t_out)

    def solution(y: np.ndarray, v: np.ndarray, a: np.ndarray, h: float) -> Solution:
        order = np.r_[n:n + nu, 0:n]
        return Solution(t_out, y[:, order], v[:, order], a[:, order], "gauss",
                        {"time_step_s": h}, extra=v[:, n + nu:])

    if step is not None:
        return solution(*run(step), step)
    h = min(0.01, t_end)
    previous = None
    err = np.inf
    groups = [g for g in (slice(0, n), slice(n, n + nu)) if g.stop > g.start]
    for _ in range(max_halvings + 1):
        try:
            y, v, a = run(h)
        except SimulationError:
            previous = None
            h /= 2
            continue
        if previous is not None:
            # each group against its peak or, where a group stays at rest (a run in static
            # equilibrium: round-off), against RATE_FLOOR × the largest coordinate (times
            # ω_max for the rates; solvers.gauss.solve_nonlinear)
            big = RATE_FLOOR * max(float(np.abs(y[:, g]).max()) for g in groups)
            floors = (big, big * system.max_frequency)
            err = max(_change(previous[i][:, g], x[:, g], floors[i])
                      for i, x in enumerate((y, v)) for g in groups) / 15.0
            if err <= rtol:
                return solution(y, v, a, h)
        previous = (y, v)
        h /= 2
    raise SimulationError(
        f"the nonlinear solution did not converge to rtol = {rtol:g} with steps down to "
        f"{2 * h:.3g} s (last change {err:.2g} of the peak): loosen simulation.rtol or set "
        f"simulation.step")


def _change(coarse: np.ndarray, fine: np.ndarray, floor: float = 0.0) -> float:
    """Largest |fine − coarse| relative to the peak |fine| or ``floor`` if larger (0 where
    nothing moves)."""
    peak = max(float(np.abs(fine).max()), floor)
    return float(np.abs(fine - coarse).max() / peak) if peak > 0.0 else 0.0
