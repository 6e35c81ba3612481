"""Compiled (numba) reverse pass of the Lawson step loop (``lawson_adjoint.py``).

The run's fine steps on a fixed discretisation (`_lawson_sensitivity_numba` gives their
tangent) read backwards: one adjoint state λ = ∂J/∂y for a scalar J of the outputs, and,
instead of a tangent per parameter, the weights with which ∂A/∂p enters J. A stage slope
k_i = ΔÃ(τ_i) s_i + ∂A/∂p(τ_i) y_i contributes κ_iᵀ ∂A/∂p(τ_i) y_i (κ_i: the stage's
adjoint), so J's derivative in every parameter is ⟨∂A/∂p, X⟩ summed over the instants the
table is read at, X = Σ κ_i y_iᵀ. ∂A/∂p is the table's polynomial in the piece's local time
(the same piece and local time as the forward steps read), so those sums collapse onto the
monomials of each piece: G[p, d] = Σ local^d X, (pieces, degree+1, n, 2n+1), whatever the
number of parameters. Static blocks (y⁺ = P y, P = exp(Δt Ã)) keep W = Σ λ⁺ yᵀ, whose
pairing with the Fréchet derivative of P the caller forms once per block. Matrices are
passed transposed, as in _lawson_numba.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._lawson_numba import ADD, FIRST, SET, _delta, _gemv, _piece
from ._lawson_sensitivity_numba import _stages


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _dots(PT, j0, nj, x, scale, out, accumulate):
    """out[q] (+)= scale · (P[:, j0+q] · x) for q < nj, from Pᵀ: products with Pᵀ (the
    adjoint of _gemv's). Four rows of Pᵀ per pass: four independent sums in flight instead
    of one chain of additions."""
    m = PT.shape[1]
    q = 0
    while q + 4 <= nj:
        r0, r1, r2, r3 = PT[j0 + q], PT[j0 + q + 1], PT[j0 + q + 2], PT[j0 + q + 3]
        s0 = s1 = s2 = s3 = 0.0
        for i in range(m):
            xi = x[i]
            s0 += r0[i] * xi
            s1 += r1[i] * xi
            s2 += r2[i] * xi
            s3 += r3[i] * xi
        if accumulate:
            out[q] += scale * s0
            out[q + 1] += scale * s1
            out[q + 2] += scale * s2
            out[q + 3] += scale * s3
        else:
            out[q], out[q + 1], out[q + 2], out[q + 3] = (scale * s0, scale * s1, scale * s2,
                                                          scale * s3)
        q += 4
    while q < nj:
        row = PT[j0 + q]
        s = 0.0
        for i in range(m):
            s += row[i] * x[i]
        if accumulate:
            out[q] += scale * s
        else:
            out[q] = scale * s
        q += 1


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _outer(X, u, v):
    """X += u vᵀ."""
    for i in range(u.shape[0]):
        ui = u[i]
        row = X[i]
        for j in range(v.shape[0]):
            row[j] += ui * v[j]


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _spread(G, lower, upper, p0, p1, tau, X):
    """G[p, d] += local^d X at the block's local time τ (piece and local time as _delta
    reads them), and X ← 0."""
    p, local = _piece(lower, upper, p0, p1, tau)
    n, m = X.shape
    power = 1.0
    for d in range(G.shape[1]):
        Gd = G[p, d]
        for i in range(n):
            for j in range(m):
                Gd[i, j] += power * X[i, j]
        power *= local
    for i in range(n):
        for j in range(m):
            X[i, j] = 0.0


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _start_tau(t_out, i0, i, j, substeps, span):
    """The local time of step j of interval i as the forward loop read it: 0 at the
    block's first step, else the previous step's end (tau + dtau of that step)."""
    if i == i0 and j == 0:
        return 0.0
    if j > 0:
        h = (t_out[i + 1] - t_out[i]) / substeps
        return (t_out[i] - t_out[i0] + (j - 1) * h) / span + h / span
    h = (t_out[i] - t_out[i - 1]) / substeps
    return (t_out[i - 1] - t_out[i0] + (substeps - 1) * h) / span + h / span


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _forward(t_out, first, last, static, pieces, lower, upper, polyT, referenceT, ET, E2T,
             substeps, states, ys):
    """The forward fine steps from y = [0, 0, 1] (`_lawson_sensitivity_numba._stages`):
    y at the output indices into ``states`` (nt, m), at every step's start on the moving
    blocks but an output interval's first into ``ys`` (`lawson.RunSteps.starts`)."""
    m = states.shape[1]
    n = (m - 1) // 2
    s = 0
    y = np.zeros(m)
    y[m - 1] = 1.0
    for q in range(m):
        states[0, q] = y[q]
    D0, Dm, De = np.empty((m, n)), np.empty((m, n)), np.empty((m, n))
    k1, k2, k3, k4 = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    Ey, E2y, a, b, c, w = (np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m),
                           np.empty(m))
    for blk in range(first.size):
        i0, i1 = first[blk], last[blk]
        P, P2 = ET[blk], E2T[blk]
        if static[blk]:
            for i in range(i0, i1):
                _gemv(P, FIRST, m, y, 1.0, w, SET)
                for q in range(m):
                    y[q] = w[q]
                    states[i + 1, q] = y[q]
            continue
        A_ref = referenceT[blk]
        span = t_out[i1] - t_out[i0]
        p0, p1 = pieces[blk], pieces[blk + 1]
        _delta(polyT, lower, upper, p0, p1, A_ref, 0.0, De)
        for i in range(i0, i1):
            h = (t_out[i + 1] - t_out[i]) / substeps
            dtau = h / span
            for j in range(substeps):
                tau = (t_out[i] - t_out[i0] + j * h) / span
                D0, De = De, D0
                _delta(polyT, lower, upper, p0, p1, A_ref, tau + 0.5 * dtau, Dm)
                _delta(polyT, lower, upper, p0, p1, A_ref, tau + dtau, De)
                if j > 0:
                    for q in range(m):
                        ys[s, q] = y[q]
                    s += 1
                _stages(P, P2, D0, Dm, De, h, y, k1, k2, k3, k4, Ey, E2y, a, b, c, w)
                for q in range(m):
                    y[q] = w[q]
            for q in range(m):
                states[i + 1, q] = y[q]


@njit(cache=True, error_model="numpy")
def lawson_adjoint_blocks(t_out, first, last, static, pieces, lower, upper, polyT, referenceT,
                          ET, E2T, substeps, seed_y, seed_acc, G, Gs, W, states, ys, forward):
    """The reverse pass of the fine Lawson steps from y = [0, 0, 1] for J with
    ∂J/∂y_i = ``seed_y`` (nt, m) and ∂J/∂z̈_i = ``seed_acc`` (nt, n) at the output indices
    i ≥ 1. Accumulates the weights of ∂A/∂p: ``G`` (pieces, degree+1, n, m) on moving
    blocks (module docstring), ``Gs`` (blocks, n, m) Σ seed_acc yᵀ on static blocks, and
    ``W`` (blocks, m, m) Σ λ_{i+1} y_iᵀ on static blocks (the weight of their propagators'
    derivative). Reads the run's states y at the output indices (``states``, (nt, m)) and
    at the start of every other fine step on the moving blocks (``ys``,
    `lawson.RunSteps.starts`); with ``forward`` it first computes both by the forward
    steps."""
    m = seed_y.shape[1]
    n = (m - 1) // 2
    if forward:
        _forward(t_out, first, last, static, pieces, lower, upper, polyT, referenceT, ET, E2T,
                 substeps, states, ys)
    s = ys.shape[0]
    D0, Dm, De = np.empty((m, n)), np.empty((m, n)), np.empty((m, n))
    k1, k2, k3, k4 = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    Ey, E2y, a, b, c, w = (np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m),
                           np.empty(m))
    # backward
    lam = np.zeros(m)
    yb = np.empty(m)
    Eyb, E2yb, ab, bb, cb = np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    k1b, k2b, k3b, k4b = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    Xe, Xm, X0 = np.zeros((n, m)), np.zeros((n, m)), np.zeros((n, m))
    u = np.empty(n)
    for blk in range(first.size - 1, -1, -1):
        i0, i1 = first[blk], last[blk]
        P, P2 = ET[blk], E2T[blk]
        A_ref = referenceT[blk]
        if static[blk]:
            for i in range(i1 - 1, i0 - 1, -1):
                for q in range(n):
                    u[q] = seed_acc[i + 1, q]
                for q in range(m):
                    lam[q] += seed_y[i + 1, q]
                _dots(A_ref, FIRST, m, u, 1.0, lam, ADD)  # z̈ = A y
                _outer(Gs[blk], u, states[i + 1])
                _outer(W[blk], lam, states[i])
                _dots(P, FIRST, m, lam, 1.0, w, SET)
                for q in range(m):
                    lam[q] = w[q]
            continue
        span = t_out[i1] - t_out[i0]
        p0, p1 = pieces[blk], pieces[blk + 1]
        # ΔÃ at the block's last step's end; further back, a step's end is the start of the
        # step after it, which the pass has just read (the same local time, as forward)
        h = (t_out[i1] - t_out[i1 - 1]) / substeps
        tau_end = (t_out[i1 - 1] - t_out[i0] + (substeps - 1) * h) / span + h / span
        _delta(polyT, lower, upper, p0, p1, A_ref, tau_end, De)
        for i in range(i1 - 1, i0 - 1, -1):
            h = (t_out[i + 1] - t_out[i]) / substeps
            dtau = h / span
            # the output at i + 1: y and z̈ = (Ã_ref + ΔÃ(end)) y
            for q in range(n):
                u[q] = seed_acc[i + 1, q]
            for q in range(m):
                lam[q] += seed_y[i + 1, q]
            _dots(A_ref, FIRST, m, u, 1.0, lam, ADD)
            _dots(De, FIRST, m, u, 1.0, lam, ADD)
            _outer(Xe, u, states[i + 1])
            for j in range(substeps - 1, -1, -1):
                tau = (t_out[i] - t_out[i0] + j * h) / span
                t0 = _start_tau(t_out, i0, i, j, substeps, span)
                _delta(polyT, lower, upper, p0, p1, A_ref, t0, D0)
                _delta(polyT, lower, upper, p0, p1, A_ref, tau + 0.5 * dtau, Dm)
                if j > 0:
                    s -= 1
                    for q in range(m):
                        yb[q] = ys[s, q]
                else:  # the interval's first step starts from its output state
                    for q in range(m):
                        yb[q] = states[i, q]
                _stages(P, P2, D0, Dm, De, h, yb, k1, k2, k3, k4, Ey, E2y, a, b, c, w)
                # y⁺ = E²y + h/6 E²_v k1 + h/3 E_v (k2 + k3) + h/6 k4
                for q in range(m):
                    E2yb[q] = lam[q]
                _dots(P2, n, n, lam, h / 6.0, k1b, SET)
                _dots(P, n, n, lam, h / 3.0, k2b, SET)
                for q in range(n):
                    k3b[q] = k2b[q]
                    k4b[q] = h / 6.0 * lam[n + q]
                # k4 = ΔÃ(end) c; c = E²y + h E_v k3
                _dots(De, FIRST, m, k4b, 1.0, cb, SET)
                _outer(Xe, k4b, c)
                for q in range(m):
                    E2yb[q] += cb[q]
                _dots(P, n, n, cb, h, k3b, ADD)
                # k3 = ΔÃ(mid) b; b = Ey + h/2 (0, k2, 0)
                _dots(Dm, FIRST, m, k3b, 1.0, bb, SET)
                _outer(Xm, k3b, b)
                for q in range(m):
                    Eyb[q] = bb[q]
                for q in range(n):
                    k2b[q] += 0.5 * h * bb[n + q]
                # k2 = ΔÃ(mid) a; a = Ey + h/2 E_v k1
                _dots(Dm, FIRST, m, k2b, 1.0, ab, SET)
                _outer(Xm, k2b, a)
                for q in range(m):
                    Eyb[q] += ab[q]
                _dots(P, n, n, ab, 0.5 * h, k1b, ADD)
                # k1 = ΔÃ(start) y
                _dots(D0, FIRST, m, k1b, 1.0, lam, SET)
                _outer(X0, k1b, yb)
                _dots(P, FIRST, m, Eyb, 1.0, lam, ADD)
                _dots(P2, FIRST, m, E2yb, 1.0, lam, ADD)
                _spread(G, lower, upper, p0, p1, tau + dtau, Xe)
                _spread(G, lower, upper, p0, p1, tau + 0.5 * dtau, Xm)
                # the step's start is the previous step's end: X0 joins its Xe, D0 is its De
                D0, De = De, D0
                for q in range(n):
                    for r in range(m):
                        Xe[q, r] = X0[q, r]
                        X0[q, r] = 0.0
        _spread(G, lower, upper, p0, p1, 0.0, Xe)
