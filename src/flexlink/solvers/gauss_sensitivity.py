"""Forward sensitivities of a Gauss collocation run (`gauss.py`, `gauss_forward.py`): the
derivative, in model parameters p, of what the run computed on its own accepted steps.

The run keeps its step ends (t, y, ẏ); an adaptive step H is two Gauss steps of H/2 (step
doubling keeps them), a uniform step one. `replay` takes each accepted step again from its
recorded start (the compiled Newton, tight tolerance) to recover each Gauss step's
converged stage accelerations X_i; the replayed ends agree with the recorded ones to the
run's Newton tolerance. A Gauss step of h from (y0, v0) with stage positions
Q_i = y0 + c_i h v0 + h² Σ (a²)_ij X_j and rates V_i = v0 + h Σ a_ij X_j solves
R(Q_i, V_i, X_i; p) = 0. Held at the run's steps, its derivative solves, per Gauss step, one
linear system with the residual's Jacobians at each stage (not the run's frozen Newton
matrix):

    Σ_j (δ_ij R_X,i + h² (a²)_ij R_Q,i + h a_ij R_V,i) dX_j
        = −(R_Q,i (dy0 + c_i h dv0) + R_V,i dv0 + ∂R/∂p(stage i)),
    dy1 = dy0 + h dv0 + h² Σ (bᵀa)_j dX_j,   dv1 = dv0 + h Σ b_j dX_j,

for every parameter at once. The Jacobians are analytic for the model with every joint
prescribed (`prescribed_jacobians`), else central differences of the compiled residual
(`radau_sensitivity.stage_jacobians`, the differences the Radau IIA tangent takes, ~1e-10
relative), so the derivative equals the exact derivative of the computed run up to those
and the run's Newton residual, and approaches the continuous sensitivity as the run's
tolerance does.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from .gauss_steps import GAUSS2, NODES, NewtonSettings
from .radau_sensitivity import CHUNK, stage_jacobians

# stage_inputs(times (b,)) → the model's StageInputs rows there
StageRows = Callable[[np.ndarray], Any]
# forcing(stage rows (b,) of the replayed steps, Q, V, X (b, n)) → ∂R/∂p (b, n, K)
Forcing = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
# jacobians(stage rows (b,), Q, V, X (b, n)) → ∂R/∂Q, ∂R/∂V, ∂R/∂X (b, n, n) each
Jacobians = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
                     tuple[np.ndarray, np.ndarray, np.ndarray]]

REPLAY_TOL = 1e-12  # Newton's tolerance of the replay, relative to the stage accelerations
REPLAY_MAX = 50


@dataclass(frozen=True)
class GaussSteps:
    """A run's Gauss steps (G of them, ``parts`` per accepted step): start times t (G,) and
    steps h (G,) in s, start states y, v (G, n), converged stage accelerations X (G, 2, n),
    their stage input rows ``rows`` (2G rows, a StageInputs); ``mismatch``: the largest
    difference between a replayed accepted step's end and the recorded one, relative to the
    largest |y| (|ẏ|) of the run."""

    t: np.ndarray
    h: np.ndarray
    y: np.ndarray
    v: np.ndarray
    X: np.ndarray
    parts: int
    rows: Any
    mismatch: float

    def stages(self) -> tuple[np.ndarray, np.ndarray]:
        """Stage positions Q and rates V (G, 2, n)."""
        c, a, a2 = GAUSS2.nodes, GAUSS2.coeffs, GAUSS2.coeffs2
        h = self.h[:, None, None]
        V = self.v[:, None, :] + h * np.einsum("ij,gjn->gin", a, self.X)
        Q = (self.y[:, None, :] + (c[None, :, None] * h) * self.v[:, None, :]
             + h**2 * np.einsum("ij,gjn->gin", a2, self.X))
        return Q, V


def replay(data: Any, stage_inputs: StageRows, t_nodes: np.ndarray, y: np.ndarray,
           v: np.ndarray, parts: int, newton: NewtonSettings) -> GaussSteps:
    """The Gauss steps of a run whose accepted steps end at t_nodes (S+1,) with states y, v
    (S+1, n) there (`gauss.solve_nonlinear`'s ``step_ends``), each taken again from its
    recorded start with the compiled Newton (``newton``: the run's settings, tolerance
    REPLAY_TOL)."""
    from ._gauss_numba import residual_model
    from ._gauss_sensitivity_numba import replay as compiled_replay

    S, n = t_nodes.size - 1, y.shape[1]
    H = np.diff(t_nodes)
    G = S * parts
    h = np.repeat(H / parts, parts)
    t = np.repeat(t_nodes[:-1], parts) + np.tile(np.arange(parts), S) * h
    rows = stage_inputs((t[:, None] + NODES[None, :] * h[:, None]).ravel())
    starts_y, starts_v = np.empty((G, n)), np.empty((G, n))
    X = np.empty((G, 2, n))
    ends_y, ends_v = np.empty((S, n)), np.empty((S, n))
    tight = newton._replace(tol=REPLAY_TOL, max_iterations=REPLAY_MAX)
    failed = compiled_replay(residual_model(data), rows, np.ascontiguousarray(y[:-1]),
                             np.ascontiguousarray(v[:-1]), H, parts, GAUSS2, tight, starts_y,
                             starts_v, X, ends_y, ends_v)
    if failed >= 0:
        raise ValueError(f"the replay of the Gauss step at t = {t[failed]:.4g} s did not "
                         "converge")
    scale_y = max(float(np.abs(y).max(initial=0.0)), 1e-300)
    scale_v = max(float(np.abs(v).max(initial=0.0)), 1e-300)
    mismatch = max(float(np.abs(ends_y - y[1:]).max(initial=0.0)) / scale_y,
                   float(np.abs(ends_v - v[1:]).max(initial=0.0)) / scale_v)
    return GaussSteps(t, h, starts_y, starts_v, X, parts, rows, mismatch)


def residual_function(data: Any, rows: Any) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """R(u, Y) (b, n) of the model at stage rows u (b, 1) (float row numbers of ``rows``)
    and arguments Y = [Q, V, X] (b, 3n): the form `stage_jacobians` differentiates."""
    from ._gauss_numba import residual_model
    from ._gauss_sensitivity_numba import residuals

    model = residual_model(data)  # (data stays alive with this closure)

    def residual(u: np.ndarray, Y: np.ndarray) -> np.ndarray:
        n = Y.shape[1] // 3
        out = np.empty((Y.shape[0], n))
        c = np.ascontiguousarray
        residuals(model, rows, u[:, 0].astype(np.int64), c(Y[:, :n]), c(Y[:, n:2 * n]),
                  c(Y[:, 2 * n:]), out)
        return out
    return residual


def difference_jacobians(data: Any, rows: Any) -> Jacobians:
    """R_Q, R_V, R_X of the model by central differences of its compiled residual
    (`stage_jacobians`): any nonlinear model."""
    residual = residual_function(data, rows)

    def jacobians(index: np.ndarray, Q: np.ndarray, V: np.ndarray, X: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        n = Q.shape[1]
        J = stage_jacobians(residual, index[:, None].astype(float),
                            np.concatenate([Q, V, X], axis=1))
        return J[..., :n], J[..., n:2 * n], J[..., 2 * n:]
    return jacobians


def prescribed_jacobians(data: Any, rows: Any) -> Jacobians | None:
    """R_Q, R_V, R_X of the model with every joint prescribed, analytic
    (`_gauss_sensitivity_numba.prescribed_jacobians`), or None for a model they do not
    cover (sliders, a moving base: `difference_jacobians`)."""
    if data.translation or data.cart or data.line_node.size or data.nu:
        return None
    from ._gauss_sensitivity_numba import prescribed_jacobians as compiled

    def jacobians(index: np.ndarray, Q: np.ndarray, V: np.ndarray, X: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        b, n = Q.shape
        RQ, RV, RX = np.empty((b, n, n)), np.empty((b, n, n)), np.empty((b, n, n))
        c = np.ascontiguousarray
        compiled(data, rows, index.astype(np.int64), c(Q), c(V), c(X), RQ, RV, RX)
        return RQ, RV, RX
    return jacobians


def gauss_tangent(steps: GaussSteps, data: Any, forcing: Forcing, dy0: np.ndarray,
                  dv0: np.ndarray, jacobians: Jacobians | None = None
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The derivatives of the accepted steps' end states dy, dv (S+1, n, K) (row 0 the
    start: dy0, dv0 (n, K)) in K parameters; ``forcing``: ∂R/∂p at the stages;
    ``jacobians``: R_Q, R_V, R_X at the stages (default: `difference_jacobians`)."""
    G, _, n = steps.X.shape
    K = dy0.shape[1]
    a, a2 = GAUSS2.coeffs, GAUSS2.coeffs2
    b, w2 = GAUSS2.weights, GAUSS2.weights2
    if jacobians is None:
        jacobians = difference_jacobians(data, steps.rows)
    Q, V = steps.stages()
    S = G // steps.parts
    out_y, out_v = np.empty((S + 1, n, K)), np.empty((S + 1, n, K))
    out_y[0], out_v[0] = dy0, dv0
    dY = np.concatenate([dy0, dv0])  # (2n, K)
    eye = np.eye(n)
    for lo in range(0, G, CHUNK):
        hi = min(G, lo + CHUNK)
        m = hi - lo
        index = np.arange(2 * lo, 2 * hi, dtype=np.int64)
        stage = (Q[lo:hi].reshape(-1, n), V[lo:hi].reshape(-1, n),
                 steps.X[lo:hi].reshape(-1, n))
        RQ, RV, RX = (J.reshape(m, 2, n, n) for J in jacobians(index, *stage))
        Rp = forcing(index, *stage).reshape(m, 2, n, K)
        h = steps.h[lo:hi, None, None, None, None]
        M = (np.eye(2)[None, :, None, :, None] * RX[:, :, :, None, :]
             + h**2 * a2[None, :, None, :, None] * RQ[:, :, :, None, :]
             + h * a[None, :, None, :, None] * RV[:, :, :, None, :]).reshape(m, 2 * n, 2 * n)
        ch = (GAUSS2.nodes[None, :, None, None] * steps.h[lo:hi, None, None, None])
        rhs = -np.concatenate([RQ, ch * RQ + RV, Rp], axis=3).reshape(m, 2 * n, 2 * n + K)
        dX = np.linalg.solve(M, rhs).reshape(m, 2, n, 2 * n + K)  # dX = Φ dY0 + Ψ
        hs = steps.h[lo:hi, None, None]
        # [dy1; dv1] = E dY0 + F dX, E = [[I, h I], [0, I]]
        T = np.zeros((m, 2 * n, 2 * n + K))
        T[:, :n, :n] = eye
        T[:, :n, n:2 * n] = hs * eye
        T[:, n:2 * n, n:2 * n] = eye
        T[:, :n] += hs**2 * np.einsum("j,sjnc->snc", w2, dX)
        T[:, n:] += hs * np.einsum("j,sjnc->snc", b, dX)
        for s in range(m):
            dY = T[s, :, :2 * n] @ dY + T[s, :, 2 * n:]
            g = lo + s + 1
            if g % steps.parts == 0:
                out_y[g // steps.parts], out_v[g // steps.parts] = dY[:n], dY[n:]
    return out_y, out_v
