"""Two-stage Gauss–Legendre collocation for M(q, t) q̈ = f(q, q̇, t) (the nonlinear model).

Why this method: the highest modal frequencies (thousands of rad/s with 8 modes) make explicit
schemes take tiny steps, while the motion that matters is slow. Gauss collocation is A-stable,
of order 4, symmetric and symplectic: without damping and with the joints held, the energy
error stays bounded at O(h⁴) instead of drifting. Steps are uniform, so every joint angle the
run needs is evaluated in one vectorised call before the loop.

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

from ..dynamics.nonlinear import NodeInputs, NonlinearSystem
from ..errors import SimulationError
from .solution import Solution
from .threads import single_threaded

_R3 = np.sqrt(3.0) / 6.0
NODES = np.array([0.5 - _R3, 0.5 + _R3])
COEFFS = np.array([[0.25, 0.25 - _R3], [0.25 + _R3, 0.25]])
COEFFS2 = COEFFS @ COEFFS
WEIGHTS = np.array([0.5, 0.5])
WEIGHTS2 = WEIGHTS @ COEFFS  # q₁ = q₀ + h v₀ + h² Σ (bᵀa)_j X_j
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
        _compiled_loop(system, q, v, X, h, inputs, on_progress, t_ends)
        return t_ends, q, v
    newton = _Newton(system, h, floor=ROUND_OFF * system.max_frequency**2)
    with single_threaded():  # (the compiled path needs no limit: no BLAS calls)
        for i in range(steps):
            if i > 0:  # predictor: last step's stage accelerations, extrapolated linearly
                X = X + (X[1] - X[0]) / (NODES[1] - NODES[0])
            X = newton.solve(q[i], v[i], X, inputs[2 * i:2 * i + 2])
            v[i + 1] = v[i] + h * (WEIGHTS @ X)
            q[i + 1] = q[i] + h * v[i] + h**2 * (WEIGHTS2 @ X)
            if on_progress is not None and i % 50 == 0:
                on_progress(float(t_ends[i + 1]))
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
        raise SimulationError("the nonlinear integration produced non-finite values")
    return t_ends, q, v


CHUNK = 400  # steps per compiled call, between progress reports


def _compiled_loop(system: NonlinearSystem, q: np.ndarray, v: np.ndarray, X: np.ndarray,
                   h: float, inputs: NodeInputs, on_progress: Callable[[float], None] | None,
                   t_ends: np.ndarray) -> None:
    """Run the numba step loop over q, v in place, in chunks of CHUNK steps."""
    steps = q.shape[0] - 1
    from ._gauss_numba import gauss_loop  # numba loads in ~0.5 s: only when used

    arrays = system.kernel_arrays()
    w2 = system.max_frequency**2
    for start in range(0, steps, CHUNK):
        end = min(start + CHUNK, steps)
        stage = slice(2 * start, 2 * end)
        failed, _, _ = gauss_loop(
            q[start:end + 1], v[start:end + 1], X, h,
            *(np.ascontiguousarray(a[stage]) for a in (
                inputs.angle, inputs.rate, inputs.acceleration, inputs.tip_acceleration,
                inputs.load)),
            *arrays, NODES, COEFFS, COEFFS2, WEIGHTS, WEIGHTS2, NEWTON_TOL, NEWTON_MAX,
            start > 0, ROUND_OFF * w2)
        if failed >= 0:
            raise SimulationError(
                f"the nonlinear step at t = {t_ends[start + failed]:.4g} s did not converge in "
                f"{NEWTON_MAX} Newton iterations (h = {h:.3g} s): reduce the step")
        if on_progress is not None:
            on_progress(float(t_ends[end]))


class _Newton:
    """Simplified Newton for the stage accelerations. The iteration matrix (finite differences
    of the stage residuals) is kept across steps and rebuilt only when convergence slows."""

    def __init__(self, system: NonlinearSystem, h: float, tol: float = NEWTON_TOL,
                 floor: float = 0.0, elastic: int | None = None) -> None:
        """``floor`` (1/s²) · max|q| (the first ``elastic`` unknowns, default all): the
        absolute part of the stopping test, as the compiled loops' ``floor``."""
        self.system, self.h, self.tol = system, h, tol
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
            q_size = float(np.abs(q0[:self.elastic]).max(initial=0.0))
            if remaining <= self.tol * max(float(np.abs(X).max()), 1e-300) + self.floor * q_size:
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
                    t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """q, q̇, q̈ at times t from values, rates and accelerations at nodes t_nodes (uniform or
    not): the quintic Hermite interpolant and its first two derivatives (exact at the nodes)."""
    i = np.clip(np.searchsorted(t_nodes, t, side="right") - 1, 0, t_nodes.size - 2)
    h = (t_nodes[i + 1] - t_nodes[i])[:, None] if t_nodes.size > 1 else np.ones((t.size, 1))
    s = (t - t_nodes[i]) / h[:, 0]
    terms = np.stack([q[i], h * v[i], h**2 * a[i], q[i + 1], h * v[i + 1], h**2 * a[i + 1]])
    powers = s[:, None] ** np.arange(6)[None, :]  # (m, 6)
    return tuple(np.einsum("mj,jmn->mn", powers @ B.T, terms) / h**d  # type: ignore[return-value]
                 for d, B in enumerate(_HERMITE_D))


def solve_nonlinear(
    system: NonlinearSystem, t_out: np.ndarray, rtol: float, step: float | None = None,
    on_progress: Callable[[float], None] | None = None, max_halvings: int = 6,
    loop: Any = None,
) -> Solution:
    """q, q̇, q̈ at t_out (from rest at t_out[0] = 0), method "gauss", the step used (s) in
    its stats. q̈ interpolates the equations' accelerations at the step ends (the quintic's
    second derivative).

    With ``step`` given: one run at that step. Otherwise the step is halved from 10 ms until the
    error estimate of the finer solution, |difference| / 15 (fourth order), is within rtol of
    the peak |q| and of the peak |q̇| over the run (as the Magnus control; q̈, dominated by the
    high modes, converges more slowly: rtol ≤ 1e-4 for accelerometers). A step at which Newton
    fails is halved too. ``loop``: a gauss_sampled.SampledLoop — sampled controllers,
    integrated per sample interval; the first step is then at most one interval."""
    t_end = float(t_out[-1])

    def run(h: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if loop is None:
            t_nodes, q, v = integrate_gauss(system, t_end, h, on_progress)
            a = system.accelerations(t_nodes, q, v)
        else:  # sampled controllers (gauss_sampled.SampledLoop): the held forces at the ends
            t_nodes, q, v = loop.integrate(system, h, on_progress)
            a = system.accelerations(t_nodes, q, v, load=loop.held_voltages(t_nodes)
                                     @ system.actuator_B.T)
        return hermite_quintic(t_nodes, q, v, a, t_out)

    def solution(q: np.ndarray, v: np.ndarray, a: np.ndarray, h: float) -> Solution:
        return Solution(t_out, q, v, a, "gauss", {"time_step_s": h})

    if step is not None:
        return solution(*run(step), step)
    h = min(0.01, t_end)
    if loop is not None:  # a step that halves the sample intervals from the first comparison
        h = min(h, float(np.diff(loop.grid).max()))
    previous = None
    err = np.inf
    for _ in range(max_halvings + 1):
        try:
            q, v, a = run(h)
        except SimulationError as exc:  # Newton failed at this step size: halve
            if type(exc).__name__ == "LoopUnstable":
                raise
            previous = None
            h /= 2
            continue
        if previous is not None:
            # rates relative to their peak, or (a run at rest in equilibrium, whose rates
            # are round-off) to a rate floor RATE_FLOOR ω_max |q|
            floor = RATE_FLOOR * system.max_frequency * float(np.abs(q).max())
            err = max(_relative_change(previous[0], q),
                      _relative_change(previous[1], v, floor)) / 15.0
            if err <= rtol:
                return solution(q, v, a, h)
        previous = (q, v)
        h /= 2
    raise SimulationError(
        f"the nonlinear solution did not converge to rtol = {rtol:g} with steps down to "
        f"{2 * h:.3g} s (last change {err:.2g} of the peak): loosen simulation.rtol or set "
        f"simulation.step")


def _relative_change(coarse: np.ndarray, fine: np.ndarray, floor: float = 0.0) -> float:
    """Largest |fine − coarse| relative to the peak |fine| of all coordinates (as the Magnus
    control: a tolerance on the physical signals, not on tiny high-mode amplitudes), or to
    ``floor`` if larger."""
    return float(np.abs(fine - coarse).max() / max(float(np.abs(fine).max()), floor, 1e-300))
