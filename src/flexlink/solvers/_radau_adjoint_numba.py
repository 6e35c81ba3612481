"""Compiled (numba) reverse pass of a Radau IIA run's accepted steps (``radau_adjoint.py``).

The forward tangent of a step (`radau_sensitivity.radau_tangent`) solves, with the exact
Jacobian J_j at each converged stage,

    G dz = (hA ⊗ I)(diag(J_j)(1 ⊗ dy0) + ∂f/∂p),   G = I − (hA ⊗ I) diag(J_j),
    dy1 = P (dy0 + dz_3) + c   (P, c: the projection's derivative, if the run projects).

Read backwards, one adjoint λ = ∂J/∂y of a scalar J replaces the tangents of all
parameters: per step one solve with Gᵀ, and the stage weights w_j = h Σ_i a_ij ν_i
(ν = G⁻ᵀ λ_dz) with which ∂f/∂p at stage j enters J (the caller contracts them once with
every field's ∂f/∂p).
"""

from __future__ import annotations

from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ..dynamics._forward_numba import _solve


@njit(cache=True, _nrt=False, error_model="numpy")
def radau_reverse(h, coef, J, P, gy0, gz, gy1, W, lam_end, lam, G, rhs, tmp):
    """The reverse pass over S steps of sizes h (S,) with the Radau IIA coefficients coef
    (3, 3), the stage Jacobians J (S, 3, m, m) and the projection's Jacobians P (S, m, m;
    (0, m, m) if the run does not project). Seeds: ∂J/∂(step start) gy0 (S, m), ∂J/∂(stage
    increments) gz (S, 3, m) and ∂J/∂(step end, projected) gy1 (S, m) from the outputs the
    steps' dense output gives. lam (m,): on entry the adjoint of the last step's end from
    the steps after it (zero at a run's end), on exit that of the first step's start (the
    steps may be a run's in consecutive pieces, last first). Writes the stage weights W
    (S, 3, m) and the adjoint of each step's projected end lam_end (S, m). Scratch: G
    (3m, 3m), rhs (3m,), tmp (m,)."""
    S = h.size
    m = lam.size
    projected = P.shape[0] > 0
    for s in range(S - 1, -1, -1):
        for i in range(m):
            lam[i] += gy1[s, i]
            lam_end[s, i] = lam[i]
        if projected:  # λ of the unprojected end: Pᵀ λ
            for i in range(m):
                acc = 0.0
                for r in range(m):
                    acc += P[s, r, i] * lam[r]
                tmp[i] = acc
        else:
            for i in range(m):
                tmp[i] = lam[i]
        for k in range(3):
            for i in range(m):
                rhs[k * m + i] = gz[s, k, i]
        for i in range(m):
            rhs[2 * m + i] += tmp[i]  # y1 = y0 + z_3
            lam[i] = tmp[i] + gy0[s, i]
        hs = h[s]
        for j in range(3):  # Gᵀ[(j, b), (i, a)] = δ − h a_ij J_j[a, b]
            for a in range(m):
                for i in range(3):
                    f = hs * coef[i, j]
                    for b in range(m):
                        G[j * m + b, i * m + a] = -f * J[s, j, a, b]
        for r in range(3 * m):
            G[r, r] += 1.0
        _solve(G, rhs)
        for j in range(3):
            for b in range(m):
                acc = 0.0
                for i in range(3):
                    acc += coef[i, j] * rhs[i * m + b]
                W[s, j, b] = hs * acc
        for j in range(3):  # λ_y0 += J_jᵀ w_j
            for a in range(m):
                w = W[s, j, a]
                if w != 0.0:
                    for b in range(m):
                        lam[b] += J[s, j, a, b] * w
