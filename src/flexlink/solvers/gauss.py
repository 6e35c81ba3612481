"""Two-stage Gauss–Legendre collocation for M(q, t) q̈ = f(q, q̇, t) (the nonlinear model).

Why this method: the highest modal frequencies (thousands of rad/s with 8 modes) make explicit
schemes take tiny steps, while the motion that matters is slow. Gauss collocation is A-stable,
of order 4, symmetric and symplectic: without damping and with the joints held, the energy
error stays bounded at O(h⁴) instead of drifting. Steps are error-controlled
(`gauss_steps.py`: step doubling, batches of equal steps whose joint angles are evaluated in
one vectorised call), or uniform with a fixed ``simulation.step``.

One step, with stage accelerations X_i (unknowns), stage velocities V_i = v₀ + h Σ a_ij X_j and
positions Q_i = q₀ + c_i h v₀ + h² Σ (a²)_ij X_j, solves the stage residuals
R_i = M(Q_i) X_i − f(Q_i, V_i, t_i) = 0 (``NonlinearSystem.residual``, no mass matrix needed)
by simplified Newton with the iteration matrix δ_ij ∂R_i/∂X + h² (a²)_ij ∂R_i/∂Q +
h a_ij ∂R_i/∂V — it contains K and D exactly, so the stiff modes do not slow the iteration;
it is kept across steps while it contracts well. Output times come from the quintic Hermite
interpolant of q, q̇, q̈ at the step ends. docs/nonlinear.md §4.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..dynamics.histories import input_breakpoints
from ..dynamics.nonlinear import NodeInputs, NonlinearSystem
from ..dynamics.nonlinear_kernel import StageInputs
from ..errors import SimulationError, UnstableLoop
from .gauss_steps import (
    COEFFS,
    COEFFS2,
    GAUSS2,
    NODES,
    STATE_ROUND_OFF,
    WEIGHTS,
    WEIGHTS2,
    NewtonSettings,
    newton_settings,
)
from .solution import FIXED_STEP, Accuracy, Solution
from .threads import single_threaded

NEWTON_TOL = 1e-9  # relative to the largest stage acceleration
NEWTON_MAX = 20
# Newton's absolute floor, relative to ω_max² |q| (the elastic accelerations): round-off of
# the elastic forces, what a static equilibrium under a constant load converges to.
ROUND_OFF = 1e-13
# The step control's floor on the peak rate, relative to ω_max |q|: far below any motion's
# rates (ω |q|), far above the round-off rates of a run at rest in static equilibrium.
RATE_FLOOR = 1e-8


def integrate_gauss(
    system: NonlinearSystem, t_end: float, step: float,
    on_progress: Callable[[float], None] | None = None,
    q0: np.ndarray | None = None, v0: np.ndarray | None = None, compiled: bool = True,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step ends t (m+1,), q and q̇ there (m+1, n), from q0, v0 (default: the system's
    initial coordinates, at rest) at t = 0;
    uniform steps ≤ step (s). ``compiled``: the numba loop (numba is a dependency), or the
    numpy one that it is tested against."""
    steps = max(1, int(np.ceil(t_end / step - 1e-9)))
    h = t_end / steps
    n = system.n
    t_ends = np.arange(steps + 1) * h
    inputs = system.node_inputs((t_ends[:-1, None] + NODES[None, :] * h).ravel())
    q = np.zeros((steps + 1, n))
    v = np.zeros((steps + 1, n))
    q[0] = system.initial_coordinates() if q0 is None else q0
    if v0 is not None:
        v[0] = v0
    X = np.repeat(system.accelerations(np.zeros(1), q[:1], v[:1]), 2, axis=0)
    if compiled:
        fixed_steps(system.kernel_data(), inputs.stage_inputs(), q, v, X, h,
                    newton_settings(NEWTON_TOL, NEWTON_MAX, ROUND_OFF * system.max_frequency**2,
                                    False), t_ends, on_progress)
        return t_ends, q, v
    newton = _Newton(system, h, floor=ROUND_OFF * system.max_frequency**2)
    numpy_fixed_steps(newton, q, v, X, h, inputs, t_ends, on_progress)
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise SimulationError("the nonlinear integration produced non-finite values")
    return t_ends, q, v


CHUNK = 400  # steps per compiled call, between progress reports


def fixed_steps(data: Any, rows: StageInputs, y: np.ndarray, v: np.ndarray, X: np.ndarray,
                h: float, newton: NewtonSettings, t_ends: np.ndarray,
                on_progress: Callable[[float], None] | None,
                check: Callable[[int, int], None] | None = None) -> None:
    """Advance y, v (steps+1, n) in place from row 0 by uniform steps h (s) in the compiled
    loop of the model whose kernel data ``data`` is (`_gauss_numba.gauss_loop`), in chunks
    of CHUNK steps; rows: two stage rows per step; X (2, n): the stage accelerations' guess
    for the first step. Raises SimulationError at a step whose Newton iteration fails.
    ``check(start, end)``: called after each chunk with the rows it wrote (start, end]; it
    may stop the run by raising."""
    from ._gauss_numba import gauss_loop, residual_model  # numba's import is slow: only when used

    steps = y.shape[0] - 1
    peak = np.zeros(1)  # the run's largest stage acceleration, across chunks
    model = residual_model(data)
    for start in range(0, steps, CHUNK):
        end = min(start + CHUNK, steps)
        stage = slice(2 * start, 2 * end)
        failed, _, _ = gauss_loop(model, StageInputs(*(a[stage] for a in rows)),
                                  y[start:end + 1], v[start:end + 1], X, h, GAUSS2, newton,
                                  start > 0, peak)
        if failed >= 0:
            raise SimulationError(
                f"the nonlinear step at t = {t_ends[start + failed]:.4g} s did not converge in "
                f"{newton.max_iterations} Newton iterations (h = {h:.3g} s): reduce the step")
        if check is not None:
            check(start, end)
        if on_progress is not None:
            on_progress(float(t_ends[end]))


def numpy_fixed_steps(newton: _Newton, y: np.ndarray, v: np.ndarray, X: np.ndarray, h: float,
                      rows: Any, t_ends: np.ndarray,
                      on_progress: Callable[[float], None] | None) -> None:
    """`fixed_steps` in numpy (the reference of the compiled loop): ``rows`` indexable by
    stage rows as the model's residual takes them."""
    with single_threaded():  # (the compiled path needs no limit: no BLAS calls)
        for i in range(y.shape[0] - 1):
            if i > 0:  # predictor: last step's stage accelerations, extrapolated linearly
                X = X + (X[1] - X[0]) / (NODES[1] - NODES[0])
            X = newton.solve(y[i], v[i], X, rows[2 * i:2 * i + 2])
            v[i + 1] = v[i] + h * (WEIGHTS @ X)
            y[i + 1] = y[i] + h * v[i] + h**2 * (WEIGHTS2 @ X)
            if on_progress is not None and i % 50 == 0:
                on_progress(float(t_ends[i + 1]))


class _Newton:
    """Simplified Newton for the stage accelerations. The iteration matrix (finite differences
    of the stage residuals) is kept across steps and rebuilt only when convergence slows."""

    def __init__(self, system: NonlinearSystem, h: float, tol: float = NEWTON_TOL,
                 running_peak: bool = False, floor: float = 0.0,
                 elastic: int | None = None) -> None:
        """``running_peak``: the test is relative to the largest stage acceleration of the
        run so far, not only of this step (forward runs: a rigid arm's accelerations vanish
        while it coasts, `_gauss_numba.solve_stages`). ``floor`` (1/s²) · max|q|
        (the first ``elastic`` unknowns, default all): the absolute part of the stopping
        test, as the compiled loops' ``floor``, with their STATE_ROUND_OFF of every
        unknown."""
        self.system, self.h, self.tol = system, h, tol
        self.running_peak = running_peak
        self.peak = 0.0
        self.floor, self.elastic = floor, elastic
        self.inverse: np.ndarray | None = None
        self.rebuilds = 0
        self.iterations = 0

    def solve(self, q0: np.ndarray, v0: np.ndarray, X: np.ndarray,
              inputs: NodeInputs) -> np.ndarray:
        """Stage accelerations (2, n) of one step from q0, v0 (n,), starting at the guess X."""
        h, n = self.h, self.system.n
        base_q = q0[None, :] + (NODES * h)[:, None] * v0[None, :]
        previous = np.inf
        fresh = False
        for _ in range(NEWTON_MAX):
            self.iterations += 1
            V = v0[None, :] + h * (COEFFS @ X)
            Q = base_q + h**2 * (COEFFS2 @ X)
            if self.inverse is None:
                self._rebuild(Q, V, X, inputs)
                fresh = True
            assert self.inverse is not None
            residual = self.system.residual(Q, V, X, inputs)
            dX = (self.inverse @ residual.ravel()).reshape(2, n)
            X = X - dX
            size = float(np.abs(dX).max())
            # stop when the remaining error, estimated from the contraction rate θ, is small
            theta = size / previous
            # (first iteration: no rate yet, the increment itself must be small)
            remaining = size * theta / (1.0 - theta) if 0.0 < theta < 1.0 else size
            largest = float(np.abs(X).max())
            q_size = float(np.abs(q0[:self.elastic]).max(initial=0.0))
            state_floor = STATE_ROUND_OFF * float(np.abs(q0).max(initial=0.0)) / self.h**2
            if remaining <= (self.tol * max(largest, self.peak, 1e-300) + self.floor * q_size
                             + state_floor):
                if self.running_peak:
                    self.peak = max(self.peak, largest)
                return X
            if size > 0.1 * previous and not fresh:
                self.inverse = None  # slow convergence: rebuild the matrix at the next iterate
            previous = size
            fresh = False
        raise SimulationError(
            f"the nonlinear step did not converge in {NEWTON_MAX} Newton iterations "
            f"(h = {h:.3g} s): reduce the step")

    def _rebuild(self, Q: np.ndarray, V: np.ndarray, X: np.ndarray, inputs: NodeInputs) -> None:
        """J_ij = δ_ij ∂R_i/∂X_i + h² (a²)_ij ∂R_i/∂Q_i + h a_ij ∂R_i/∂V_i for the stage
        residuals R_i(Q_i, V_i, X_i), by finite differences (exact in X: R is linear in it)."""
        h, n = self.h, self.system.n
        eps = 1e-7
        count = 3 * n + 1
        shift = np.zeros((count, 3 * n))
        shift[1:] = np.eye(3 * n)
        shift[1:2 * n + 1] *= eps
        Qb = (Q[:, None, :] + shift[None, :, :n]).reshape(-1, n)
        Vb = (V[:, None, :] + shift[None, :, n:2 * n]).reshape(-1, n)
        Xb = (X[:, None, :] + shift[None, :, 2 * n:]).reshape(-1, n)
        index = np.repeat(np.arange(2), count)
        R = self.system.residual(Qb, Vb, Xb, inputs[index]).reshape(2, count, n)
        J = np.zeros((2 * n, 2 * n))
        for i in range(2):
            dR = (R[i, 1:] - R[i, 0]).T  # (n, 3n): ∂R_i/∂Q·ε, ∂R_i/∂V·ε, ∂R_i/∂X
            for j in range(2):
                J[i * n:(i + 1) * n, j * n:(j + 1) * n] = (
                    h**2 * COEFFS2[i, j] * dR[:, :n] + h * COEFFS[i, j] * dR[:, n:2 * n]) / eps
            J[i * n:(i + 1) * n, i * n:(i + 1) * n] += dR[:, 2 * n:]
        self.inverse = np.linalg.inv(J)
        self.rebuilds += 1


# Quintic Hermite basis on s ∈ [0, 1], one row per datum (q₀, h q̇₀, h² q̈₀, q₁, h q̇₁, h² q̈₁),
# columns the coefficients of s⁰ … s⁵; and its first and second s-derivatives.
_HERMITE = np.array([[1, 0, 0, -10, 15, -6], [0, 1, 0, -6, 8, -3], [0, 0, 0.5, -1.5, 1.5, -0.5],
                     [0, 0, 0, 10, -15, 6], [0, 0, 0, -4, 7, -3], [0, 0, 0, 0.5, -1, 0.5]])
_DERIVATIVE = np.diag(np.arange(1.0, 6.0), -1)  # d/ds on coefficient vectors (s^k → k s^(k−1))
_HERMITE_D = [_HERMITE, _HERMITE @ _DERIVATIVE, _HERMITE @ _DERIVATIVE @ _DERIVATIVE]


def hermite_quintic(t_nodes: np.ndarray, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                    t: np.ndarray, a_end: np.ndarray | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ at times t from values, rates and accelerations at nodes t_nodes (uniform or
    not): the quintic Hermite interpolant and its first two derivatives (exact at the nodes).
    ``a_end``: the accelerations at each node as the end of the interval before it, where
    they differ from ``a`` (an input's jump there: `end_accelerations`); default a."""
    a_end = a if a_end is None else a_end
    i = np.clip(np.searchsorted(t_nodes, t, side="right") - 1, 0, t_nodes.size - 2)
    h = (t_nodes[i + 1] - t_nodes[i])[:, None] if t_nodes.size > 1 else np.ones((t.size, 1))
    s = (t - t_nodes[i]) / h[:, 0]
    terms = np.stack([q[i], h * v[i], h**2 * a[i], q[i + 1], h * v[i + 1],
                      h**2 * a_end[i + 1]])
    powers = s[:, None] ** np.arange(6)[None, :]  # (m, 6)
    return tuple(np.einsum("mj,jmn->mn", powers @ B.T, terms) / h**d  # type: ignore[return-value]
                 for d, B in enumerate(_HERMITE_D))


def end_accelerations(accelerations: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
                      t_nodes: np.ndarray, q: np.ndarray, v: np.ndarray, a: np.ndarray,
                      breaks: np.ndarray) -> np.ndarray:
    """The accelerations (m+1, n) at each step end t_nodes as the end of the step before it:
    ``a`` (the equations with the inputs at the node), except at a node on an input
    breakpoint ``breaks`` (s), where the inputs jump: there ``accelerations(t, q, v)`` with
    the inputs of the step that ends there (just before the breakpoint). Without them the
    interpolant of that step would end on the next step's acceleration."""
    breaks = np.asarray(breaks, dtype=float)
    a_end = a.copy()
    if breaks.size == 0 or t_nodes.size < 2:
        return a_end
    eps = 1e-12 * max(1.0, float(t_nodes[-1]))
    j = np.clip(np.searchsorted(breaks, t_nodes[1:]), 1, breaks.size) - 1
    nearest = np.where(np.abs(breaks[np.minimum(j + 1, breaks.size - 1)] - t_nodes[1:])
                       < np.abs(breaks[j] - t_nodes[1:]), breaks[np.minimum(j + 1,
                                                                           breaks.size - 1)],
                       breaks[j])
    at = np.flatnonzero(np.abs(nearest - t_nodes[1:]) <= eps) + 1
    if at.size:
        before = np.nextafter(np.minimum(t_nodes[at], nearest[at - 1]), -np.inf)
        a_end[at] = accelerations(before, q[at], v[at])
    return a_end


def node_solution(system: NonlinearSystem, t_nodes: np.ndarray, q: np.ndarray, v: np.ndarray,
                  t_out: np.ndarray, loop: Any = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ at t_out from the step ends t_nodes, q, q̇ there: the quintic Hermite
    interpolant with the equations' accelerations at the step ends (`end_accelerations`
    at the inputs' breakpoints). ``loop``: a gauss_sampled.SampledLoop whose held forces
    the accelerations take."""
    def accelerations(t: np.ndarray, q: np.ndarray, v: np.ndarray,
                      before: bool = False) -> np.ndarray:
        if loop is None:
            return system.accelerations(t, q, v)
        # sampled controllers (gauss_sampled.SampledLoop): the held forces
        return system.accelerations(t, q, v, load=loop.held_voltages(t, before)
                                    @ system.actuator_B.T)

    a = np.zeros_like(q)
    used = interpolated_nodes(t_nodes, t_out)  # the others' accelerations are not read
    a[used] = accelerations(t_nodes[used], q[used], v[used])
    breaks = input_breakpoints(system.chain.joints, system.actuators)
    if loop is not None:
        breaks = np.union1d(breaks, loop.grid)
    a_end = end_accelerations(lambda t, q, v: accelerations(t, q, v, True), t_nodes, q, v,
                              a, breaks)
    return hermite_quintic(t_nodes, q, v, a, t_out, a_end)


def interpolated_nodes(t_nodes: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The nodes (sorted indices) whose data `hermite_quintic` reads for times t: the ends
    of each time's interval."""
    i = np.clip(np.searchsorted(t_nodes, t, side="right") - 1, 0, max(t_nodes.size - 2, 0))
    return np.unique(np.concatenate([i, np.minimum(i + 1, t_nodes.size - 1)]))


def solve_nonlinear(
    system: NonlinearSystem, t_out: np.ndarray, rtol: float, step: float | None = None,
    on_progress: Callable[[float], None] | None = None, loop: Any = None, atol: float = 0.0,
    step_ends: list | None = None,
) -> Solution:
    """q, q̇, q̈ at t_out (from rest at t_out[0] = 0), method "gauss", with its step
    statistics, the tolerance asked for and the error estimate reached. q̈ interpolates the
    equations' accelerations at the step ends (the quintic's second derivative).

    With ``step`` given: uniform steps of at most that (s), no estimate. Otherwise adaptive
    steps (gauss_steps.py): each step's local error, estimated by step doubling, within
    atol + rtol · the peak |q| (and |q̇|) so far; steps end at the inputs' breakpoints.
    ``loop``: a gauss_sampled.SampledLoop — sampled controllers, updated at their sample
    instants (where steps end too), the actuators' forces held in between. ``step_ends``:
    a list that receives the step ends (t, q, q̇) and the Gauss steps per step (2: step
    doubling keeps two half steps; 1: uniform steps), what sensitivities replay."""
    t_end = float(t_out[-1])

    def finish(t_nodes: np.ndarray, q: np.ndarray, v: np.ndarray, stats: dict[str, float],
               accuracy: Accuracy) -> Solution:
        if step_ends is not None:
            step_ends.append((t_nodes, q, v, 1 if step is not None else 2))
        return Solution(t_out, *node_solution(system, t_nodes, q, v, t_out, loop), "gauss",
                        stats, accuracy=accuracy)

    if step is not None:
        nodes = (integrate_gauss(system, t_end, step, on_progress) if loop is None
                 else loop.integrate(system, step, on_progress))
        return finish(*nodes, {"time_step_s": t_end / max(1, int(np.ceil(
            t_end / step - 1e-9)))}, Accuracy(rtol, None, FIXED_STEP))
    record = integrate_adaptive(system, t_end, rtol, atol, on_progress, loop)
    return finish(record.t, record.y, record.v, record.stats(), record.accuracy(rtol))


FIRST_STEP = 0.01  # s, the adaptive control's first try


def integrate_adaptive(system: NonlinearSystem, t_end: float, rtol: float, atol: float = 0.0,
                       on_progress: Callable[[float], None] | None = None,
                       loop: Any = None) -> Any:
    """Step ends from rest at t = 0 to t_end (s) with error-controlled steps
    (gauss_steps.step_doubling on the compiled loop): a gauss_steps.StepRecord. ``loop``: a
    gauss_sampled.SampledLoop, whose controllers are updated from the state at each of their
    sample instants (every one a step end), their voltages held until the next."""
    from .gauss_steps import DOUBLING_STAGES, Batch, DoublingLoop, step_control, step_doubling

    n = system.n
    # Newton's error a thousandth of the step's tolerance: tighter buys nothing (the
    # prescribed model conserves no momentum whose drift would add up), looser would bias the
    # estimate
    doubling = DoublingLoop(
        system.kernel_data(), n,
        newton_settings(max(NEWTON_TOL, 1e-3 * rtol), NEWTON_MAX,
                        ROUND_OFF * system.max_frequency**2, False),
        step_control(np.zeros(n), rtol, atol, RATE_FLOOR * system.max_frequency))

    breaks = input_breakpoints(system.chain.joints, system.actuators)
    if loop is not None:
        loop.start()
        breaks = np.union1d(breaks, loop.grid)
    held = np.zeros(n)  # the actuators' forces B V of the held voltages
    sample = [0]  # the next sample instant of the loop's grid
    eps = 1e-12 * max(1.0, t_end)

    def advance(t0: float, H: float, count: int, q0: np.ndarray, v0: np.ndarray,
                X: np.ndarray, h_prev: float, new_step: bool) -> Batch:
        inputs = system.node_inputs(
            (t0 + H * (np.arange(count)[:, None] + DOUBLING_STAGES[None, :])).ravel())
        load = inputs.load
        if loop is not None:
            while sample[0] < loop.grid.size - 1 and loop.grid[sample[0]] <= t0 + eps:
                loop.check_bounded(system, t0, q0)
                held[:] = system.actuator_B @ loop.update(sample[0], q0)
                sample[0] += 1
            load = np.repeat(held[None, :], load.shape[0], axis=0)
        return doubling.batch(inputs.stage_inputs(load), q0, v0, X, h_prev, H, count,
                              new_step)

    q0, v0 = system.initial_coordinates(), np.zeros(n)
    X = np.repeat(system.accelerations(np.zeros(1), q0[None], v0[None]), 2, axis=0)
    try:
        record = step_doubling(advance, q0, v0, X, t_end, breaks, FIRST_STEP,
                               doubling.control, on_progress)
    except SimulationError as exc:
        if loop is None or isinstance(exc, UnstableLoop):
            raise
        raise SimulationError(f"closed loop unstable: {exc}") from None  # the steps collapsed
    if not (np.all(np.isfinite(record.y)) and np.all(np.isfinite(record.v))):
        raise SimulationError("the nonlinear integration produced non-finite values")
    if loop is not None:
        loop.check_bounded(system, t_end, record.y[-1])
        loop.update(loop.grid.size - 1, record.y[-1])  # the records at t_end
    return record
