"""Compiled (numba) Lawson step loop for several systems at once (``lawson_batch.py``): the
loop of ``_lawson_numba.py`` with a trailing variant axis on every matrix and vector.

Variants that share the output times and the steps per interval share the step h of every
output interval; each keeps its own table (blocks, pieces, polynomials), matrices and state.
The variant axis is innermost and contiguous, so each element-wise loop of the single-system
kernel becomes a loop over (entry, variant) whose inner loop runs over variants and
vectorises across them. Each variant sees the operations of its own single run in the same
order (the same four-column grouping of the sums, the same Horner sequence, no fused
multiply-adds): its states equal its single run's bit for bit (tests/unit/test_lawson_batch.py).

Only the first, Richardson-checked pass of an adaptive run is batched (fine and coarse pass
together, running maxima kept, coarse states not kept); a variant that needs shorter steps
continues alone (``lawson.finish``).
"""

from __future__ import annotations

import numpy as np
from numba import boolean, float64, int64, njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._lawson_numba import ADD, FIRST, SET

# Variants per call: a constant trip count lets LLVM unroll and vectorise each inner loop
# without a scalar remainder or run-time checks (a variable count vectorised only from about
# 32 variants on).
LANES = 32


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _copy(a, b):
    """b[:, :] = a."""
    for i in range(a.shape[0]):
        for v in range(LANES):
            b[i, v] = a[i, v]


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _zero2(a, b):
    """a[:, :] = b[:, :] = 0."""
    for i in range(a.shape[0]):
        for v in range(LANES):
            a[i, v] = 0.0
            b[i, v] = 0.0


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _add(w, n, scale, k):
    """w[n:2n] += scale · k."""
    for i in range(k.shape[0]):
        for v in range(LANES):
            w[n + i, v] += scale * k[i, v]


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _gemv(PT, j0, nj, x, scale, out, accumulate, xs):
    """out (+)= scale · P[:, j0:j0+nj] x[:nj] per variant, from Pᵀ (entries, entries,
    variants); xs: scratch (8, variants). The single kernel's `_gemv`, entry for entry."""
    m = out.shape[0]
    if not accumulate:
        for i in range(m):
            for v in range(LANES):
                out[i, v] = 0.0
    q = 0
    while q + 4 <= nj:
        j = j0 + q
        for r in range(4):
            for v in range(LANES):
                xs[r, v] = scale * x[q + r, v]
        for i in range(m):
            for v in range(LANES):
                out[i, v] += (PT[j, i, v] * xs[0, v] + PT[j + 1, i, v] * xs[1, v]) + (
                    PT[j + 2, i, v] * xs[2, v] + PT[j + 3, i, v] * xs[3, v])
        q += 4
    while q < nj:
        for v in range(LANES):
            xs[0, v] = scale * x[q, v]
        for i in range(m):
            for v in range(LANES):
                out[i, v] += PT[j0 + q, i, v] * xs[0, v]
        q += 1


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _gemv2(PT, j0, nj, x, sx, out, z, sz, out2, xs):
    """out += sx · P[:, j0:j0+nj] x and out2 += sz · P[:, j0:j0+nj] z in one pass over Pᵀ
    (the single kernel's `_gemv2`); xs: scratch (8, variants)."""
    m = out.shape[0]
    q = 0
    while q + 4 <= nj:
        j = j0 + q
        for r in range(4):
            for v in range(LANES):
                xs[r, v] = sx * x[q + r, v]
                xs[4 + r, v] = sz * z[q + r, v]
        for i in range(m):
            for v in range(LANES):
                p0, p1, p2, p3 = PT[j, i, v], PT[j + 1, i, v], PT[j + 2, i, v], PT[j + 3, i, v]
                out[i, v] += (p0 * xs[0, v] + p1 * xs[1, v]) + (p2 * xs[2, v] + p3 * xs[3, v])
                out2[i, v] += (p0 * xs[4, v] + p1 * xs[5, v]) + (p2 * xs[6, v]
                                                                 + p3 * xs[7, v])
        q += 4
    while q < nj:
        for v in range(LANES):
            xs[0, v] = sx * x[q, v]
            xs[4, v] = sz * z[q, v]
        for i in range(m):
            for v in range(LANES):
                out[i, v] += PT[j0 + q, i, v] * xs[0, v]
                out2[i, v] += PT[j0 + q, i, v] * xs[4, v]
        q += 1


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _stages_ab(Dm, ET, h, Ey, k1, k2, k3, w, xs):
    """The single kernel's `_stages_ab` per variant."""
    n = k1.shape[0]
    m = Ey.shape[0]
    _gemv(ET, n, n, k1, 0.5 * h, w, SET, xs)
    _zero2(k2, k3)
    _gemv2(Dm, FIRST, m, Ey, 1.0, k3, w, 1.0, k2, xs)
    for q in range(n):
        for v in range(LANES):
            k2[q, v] += k3[q, v]
    _gemv(Dm, n, n, k2, 0.5 * h, k3, ADD, xs)


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _fine_step(ET, E2T, Da, Db, h, y, k1, Ey, E2y, u, w, k2, k3, k4, cin, cscale, wc, cout,
               xs):
    """The single kernel's `_fine_step` per variant."""
    m = y.shape[0]
    n = k1.shape[0]
    _copy(E2y, u)
    _gemv2(E2T, n, n, k1, h / 6.0, u, cin, cscale, wc, xs)
    _stages_ab(Da, ET, h, Ey, k1, k2, k3, w, xs)
    for q in range(n):
        for v in range(LANES):
            k2[q, v] += k3[q, v]
    _copy(E2y, w)
    _gemv2(ET, n, n, k3, h, w, k2, h / 3.0, u, xs)
    _zero2(k4, cout)
    _gemv2(Db, FIRST, m, w, 1.0, k4, wc, 1.0, cout, xs)
    _add(u, n, h / 6.0, k4)
    _copy(u, y)


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _pair(ET, E2T, E4T, D, h, y, k1, yc, c1, k2, k3, k4, b2, b3, b4, Ey, E2y, u, w, Ecy,
          E4y, wc, xs, bounds, reach, beyond, at_rest, t_mid, a):
    """The single kernel's `_pair` (two fine steps of h, one coarse step of 2h) per variant,
    with the moving lanes' reach of their bounds read between the fine steps (at t_mid)."""
    m = y.shape[0]
    n = k1.shape[0]
    H = 2.0 * h
    _zero2(E2y, Ecy)
    _gemv2(E2T, FIRST, m, y, 1.0, E2y, yc, 1.0, Ecy, xs)
    _gemv(ET, FIRST, m, y, 1.0, Ey, SET, xs)
    _gemv(E4T, FIRST, m, yc, 1.0, E4y, SET, xs)
    _copy(Ecy, wc)
    _fine_step(ET, E2T, D[0], D[1], h, y, k1, Ey, E2y, u, w, k2, k3, k4, c1, 0.5 * H, wc, b2,
               xs)
    _lane_reach(bounds, y, t_mid, at_rest, False, reach, beyond, a)
    _copy(Ecy, wc)
    _add(wc, n, 0.5 * H, b2)
    _zero2(k1, b3)
    _gemv2(D[1], FIRST, m, y, 1.0, k1, wc, 1.0, b3, xs)
    _gemv(ET, FIRST, m, y, 1.0, Ey, SET, xs)
    _gemv(E2T, FIRST, m, y, 1.0, E2y, SET, xs)
    _copy(E4y, wc)
    _fine_step(ET, E2T, D[2], D[3], h, y, k1, Ey, E2y, u, w, k2, k3, k4, b3, H, wc, b4, xs)
    for q in range(n):
        for v in range(LANES):
            b2[q, v] += b3[q, v]
    _copy(E4y, yc)
    _gemv(E4T, n, n, c1, H / 6.0, yc, ADD, xs)
    _gemv(E2T, n, n, b2, H / 3.0, yc, ADD, xs)
    _add(yc, n, H / 6.0, b4)
    _zero2(k1, c1)
    _gemv2(D[3], FIRST, m, y, 1.0, k1, yc, 1.0, c1, xs)


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _lane_reach(bounds, y, t, at_rest, rest, reach, beyond, a):
    """The single kernel's `_reach` for the lanes whose ``at_rest`` is ``rest`` (the others'
    states here are thrown away): bounds (r, m, V), reach and beyond (r, V); ``a`` (V,):
    scratch. Each lane's sum in the single kernel's order, across the lanes."""
    for j in range(bounds.shape[0]):
        for v in range(LANES):
            a[v] = 0.0
        for q in range(bounds.shape[1]):
            for v in range(LANES):
                a[v] += bounds[j, q, v] * y[q, v]
        for v in range(LANES):
            if at_rest[v] == rest:
                value = abs(a[v])
                reach[j, v] = max(reach[j, v], value)
                if value > 1.0 and beyond[j, v] == np.inf:
                    beyond[j, v] = t


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _record(i, y, yc, states, peak, spread):
    """The single kernel's `_record` with the coarse pass, coarse states not kept."""
    for q in range(y.shape[0]):
        for v in range(LANES):
            a = y[q, v]
            states[v, i, q] = a
            a = abs(a)
            if a > peak[q, v] or np.isnan(a):
                peak[q, v] = a
    for q in range(y.shape[0]):
        for v in range(LANES):
            a = abs(y[q, v] - yc[q, v])
            if a > spread[q, v] or np.isnan(a):
                spread[q, v] = a


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _lane_piece(lo, hi, count, v, tau):
    """The piece (of the lane's current block, `count` pieces) that holds its local time τ,
    and τ in that piece (the single kernel's `_piece`)."""
    p = 0
    while p < count - 1 and tau > hi[p, v]:
        p += 1
    return p, (tau - lo[p, v]) / (hi[p, v] - lo[p, v])


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _lane_delta(W, ref, p, local, v, outT):
    """outT[:, :, v] = (A(τ) − A_ref)ᵀ of lane v from its piece p at local time ``local``:
    the single kernel's `_delta` (Horner, the degree outermost), entry for entry."""
    degree = W.shape[1] - 1
    for j in range(outT.shape[0]):
        for i in range(outT.shape[1]):
            acc = W[p, degree, j, i, v]
            for d in range(degree - 1, -1, -1):
                acc = acc * local + W[p, d, j, i, v]
            outT[j, i, v] = acc - ref[j, i, v]


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _lane_deltas(W, ref, piece, local, out):
    """out[r] = (A − A_ref)ᵀ at the four instants of a pair of fine steps, every lane at its
    own piece[r, v] and local time local[r, v] (the single kernel's `_deltas`; its fast path
    and `_delta` give the same numbers). Across lanes in one pass where every lane is in its
    block's first piece (a block of several pieces is one output interval around a kink)."""
    nv = out.shape[3]
    first = True
    for r in range(4):
        for v in range(nv):
            if piece[r, v] != 0:
                first = False
    if not first or W.shape[1] != 6:
        for r in range(4):
            for v in range(nv):
                _lane_delta(W, ref, piece[r, v], local[r, v], v, out[r])
        return
    for j in range(out.shape[1]):
        for i in range(out.shape[2]):
            for v in range(LANES):
                c0, c1, c2 = W[0, 0, j, i, v], W[0, 1, j, i, v], W[0, 2, j, i, v]
                c3, c4, c5 = W[0, 3, j, i, v], W[0, 4, j, i, v], W[0, 5, j, i, v]
                rf = ref[j, i, v]
                la, lb, lc, ld = local[0, v], local[1, v], local[2, v], local[3, v]
                out[0, j, i, v] = (((((c5 * la + c4) * la + c3) * la + c2) * la + c1) * la
                                   + c0) - rf
                out[1, j, i, v] = (((((c5 * lb + c4) * lb + c3) * lb + c2) * lb + c1) * lb
                                   + c0) - rf
                out[2, j, i, v] = (((((c5 * lc + c4) * lc + c3) * lc + c2) * lc + c1) * lc
                                   + c0) - rf
                out[3, j, i, v] = (((((c5 * ld + c4) * ld + c3) * ld + c2) * ld + c1) * ld
                                   + c0) - rf


@njit(cache=True, error_model="numpy")
def lawson_blocks_batch(y, yc, t_out, first, last, static, pieces, lower, upper, poly,
                        reference, ET, E2T, E4T, substeps, states, accelerations, peak,
                        spread, bounds, reach, beyond):
    """`_lawson_numba.lawson_blocks` with ``coarse`` and no coarse states, for V = `LANES`
    variants at once, each on its own table (blocks, pieces, polynomials): y, yc (m, V);
    per lane v, padded past its own blocks and polynomials: its table's first, last, static
    (V, blocks), pieces (V, blocks+1), lower, upper (V, polynomials), poly (V, polynomials,
    degree+1, n, m) and reference (V, blocks, n, m) as in the table (not transposed), its
    ET, E2T, E4T (V, blocks, m, m) (transposed, as the single loop takes them); states
    (V, nt, m); accelerations (V, nt, n) (each variant's contiguous, as its single run's);
    peak, spread (m, V); bounds (r, m, V), reach, beyond (r, V): the single loop's, per lane
    (rows of zeros where a run has fewer). t_out and substeps (even) are shared, so is the
    step h of every output interval.

    Output interval by output interval, every lane in the block of its own table that holds
    it: the lanes in moving blocks cross it in Lawson steps (those in static blocks take the
    same steps, thrown away), then the lanes in static blocks in one product with their
    exp(Δt Ã). Each lane's block matrices and polynomials are copied lanes-last (and the
    table's transposed) when it enters the block, so that every product and polynomial runs
    across the lanes."""
    m, nv = y.shape
    if nv != LANES:  # the inner loops run over LANES variants, unchecked
        raise ValueError("lawson_blocks_batch advances LANES variants")
    n = (m - 1) // 2
    nt = t_out.shape[0]
    most = 1  # the most pieces of one block, over every lane's blocks
    for v in range(nv):
        for b in range(first.shape[1]):
            most = max(most, pieces[v, b + 1] - pieces[v, b])
    degree1 = poly.shape[2]
    W = np.zeros((most, degree1, m, n, nv))  # each lane's current block's polynomials
    lo, hi = np.zeros((most, nv)), np.ones((most, nv))
    count = np.ones(nv, dtype=np.int64)
    Ar = np.zeros((m, n, nv))
    P, P2, P4 = np.zeros((m, m, nv)), np.zeros((m, m, nv)), np.zeros((m, m, nv))
    block = np.full(nv, -1, dtype=np.int64)
    i0 = np.zeros(nv, dtype=np.int64)
    ends = np.zeros(nv, dtype=np.int64)  # the output index where the lane's block ends
    span = np.ones(nv)
    at_rest = np.zeros(nv, dtype=np.bool_)
    starts = np.zeros(nv, dtype=np.bool_)
    piece = np.zeros((4, nv), dtype=np.int64)
    local = np.zeros((4, nv))
    D = np.zeros((4, m, n, nv))
    k1, k2, k3, k4 = (np.zeros((n, nv)), np.zeros((n, nv)), np.zeros((n, nv)),
                      np.zeros((n, nv)))
    c1, b2, b3, b4 = (np.zeros((n, nv)), np.zeros((n, nv)), np.zeros((n, nv)),
                      np.zeros((n, nv)))
    r, tk, tc = np.zeros((n, nv)), np.zeros((n, nv)), np.zeros((n, nv))
    Ey, E2y, w, u = np.zeros((m, nv)), np.zeros((m, nv)), np.zeros((m, nv)), np.zeros((m, nv))
    Ecy, E4y, wc = np.zeros((m, nv)), np.zeros((m, nv)), np.zeros((m, nv))
    y0, yc0, ws, wcs = (np.zeros((m, nv)), np.zeros((m, nv)), np.zeros((m, nv)),
                        np.zeros((m, nv)))
    xs = np.zeros((8, nv))
    sums = np.zeros(nv)  # _lane_reach's
    for i in range(nt - 1):
        moving = False
        resting = False
        entering = False
        for v in range(nv):
            starts[v] = False
            if block[v] < 0 or i == ends[v]:  # the lane enters its next block
                b = block[v] + 1
                block[v] = b
                i0[v], ends[v] = first[v, b], last[v, b]
                span[v] = t_out[ends[v]] - t_out[i0[v]]
                at_rest[v] = static[v, b]
                p0 = pieces[v, b]
                count[v] = pieces[v, b + 1] - p0
                for p in range(count[v]):
                    lo[p, v], hi[p, v] = lower[v, p0 + p], upper[v, p0 + p]
                    for d in range(degree1):
                        for q in range(n):
                            for j in range(m):
                                W[p, d, j, q, v] = poly[v, p0 + p, d, q, j]
                for q in range(n):
                    for j in range(m):
                        Ar[j, q, v] = reference[v, b, q, j]
                for j in range(m):
                    for q in range(m):
                        P[j, q, v] = ET[v, b, j, q]
                        P2[j, q, v] = E2T[v, b, j, q]
                        P4[j, q, v] = E4T[v, b, j, q]
                starts[v] = not at_rest[v]
                entering = entering or starts[v]
            if at_rest[v]:
                resting = True
            else:
                moving = True
        if entering:  # k1, c1 = ΔÃ(τ = 0) y, yc of the lanes entering a moving block
            for v in range(nv):
                if starts[v]:
                    p, tau = _lane_piece(lo, hi, count[v], v, 0.0)
                    _lane_delta(W, Ar, p, tau, v, D[3])
            _gemv(D[3], FIRST, m, y, 1.0, tk, SET, xs)
            _gemv(D[3], FIRST, m, yc, 1.0, tc, SET, xs)
            for v in range(nv):
                if starts[v]:
                    for q in range(n):
                        k1[q, v] = tk[q, v]
                        c1[q, v] = tc[q, v]
        if resting and moving:  # the resting lanes' states, before the steps change them
            _copy(y, y0)
            _copy(yc, yc0)
        if moving:
            h = (t_out[i + 1] - t_out[i]) / substeps
            for j in range(0, substeps, 2):
                for v in range(nv):
                    dtau = h / span[v]
                    tau = (t_out[i] - t_out[i0[v]] + j * h) / span[v]
                    piece[0, v], local[0, v] = _lane_piece(lo, hi, count[v], v,
                                                           tau + 0.5 * dtau)
                    piece[1, v], local[1, v] = _lane_piece(lo, hi, count[v], v, tau + dtau)
                    piece[2, v], local[2, v] = _lane_piece(lo, hi, count[v], v,
                                                           tau + 1.5 * dtau)
                    piece[3, v], local[3, v] = _lane_piece(lo, hi, count[v], v,
                                                           tau + 2.0 * dtau)
                _lane_deltas(W, Ar, piece, local, D)
                _pair(P, P2, P4, D, h, y, k1, yc, c1, k2, k3, k4, b2, b3, b4, Ey, E2y, u,
                      w, Ecy, E4y, wc, xs, bounds, reach, beyond, at_rest,
                      t_out[i] + (j + 1) * h, sums)
                _lane_reach(bounds, y, t_out[i] + (j + 2) * h, at_rest, False, reach, beyond,
                            sums)
        if resting:  # y ← exp(Δt Ã) y on the static lanes, both passes in one product
            if moving:
                _zero2(ws, wcs)
                _gemv2(P, FIRST, m, y0, 1.0, ws, yc0, 1.0, wcs, xs)
                for v in range(nv):
                    if at_rest[v]:
                        for q in range(m):
                            y[q, v] = ws[q, v]
                            yc[q, v] = wcs[q, v]
            else:
                _zero2(ws, wcs)
                _gemv2(P, FIRST, m, y, 1.0, ws, yc, 1.0, wcs, xs)
                _copy(wcs, yc)
                _copy(ws, y)
            _lane_reach(bounds, y, t_out[i + 1], at_rest, True, reach, beyond, sums)
        _record(i + 1, y, yc, states, peak, spread)
        if moving:  # z̈ = A y on the moving lanes (the static ones': static_accelerations)
            _gemv(Ar, FIRST, m, y, 1.0, r, SET, xs)
            for v in range(nv):
                if not at_rest[v]:
                    for q in range(n):
                        accelerations[v, i + 1, q] = r[q, v] + k1[q, v]


# The one signature `lawson_batch.first_passes` calls lawson_blocks_batch with (C-contiguous).
SIGNATURE = (float64[:, ::1], float64[:, ::1], float64[::1], int64[:, ::1], int64[:, ::1],
             boolean[:, ::1], int64[:, ::1], float64[:, ::1], float64[:, ::1],
             float64[:, :, :, :, ::1], float64[:, :, :, ::1], float64[:, :, :, ::1],
             float64[:, :, :, ::1], float64[:, :, :, ::1], int64, float64[:, :, ::1],
             float64[:, :, ::1], float64[:, ::1], float64[:, ::1], float64[:, :, ::1],
             float64[:, ::1], float64[:, ::1])


def load() -> None:
    """Make lawson_blocks_batch ready for `SIGNATURE` (numba's cache, or compile it)."""
    lawson_blocks_batch.compile(SIGNATURE)
