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
def radau_reverse(h, coef, coef2, J, P, gy0, gz, gy1, W, lam_end, lam, nu, n, G, rhs, x, tmp):
    """The reverse pass over S steps of sizes h (S,) with the Radau IIA coefficients coef
    (3, 3) (coef2 = coef @ coef), the stage Jacobians J (S, 3, m, m) of states
    [p (nu), ṗ, z (n), ż, integrals] (rows of p and z: the identity into their rates) and
    the projection's Jacobians P (S, m, m; (0, m, m) if the run does not project). Seeds:
    ∂J/∂(step start) gy0 (S, m), ∂J/∂(stage increments) gz (S, 3, m) and ∂J/∂(step end,
    projected) gy1 (S, m) from the outputs the steps' dense output gives. lam (m,): on
    entry the adjoint of the last step's end from the steps after it (zero at a run's
    end), on exit that of the first step's start (the steps may be a run's in consecutive
    pieces, last first). Writes the stage weights W (S, 3, m) and the adjoint of each
    step's projected end lam_end (S, m). Scratch: G (3r, 3r), rhs (3m,), x (3r,), tmp (m,),
    r = m − nu − n.

    Gᵀν = g with w_j = h Σ_i a_ij ν_i reads w_j = h Σ_i a_ij (g_i + J_iᵀ w_i); a
    coordinate's row of J_i is the identity into its rate, so w's coordinate entries follow
    from its rate and integral entries (w_j[c] = h Σ_l a_lj (g_l[c] + Σ_R J_l[R, c] w_l[R])),
    which one solve of 3r unknowns gives."""
    S = h.size
    m = lam.size
    r = m - nu - n
    projected = P.shape[0] > 0
    for s in range(S - 1, -1, -1):
        for i in range(m):
            lam[i] += gy1[s, i]
            lam_end[s, i] = lam[i]
        if projected:  # λ of the unprojected end: Pᵀ λ
            for i in range(m):
                acc = 0.0
                for k in range(m):
                    acc += P[s, k, i] * lam[k]
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
        h2 = hs * hs
        # the system in w's rate and integral entries (index bi over them: b the state
        # index, c its coordinate's or −1)
        for j in range(3):
            for bi in range(r):
                b = nu + bi if bi < nu else nu + n + bi
                c = bi if bi < nu else (nu + bi if bi < nu + n else -1)
                row = j * r + bi
                acc = 0.0
                for i in range(3):
                    acc += coef[i, j] * rhs[i * m + b]
                acc *= hs
                if c >= 0:
                    acc2 = 0.0
                    for i in range(3):
                        acc2 += coef2[i, j] * rhs[i * m + c]
                    acc += h2 * acc2
                x[row] = acc
                for i in range(3):
                    f = hs * coef[i, j]
                    f2 = h2 * coef2[i, j]
                    for ci in range(r):
                        e = nu + ci if ci < nu else nu + n + ci
                        v = -f * J[s, i, e, b]
                        if c >= 0:
                            v -= f2 * J[s, i, e, c]
                        G[row, i * r + ci] = v
                G[row, row] += 1.0
        _solve(G, x)
        for j in range(3):
            for bi in range(r):
                b = nu + bi if bi < nu else nu + n + bi
                W[s, j, b] = x[j * r + bi]
            for ci in range(nu + n):  # the coordinates' entries from the rest
                c = ci if ci < nu else nu + ci
                acc = 0.0
                for i in range(3):
                    v = rhs[i * m + c]
                    for ei in range(r):
                        e = nu + ei if ei < nu else nu + n + ei
                        v += J[s, i, e, c] * x[i * r + ei]
                    acc += coef[i, j] * v
                W[s, j, c] = hs * acc
        for j in range(3):  # λ_y0 += J_jᵀ w_j
            for a in range(m):
                w = W[s, j, a]
                if w != 0.0:
                    for b in range(m):
                        lam[b] += J[s, j, a, b] * w
