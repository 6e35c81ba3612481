"""Compiled (numba) step loop of the Lawson integrator (``lawson.py``).

One step is two products with the (2n+1)² block propagator, four with n of its columns and
four with the n-row remainder ΔÃ (_step); ΔÃ is evaluated from the table's polynomials at the
four instants of two fine steps in one pass (_deltas). The Richardson pass with steps of 2h
runs alongside (``coarse``) and reads the same ΔÃ. Compiled, a step costs a small fraction of
the same step as a sequence of numpy calls. Compiled functions are cached on disk
(``cache=True``).

Copies are explicit loops (`_copy`, `_copy2`), not slice assignments (``u[:] = w``): numba
lowers each slice assignment to general broadcasting code, which took most of the first
compilation (same results, bit for bit). The helpers are never called from Python (no CPython
wrapper to generate), and numpy's error model leaves out the division-by-zero checks (a
zero-width block cannot occur; a non-finite state is caught by the caller): both shorten the
first compilation too.
"""

from __future__ import annotations

import numpy as np
from numba import boolean, float64, int64, njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation

# The matrix helpers' (_gemv, _gemv2, and the other modules' _dots, _many) first column j0
# and ``accumulate`` as values typed like the others (int64, bool), not literal 0, True or
# False: numba compiles a function once per type of its arguments, and each literal is a
# type of its own (a helper called with 0 and with n compiled twice).
FIRST = np.int64(0)  # j0: from the first column
SET, ADD = np.bool_(False), np.bool_(True)  # accumulate: out = …, out += …


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _delta(polyT, lower, upper, p0, p1, referenceT, tau, outT):
    """outT = (A(τ) − A_ref)ᵀ for one block whose pieces are p0 … p1−1 (Horner in τ)."""
    p = p0
    while p < p1 - 1 and tau > upper[p]:
        p += 1
    local = (tau - lower[p]) / (upper[p] - lower[p])
    degree = polyT.shape[1] - 1
    # Horner with the degree outermost: the inner loops run over contiguous entries and
    # vectorise; each entry sees the same operations in the same order as entry by entry.
    for j in range(outT.shape[0]):
        for i in range(outT.shape[1]):
            outT[j, i] = polyT[p, degree, j, i]
    for d in range(degree - 1, -1, -1):
        for j in range(outT.shape[0]):
            for i in range(outT.shape[1]):
                outT[j, i] = outT[j, i] * local + polyT[p, d, j, i]
    for j in range(outT.shape[0]):
        for i in range(outT.shape[1]):
            outT[j, i] -= referenceT[j, i]


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _add(w, n, scale, k):
    """w[n:2n] += scale · k (the stages act on the velocity rows only)."""
    for i in range(k.shape[0]):
        w[n + i] += scale * k[i]


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _mv(AT, x, out):
    """out = A x from Aᵀ, without allocating (numba's @ allocates a result per call).

    Column by column: the inner loop is element-wise and vectorises without fastmath, and
    each out[i] still sums in the order j = 0, 1, … (fastmath's reassociated sums depended on
    memory alignment: a sweep case then differed in the last bits from its own single run)."""
    for i in range(out.shape[0]):
        out[i] = 0.0
    for j in range(AT.shape[0]):
        xj = x[j]
        for i in range(AT.shape[1]):
            out[i] += AT[j, i] * xj


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _copy(a, b):
    """b[:] = a."""
    for i in range(a.shape[0]):
        b[i] = a[i]


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _copy2(a, b):
    """b[:, :] = a."""
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            b[i, j] = a[i, j]


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _gemv(PT, j0, nj, x, scale, out, accumulate):
    """out (+)= scale · P[:, j0:j0+nj] x[:nj] from Pᵀ (accumulate: add to out, else set it).

    Four columns of P per pass over out: a quarter of the loads and stores of out that one
    column at a time costs. The inner loop is element-wise and vectorises without fastmath; each out[i]
    sums in a fixed order, whatever the memory alignment (see _mv)."""
    m = out.shape[0]
    if not accumulate:
        for i in range(m):
            out[i] = 0.0
    q = 0
    while q + 4 <= nj:
        j = j0 + q
        x0, x1 = scale * x[q], scale * x[q + 1]
        x2, x3 = scale * x[q + 2], scale * x[q + 3]
        for i in range(m):
            out[i] += (PT[j, i] * x0 + PT[j + 1, i] * x1) + (PT[j + 2, i] * x2
                                                             + PT[j + 3, i] * x3)
        q += 4
    while q < nj:
        xq = scale * x[q]
        for i in range(m):
            out[i] += PT[j0 + q, i] * xq
        q += 1


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _gemv2(PT, j0, nj, x, sx, out, v, sv, out2):
    """out += sx · P[:, j0:j0+nj] x[:nj] and out2 += sv · P[:, j0:j0+nj] v[:nj] in one pass
    over Pᵀ: the loop streams its matrices from the L2 cache, so two vectors per pass cost
    little more than one. Per entry the same operations in the same order as _gemv."""
    m = out.shape[0]
    q = 0
    while q + 4 <= nj:
        j = j0 + q
        x0, x1, x2, x3 = sx * x[q], sx * x[q + 1], sx * x[q + 2], sx * x[q + 3]
        v0, v1, v2, v3 = sv * v[q], sv * v[q + 1], sv * v[q + 2], sv * v[q + 3]
        for i in range(m):
            p0, p1, p2, p3 = PT[j, i], PT[j + 1, i], PT[j + 2, i], PT[j + 3, i]
            out[i] += (p0 * x0 + p1 * x1) + (p2 * x2 + p3 * x3)
            out2[i] += (p0 * v0 + p1 * v1) + (p2 * v2 + p3 * v3)
        q += 4
    while q < nj:
        xq, vq = sx * x[q], sv * v[q]
        for i in range(m):
            out[i] += PT[j0 + q, i] * xq
            out2[i] += PT[j0 + q, i] * vq
        q += 1


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _zero2(a, b):
    """a[:] = b[:] = 0."""
    for i in range(a.shape[0]):
        a[i] = 0.0
        b[i] = 0.0


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _piece(lower, upper, p0, p1, tau):
    """The piece p0 … p1−1 of a block that holds its local time τ, and τ in that piece."""
    p = p0
    while p < p1 - 1 and tau > upper[p]:
        p += 1
    return p, (tau - lower[p]) / (upper[p] - lower[p])


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _deltas(polyT, lower, upper, p0, p1, referenceT, tau, dtau, out):
    """out[r] = (A(τ + (r+1)/2 · dτ) − A_ref)ᵀ, r = 0 … 3: the mid and end points of two
    steps of dτ from τ, and of one step of 2 dτ (the coarse Richardson pass).

    One pass over the coefficients for the four points when they lie in one piece of degree 5
    (Horner per entry in registers: six loads for twenty products); the same operations per
    entry, in the same order, as _delta, which does the other cases."""
    pa, la = _piece(lower, upper, p0, p1, tau + 0.5 * dtau)
    pb, lb = _piece(lower, upper, p0, p1, tau + dtau)
    pc, lc = _piece(lower, upper, p0, p1, tau + 1.5 * dtau)
    pd, ld = _piece(lower, upper, p0, p1, tau + 2.0 * dtau)
    if polyT.shape[1] != 6 or pa != pd or pb != pd or pc != pd:
        for r in range(4):
            _delta(polyT, lower, upper, p0, p1, referenceT, tau + 0.5 * (r + 1) * dtau, out[r])
        return
    P = polyT[pd]
    for j in range(out.shape[1]):
        for i in range(out.shape[2]):
            c0, c1, c2 = P[0, j, i], P[1, j, i], P[2, j, i]
            c3, c4, c5 = P[3, j, i], P[4, j, i], P[5, j, i]
            ref = referenceT[j, i]
            out[0, j, i] = (((((c5 * la + c4) * la + c3) * la + c2) * la + c1) * la + c0) - ref
            out[1, j, i] = (((((c5 * lb + c4) * lb + c3) * lb + c2) * lb + c1) * lb + c0) - ref
            out[2, j, i] = (((((c5 * lc + c4) * lc + c3) * lc + c2) * lc + c1) * lc + c0) - ref
            out[3, j, i] = (((((c5 * ld + c4) * ld + c3) * ld + c2) * ld + c1) * ld + c0) - ref


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _stages_ab(Dm, ET, h, Ey, k1, k2, k3, w):
    """k₂ = ΔÃ a and k₃ = ΔÃ b of a step (Dm: ΔÃᵀ at its middle), a = Ey + h/2 E k₁,
    b = Ey + h/2 k₂, with one and a half passes over ΔÃ instead of two: ΔÃ Ey and
    ΔÃ (h/2 E k₁) in one pass, then k₃ = ΔÃ Ey + h/2 ΔÃ k₂ through ΔÃ's n velocity columns
    (b − Ey has n entries). w: scratch."""
    m = Ey.shape[0]
    n = k1.shape[0]
    _gemv(ET, n, n, k1, 0.5 * h, w, SET)  # a − Ey
    _zero2(k2, k3)
    _gemv2(Dm, FIRST, m, Ey, 1.0, k3, w, 1.0, k2)
    for q in range(n):
        k2[q] += k3[q]
    _gemv(Dm, n, n, k2, 0.5 * h, k3, ADD)


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _step(ET, E2T, Dm, D2, h, u, k1, k2, k3, k4, Ey, E2y, w):
    """One Lawson step of h on u (in place), E = exp(h/2 Ã_ref) and E² = exp(h Ã_ref) given
    transposed; Dm, D2: ΔÃᵀ at the step's middle and end. On entry k1 = ΔÃ(start) u, on exit
    k1 = ΔÃ(end) u⁺ (the next step's k1 in the same block, and z̈ − Ã_ref u⁺ at an output).

    The stages of the module docstring (lawson.py) with E applied to the k_i by linearity:
    a k_i has n entries (velocity rows), so E k_i is a product with n columns of E, and
    E(E y) is E² y. Two products with the whole (2n+1)² propagator per step instead of five:

        a = Ey + h/2 E k₁,  b = Ey + h/2 k₂,  c = E²y + h E k₃,
        y⁺ = E²y + h/6 E² k₁ + h/3 E (k₂ + k₃) + h/6 k₄."""
    m = u.shape[0]
    n = k1.shape[0]
    _gemv(ET, FIRST, m, u, 1.0, Ey, SET)
    _gemv(E2T, FIRST, m, u, 1.0, E2y, SET)
    _copy(E2y, u)  # u becomes y⁺, summed in the order of the formula above
    _gemv(E2T, n, n, k1, h / 6.0, u, ADD)
    _stages_ab(Dm, ET, h, Ey, k1, k2, k3, w)
    for q in range(n):
        k2[q] += k3[q]
    _copy(E2y, w)
    _gemv2(ET, n, n, k3, h, w, k2, h / 3.0, u)  # c, and E (k₂ + k₃) in the same pass
    _gemv(D2, FIRST, m, w, 1.0, k4, SET)
    _add(u, n, h / 6.0, k4)
    _gemv(D2, FIRST, m, u, 1.0, k1, SET)


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _fine_step(ET, E2T, Da, Db, h, y, k1, Ey, E2y, u, w, k2, k3, k4, cin, cscale, wc, cout):
    """The rest of one fine step of _pair (y ← y⁺, in place) once Ey = E y and E2y = E² y
    are known, with a coarse-step product interleaved into two of its passes over a matrix
    (_gemv2): wc += cscale · E² cin (E2T's velocity rows), then cout = ΔÃ(end) wc. Da, Db:
    ΔÃᵀ at the step's middle (_stages_ab) and at its end; k1 = ΔÃ(start) y on entry; u, w,
    k2 … k4 are scratch."""
    m = y.shape[0]
    n = k1.shape[0]
    _copy(E2y, u)  # u becomes the fine step's y⁺
    _gemv2(E2T, n, n, k1, h / 6.0, u, cin, cscale, wc)
    _stages_ab(Da, ET, h, Ey, k1, k2, k3, w)
    for q in range(n):
        k2[q] += k3[q]
    _copy(E2y, w)
    _gemv2(ET, n, n, k3, h, w, k2, h / 3.0, u)  # c, and E (k₂ + k₃)
    _zero2(k4, cout)
    _gemv2(Db, FIRST, m, w, 1.0, k4, wc, 1.0, cout)  # fine k4, and the coarse stage's k
    _add(u, n, h / 6.0, k4)
    _copy(u, y)


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _pair(ET, E2T, E4T, D, h, y, k1, yc, c1, k2, k3, k4, b2, b3, b4, Ey, E2y, u, w, Ecy,
          E4y, wc, mid):
    """Two fine steps of h on y and one coarse step of 2h on yc (in place), as two _step
    calls with (E, E², ΔÃ at D[0], D[1]), (E, E², D[2], D[3]) and one with (E², E⁴, D[1],
    D[3]): the same operations per entry, bit for bit, but the coarse step's products with
    E², E⁴ and ΔÃ share their passes over a matrix with the fine steps' where both operands
    are known (_gemv2): 20 passes over a matrix instead of 30 (with _stages_ab's). k1, c1:
    ΔÃ(start) y, yc on entry, ΔÃ(end) of the new y, yc on exit; the rest is scratch (b2 … b4:
    coarse stages); ``mid``: the state between the two fine steps, written."""
    m = y.shape[0]
    n = k1.shape[0]
    H = 2.0 * h  # the coarse step
    # Fine step 1 and the coarse step's start: E²y, E_c yc = E² yc, E y, E_c² yc = E⁴ yc.
    _zero2(E2y, Ecy)
    _gemv2(E2T, FIRST, m, y, 1.0, E2y, yc, 1.0, Ecy)
    _gemv(ET, FIRST, m, y, 1.0, Ey, SET)
    _gemv(E4T, FIRST, m, yc, 1.0, E4y, SET)
    _copy(Ecy, wc)  # wc: the coarse stage a = E_c yc + H/2 E_c c1; b2 its coarse k2
    _fine_step(ET, E2T, D[0], D[1], h, y, k1, Ey, E2y, u, w, k2, k3, k4, c1, 0.5 * H, wc, b2)
    _copy(y, mid)
    _copy(Ecy, wc)
    _add(wc, n, 0.5 * H, b2)  # coarse b
    _zero2(k1, b3)
    _gemv2(D[1], FIRST, m, y, 1.0, k1, wc, 1.0, b3)  # fine k1 of step 2, coarse k3
    # Fine step 2, and the coarse stage c = E_c² yc + H E_c b3.
    _gemv(ET, FIRST, m, y, 1.0, Ey, SET)
    _gemv(E2T, FIRST, m, y, 1.0, E2y, SET)
    _copy(E4y, wc)  # wc: the coarse stage c; b4 its coarse k4
    _fine_step(ET, E2T, D[2], D[3], h, y, k1, Ey, E2y, u, w, k2, k3, k4, b3, H, wc, b4)
    # The coarse y⁺ = E_c² yc + H/6 E_c² c1 + H/3 E_c (b2 + b3) + H/6 b4.
    for q in range(n):
        b2[q] += b3[q]
    _copy(E4y, yc)
    _gemv(E4T, n, n, c1, H / 6.0, yc, ADD)
    _gemv(E2T, n, n, b2, H / 3.0, yc, ADD)
    _add(yc, n, H / 6.0, b4)
    _zero2(k1, c1)
    _gemv2(D[3], FIRST, m, y, 1.0, k1, yc, 1.0, c1)


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _record(i, y, yc, coarse, states, coarse_states, peak, spread):
    """Write y (and yc, if ``coarse_states`` has rows) at output index i, and keep the
    Richardson check's running maxima: peak[q] = max |y_q|, spread[q] = max |y_q − yc_q|
    (coarse) over the output times so far. Their maxima decide exactly what the
    comparison of the whole arrays would (magnus.agree): the maximum of |·| is exact."""
    for q in range(y.shape[0]):
        v = y[q]
        states[i, q] = v
        a = abs(v)
        if a > peak[q] or np.isnan(a):  # a NaN stays (the caller refuses non-finite states)
            peak[q] = a
    if coarse:
        for q in range(y.shape[0]):
            a = abs(y[q] - yc[q])
            if a > spread[q] or np.isnan(a):
                spread[q] = a
        if coarse_states.shape[0]:
            for q in range(y.shape[0]):
                coarse_states[i, q] = yc[q]


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _reach(bounds, y, t, reach, beyond):
    """Keep reach[j] = max |bounds[j] · y| over the states seen, and beyond[j] the time t
    (s) of the first state where it exceeded 1 (left at inf while none has)."""
    for j in range(bounds.shape[0]):
        v = 0.0
        for i in range(y.shape[0]):
            v += bounds[j, i] * y[i]
        v = abs(v)
        reach[j] = max(reach[j], v)
        if v > 1.0 and beyond[j] == np.inf:
            beyond[j] = t


@njit(cache=True, error_model="numpy")
def lawson_blocks(y, yc, t_out, first, last, static, pieces, lower, upper, polyT, referenceT,
                  ET, E2T, E4T, substeps, coarse, states, accelerations, coarse_states,
                  peak, spread, trail, bounds, reach, beyond):
    """Advance the augmented state y = [z, ż, 1] through the blocks, and with ``coarse`` the
    state yc of the Richardson pass with half as many steps alongside (in place, both).

    Block b spans output indices first[b]..last[b], its polynomials are pieces[b]…pieces[b+1]−1
    (coefficient_table.CoefficientTable; every matrix here is passed transposed, for _gemv). A
    moving block is crossed in ``substeps`` Lawson steps per output interval (even unless
    coarse is false), with E[b] = exp(h/2 Ã_ref), E2[b] = E[b]², E4[b] = E2[b]² (the coarse
    pass's E²); a static block interval by interval with E[b] = exp(Δt Ã), exact. Writes y
    (yc, unless ``coarse_states`` has no rows) at every output index into ``states``
    (``coarse_states``) and, on moving blocks, z̈ = A y into ``accelerations``; keeps the
    running maxima over the output times of |y| per component in ``peak`` and (coarse) of
    |y − yc| in ``spread`` (m,), the Richardson check's inputs (lawson.py). ``trail``, if
    it has rows: the start state of every fine step on the moving blocks but the first of
    each output interval (the state at its start, in ``states``), in order (what a reverse
    pass of the steps reads, `_lawson_adjoint_numba`). ``bounds`` (r, m): linear combinations
    of the state, each within its bound where its magnitude is at most 1 (a link's tip
    deflection over its length, `solution.tip_bounds`), read at the end of every fine step
    (every output interval on static blocks): ``reach`` (r,) keeps the largest magnitude
    of each, ``beyond`` (r,) the end time of the first step beyond 1 (inf while none is).

    The coarse step of 2h spans two fine steps: its middle and end are their ends, so it reads
    ΔÃ at instants the fine pass evaluates anyway (one pass over the coefficients, _deltas,
    for the four instants of a pair of fine steps).
    """
    m = y.shape[0]
    n = (m - 1) // 2
    D = np.empty((4, m, n))
    k1, k2, k3, k4 = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    c1, b2, b3, b4 = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    r = np.empty(n)
    Ey, E2y, w, u = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    Ecy, E4y, wc = np.empty(m), np.empty(m), np.empty(m)
    ym = np.empty(m)  # the state between a pair's fine steps
    s = 0  # the next row of trail
    for b in range(first.size):
        i0, i1 = first[b], last[b]
        A_ref = referenceT[b]
        P, P2, P4 = ET[b], E2T[b], E4T[b]
        if static[b]:
            for i in range(i0, i1):
                if coarse:  # both states in one pass over the propagator
                    _zero2(w, wc)
                    _gemv2(P, FIRST, m, y, 1.0, w, yc, 1.0, wc)
                    _copy(wc, yc)
                else:
                    _gemv(P, FIRST, m, y, 1.0, w, SET)
                _copy(w, y)
                _record(i + 1, y, yc, coarse, states, coarse_states, peak, spread)
                _reach(bounds, y, t_out[i + 1], reach, beyond)
            continue
        span = t_out[i1] - t_out[i0]
        p0, p1 = pieces[b], pieces[b + 1]
        _delta(polyT, lower, upper, p0, p1, A_ref, 0.0, D[3])
        _gemv(D[3], FIRST, m, y, 1.0, k1, SET)
        if coarse:
            _gemv(D[3], FIRST, m, yc, 1.0, c1, SET)
        for i in range(i0, i1):
            h = (t_out[i + 1] - t_out[i]) / substeps
            dtau = h / span
            # Step by step, ΔÃ for two steps at a time; one call site of _step (each inlined
            # product is vectorised again at every call site: compilation time).
            for j in range(0, substeps, 2 if coarse else 1):
                tau = (t_out[i] - t_out[i0] + j * h) / span
                if j % 2 == 0:
                    if j + 1 < substeps:
                        _deltas(polyT, lower, upper, p0, p1, A_ref, tau, dtau, D)
                    else:  # a last single step (fine pass alone, odd substeps)
                        _delta(polyT, lower, upper, p0, p1, A_ref, tau + 0.5 * dtau, D[0])
                        _delta(polyT, lower, upper, p0, p1, A_ref, tau + dtau, D[1])
                if trail.shape[0] and j > 0:  # the first step starts from states[i]
                    _copy(y, trail[s])
                    s += 1
                if coarse:
                    _pair(P, P2, P4, D, h, y, k1, yc, c1, k2, k3, k4, b2, b3, b4, Ey, E2y, u,
                          w, Ecy, E4y, wc, ym)
                    if trail.shape[0]:
                        _copy(ym, trail[s])
                        s += 1
                    _reach(bounds, ym, t_out[i] + (j + 1) * h, reach, beyond)
                    _reach(bounds, y, t_out[i] + (j + 2) * h, reach, beyond)
                else:
                    r0 = 2 * (j % 2)
                    _step(P, P2, D[r0], D[r0 + 1], h, y, k1, k2, k3, k4, Ey, E2y, w)
                    _reach(bounds, y, t_out[i] + (j + 1) * h, reach, beyond)
            _record(i + 1, y, yc, coarse, states, coarse_states, peak, spread)
            _gemv(A_ref, FIRST, m, y, 1.0, r, SET)
            for q in range(n):
                accelerations[i + 1, q] = r[q] + k1[q]


# The one signature `lawson._solve` calls lawson_blocks with (every array C-contiguous).
SIGNATURE = (float64[::1], float64[::1], float64[::1], int64[::1], int64[::1], boolean[::1],
             int64[::1], float64[::1], float64[::1], float64[:, :, :, ::1], float64[:, :, ::1],
             float64[:, :, ::1], float64[:, :, ::1], float64[:, :, ::1], int64, boolean,
             float64[:, ::1], float64[:, ::1], float64[:, ::1], float64[::1], float64[::1],
             float64[:, ::1], float64[:, ::1], float64[::1], float64[::1])


def load() -> None:
    """Make lawson_blocks ready for `SIGNATURE`: load it from numba's cache, or compile it
    (and cache it) on a first run (`lawson.preload_compiled_loop`)."""
    lawson_blocks.compile(SIGNATURE)
