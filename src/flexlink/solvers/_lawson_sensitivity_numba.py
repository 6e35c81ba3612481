"""Compiled (numba) tangent of the Lawson step loop (``lawson_sensitivity.py``).

Along the state y = [z, ż, 1] of `_lawson_numba.lawson_blocks` (fine pass only), the
derivatives s_k = ∂y/∂p_k of K parameters, each step being the exact derivative of the
Lawson step of the run on a fixed discretisation (block propagators E = exp(h/2 Ã_ref) with
the reference Ã_ref held, ΔÃ = A(t) − Ã_ref from the table): the same step on s_k with the
stage slopes k_i = ΔÃ(t_i) s_stage + ∂A/∂p_k(t_i) y_stage, where y_stage are the stages of y
(module docstring of lawson.py). All matrices are passed transposed, as in _lawson_numba. ∂A/∂p_k is evaluated from its table
twice per step (middle and end; the end is the next step's start).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._lawson_numba import ADD, FIRST, SET, _delta, _gemv, _gemv2


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _many(PT, j0, nj, X, scale, out, accumulate):
    """out[k] (+)= scale · P[:, j0:j0+nj] X[k, :nj] for every row k of X, from Pᵀ: one pass
    over the matrix for all K vectors."""
    K, m = out.shape
    if not accumulate:
        for k in range(K):
            for i in range(m):
                out[k, i] = 0.0
    for q in range(nj):
        row = PT[j0 + q]
        for k in range(K):
            x = scale * X[k, q]
            for i in range(m):
                out[k, i] += row[i] * x


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _slopes(DT, S, F, out):
    """out[k] = ΔÃ S[k] + F[k] (ΔÃ given transposed, (m, n))."""
    K, n = out.shape
    m = S.shape[1]
    for k in range(K):
        for i in range(n):
            out[k, i] = F[k, i]
    for j in range(m):
        row = DT[j]
        for k in range(K):
            x = S[k, j]
            for i in range(n):
                out[k, i] += row[i] * x


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _stages(P, P2, D0, Dm, De, h, y, k1, k2, k3, k4, Ey, E2y, a, b, c, out):
    """One Lawson step from y: its stage states a = Ey + h/2 E k₁, b = Ey + h/2 k₂,
    c = E²y + h E k₃, slopes k1 … k4 (k2 then holds k₂ + k₃) and
    y⁺ = E²y + h/6 E² k₁ + h/3 E (k₂ + k₃) + h/6 k₄ in ``out``."""
    m = y.shape[0]
    n = k1.shape[0]
    _gemv(D0, FIRST, m, y, 1.0, k1, SET)
    _gemv(P, FIRST, m, y, 1.0, Ey, SET)
    _gemv(P2, FIRST, m, y, 1.0, E2y, SET)
    for q in range(m):
        a[q] = Ey[q]
    _gemv(P, n, n, k1, 0.5 * h, a, ADD)
    _gemv(Dm, FIRST, m, a, 1.0, k2, SET)
    for q in range(m):
        b[q] = Ey[q]
    for q in range(n):
        b[n + q] += 0.5 * h * k2[q]
    _gemv(Dm, FIRST, m, b, 1.0, k3, SET)
    for q in range(m):
        c[q] = E2y[q]
    _gemv(P, n, n, k3, h, c, ADD)
    _gemv(De, FIRST, m, c, 1.0, k4, SET)
    for q in range(m):
        out[q] = E2y[q]
    _gemv(P2, n, n, k1, h / 6.0, out, ADD)
    for q in range(n):
        k2[q] += k3[q]  # k2 + k3, the combination y⁺ reads
    _gemv(P, n, n, k2, h / 3.0, out, ADD)
    for q in range(n):
        out[n + q] += h / 6.0 * k4[q]


@njit(cache=True, error_model="numpy")
def lawson_tangent_blocks(t_out, first, last, static, pieces, lower, upper, polyT, dpolyT,
                          referenceT, ET, E2T, PdT, substeps, states, accelerations, dstates,
                          daccelerations):
    """Advance y and the K tangents S (K, m) through the blocks, from y = [0, 0, 1], S = 0.

    ``polyT``: the table of A (pieces, degree+1, m, n); ``dpolyT``: the tables of all K
    ∂A/∂p_k side by side (pieces, degree+1, m, K·n: column k·n + i is row i of ∂A/∂p_k), so
    that one Horner pass and one matrix-vector product per stage serve every parameter over
    long contiguous rows;
    ``ET``/``E2T``: exp(h/2 Ã_ref)ᵀ and its square on moving blocks, exp(Δt Ã)ᵀ on static
    blocks (E2T unused there); ``PdT[k, b]``: on a static block the derivative of its
    propagator in p_k (transposed). Writes y and S at every output index into ``states``
    (nt, m) and ``dstates`` (K, nt, m), z̈ and ∂z̈/∂p_k on moving blocks into
    ``accelerations`` (nt, n) and ``daccelerations`` (K, nt, n) (static blocks' are A y and
    A s + ∂A/∂p y, which the caller sets)."""
    m = states.shape[1]
    n = (m - 1) // 2
    K = dstates.shape[0]
    y = np.zeros(m)
    y[m - 1] = 1.0
    S = np.zeros((K, m))
    for q in range(m):
        states[0, q] = y[q]
    zeroT = np.zeros((m, K * n))
    D0, Dm, De = np.empty((m, n)), np.empty((m, n)), np.empty((m, n))
    dA0, dAm, dAe = np.empty((m, K * n)), np.empty((m, K * n)), np.empty((m, K * n))
    k1, k2, k3, k4 = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    Ey, E2y, a, b, c, w, r = (np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m),
                              np.empty(m), np.empty(m))
    Fa, Fb = np.empty(K * n), np.empty(K * n)
    F, F2 = Fa.reshape((K, n)), Fb.reshape((K, n))  # views: (K, n) of the flat products
    G1, G2, G3, G4 = np.empty((K, n)), np.empty((K, n)), np.empty((K, n)), np.empty((K, n))
    ES, E2S, SA, SB, SC, SW = (np.empty((K, m)), np.empty((K, m)), np.empty((K, m)),
                               np.empty((K, m)), np.empty((K, m)), np.empty((K, m)))
    for blk in range(first.size):
        i0, i1 = first[blk], last[blk]
        P, P2 = ET[blk], E2T[blk]
        if static[blk]:
            for i in range(i0, i1):
                _many(P, FIRST, m, S, 1.0, SW, SET)
                for k in range(K):
                    _gemv(PdT[k, blk], FIRST, m, y, 1.0, r, SET)
                    for q in range(m):
                        SW[k, q] += r[q]
                _gemv(P, FIRST, m, y, 1.0, w, SET)
                for q in range(m):
                    y[q] = w[q]
                    states[i + 1, q] = y[q]
                for k in range(K):
                    for q in range(m):
                        S[k, q] = SW[k, q]
                        dstates[k, i + 1, q] = S[k, q]
            continue
        A_ref = referenceT[blk]
        span = t_out[i1] - t_out[i0]
        p0, p1 = pieces[blk], pieces[blk + 1]
        _delta(polyT, lower, upper, p0, p1, A_ref, 0.0, De)
        _delta(dpolyT, lower, upper, p0, p1, zeroT, 0.0, dAe)
        for i in range(i0, i1):
            h = (t_out[i + 1] - t_out[i]) / substeps
            dtau = h / span
            for j in range(substeps):
                tau = (t_out[i] - t_out[i0] + j * h) / span
                D0, De = De, D0  # the last step's end is this step's start
                dA0, dAe = dAe, dA0
                _delta(polyT, lower, upper, p0, p1, A_ref, tau + 0.5 * dtau, Dm)
                _delta(polyT, lower, upper, p0, p1, A_ref, tau + dtau, De)
                _delta(dpolyT, lower, upper, p0, p1, zeroT, tau + 0.5 * dtau, dAm)
                _delta(dpolyT, lower, upper, p0, p1, zeroT, tau + dtau, dAe)
                _stages(P, P2, D0, Dm, De, h, y, k1, k2, k3, k4, Ey, E2y, a, b, c, w)
                # the tangents' stages, with the forcing ∂A/∂p at y's stages
                _gemv(dA0, FIRST, m, y, 1.0, Fa, SET)
                _slopes(D0, S, F, G1)
                _many(P, FIRST, m, S, 1.0, ES, SET)
                _many(P2, FIRST, m, S, 1.0, E2S, SET)
                for k in range(K):
                    for q in range(m):
                        SA[k, q] = ES[k, q]
                _many(P, n, n, G1, 0.5 * h, SA, ADD)
                for q in range(K * n):
                    Fa[q] = 0.0
                    Fb[q] = 0.0
                _gemv2(dAm, FIRST, m, a, 1.0, Fa, b, 1.0, Fb)  # a and b: b is known before SA
                _slopes(Dm, SA, F, G2)
                for k in range(K):
                    for q in range(m):
                        SB[k, q] = ES[k, q]
                    for q in range(n):
                        SB[k, n + q] += 0.5 * h * G2[k, q]
                _slopes(Dm, SB, F2, G3)
                for k in range(K):
                    for q in range(m):
                        SC[k, q] = E2S[k, q]
                _many(P, n, n, G3, h, SC, ADD)
                _gemv(dAe, FIRST, m, c, 1.0, Fa, SET)
                _slopes(De, SC, F, G4)
                # y⁺ (from _stages), and the same for each S
                for q in range(m):
                    y[q] = w[q]
                for k in range(K):
                    for q in range(n):
                        G2[k, q] += G3[k, q]
                    for q in range(m):
                        SW[k, q] = E2S[k, q]
                _many(P2, n, n, G1, h / 6.0, SW, ADD)
                _many(P, n, n, G2, h / 3.0, SW, ADD)
                for k in range(K):
                    for q in range(n):
                        SW[k, n + q] += h / 6.0 * G4[k, q]
                    for q in range(m):
                        S[k, q] = SW[k, q]
            # outputs: y, S and z̈ = A y, ∂z̈/∂p = A s + ∂A/∂p y at the interval's end
            for q in range(m):
                states[i + 1, q] = y[q]
            for q in range(m):  # A = Ã_ref + ΔÃ at the end of the last step
                for r_ in range(n):
                    Dm[q, r_] = De[q, r_] + A_ref[q, r_]
            _gemv(Dm, FIRST, m, y, 1.0, k4, SET)
            for q in range(n):
                accelerations[i + 1, q] = k4[q]
            _gemv(dAe, FIRST, m, y, 1.0, Fa, SET)
            _slopes(Dm, S, F, G4)
            for k in range(K):
                for q in range(m):
                    dstates[k, i + 1, q] = S[k, q]
                for q in range(n):
                    daccelerations[k, i + 1, q] = G4[k, q]
