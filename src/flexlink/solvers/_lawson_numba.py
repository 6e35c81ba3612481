"""Compiled (numba) step loop of the Lawson integrator (``lawson.py``).

One step is five products with the 17 × 17 block propagator and two evaluations of a
degree-5 polynomial of 8 × 17 matrices for the paper arm: ~4·10³ flops, ~1 µs compiled against
~40 µs as a sequence of numpy calls. Compiled functions are cached on disk (``cache=True``).

Copies are explicit loops (`_copy`, `_copy2`), not slice assignments (``u[:] = w``): numba
lowers each slice assignment to general broadcasting code, and the ten of them took ~70% of
the first compilation (6 s → 2 s of CPU on the development machine; same results, bit for bit).
The helpers are never called from Python (no CPython wrapper to generate), and numpy's error
model leaves out the division-by-zero checks (a zero-width block cannot occur; a non-finite
state is caught by the caller): another ~0.15 s.
"""

from __future__ import annotations

import numpy as np
from numba import boolean, float64, int64, njit


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


@njit(cache=True, error_model="numpy")
def lawson_blocks(y, t_out, first, last, static, pieces, lower, upper, polyT, referenceT,
                  ET, substeps, states, accelerations):
    """Advance the augmented state y = [z, ż, 1] through the blocks.

    Block b spans output indices first[b]..last[b], its polynomials are pieces[b]…pieces[b+1]−1
    (coefficient_table.CoefficientTable; every matrix here is passed transposed, for _mv). A
    moving block is crossed in ``substeps`` Lawson steps per output interval, E[b] =
    exp(h/2 Ã_ref); a static block interval by interval with E[b] = exp(Δt Ã), exact. Writes y
    at every output index into ``states`` and, on moving blocks, z̈ = A y into
    ``accelerations``. Returns the last y.
    """
    m = y.shape[0]
    n = (m - 1) // 2
    D1 = np.empty((m, n))
    Dm = np.empty((m, n))
    D2 = np.empty((m, n))
    k1, k2, k3, k4, r = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    u, w, a, Ey, v = np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    for q in range(m):
        u[q] = y[q]
    for b in range(first.size):
        i0, i1 = first[b], last[b]
        A_ref = referenceT[b]
        P = ET[b]
        if static[b]:
            for i in range(i0, i1):
                _mv(P, u, w)
                for q in range(m):
                    u[q] = w[q]
                    states[i + 1, q] = w[q]
            continue
        span = t_out[i1] - t_out[i0]
        p0, p1 = pieces[b], pieces[b + 1]
        _delta(polyT, lower, upper, p0, p1, A_ref, 0.0, D1)
        for i in range(i0, i1):
            h = (t_out[i + 1] - t_out[i]) / substeps
            for j in range(substeps):
                tau = (t_out[i] - t_out[i0] + j * h) / span
                dtau = h / span
                _delta(polyT, lower, upper, p0, p1, A_ref, tau + 0.5 * dtau, Dm)
                _delta(polyT, lower, upper, p0, p1, A_ref, tau + dtau, D2)
                _mv(D1, u, k1)
                _copy(u, w)
                _add(w, n, 0.5 * h, k1)
                _mv(P, w, a)
                _mv(Dm, a, k2)
                _mv(P, u, Ey)
                _copy(Ey, w)
                _add(w, n, 0.5 * h, k2)
                _mv(Dm, w, k3)
                _copy(Ey, w)
                _add(w, n, h, k3)
                _mv(P, w, a)  # stage c
                _mv(D2, a, k4)
                _copy(u, w)
                _add(w, n, h / 6.0, k1)
                _mv(P, w, v)
                _add(v, n, h / 3.0, k2)
                _add(v, n, h / 3.0, k3)
                _mv(P, v, u)
                _add(u, n, h / 6.0, k4)
                _copy2(D2, D1)
            for q in range(m):
                states[i + 1, q] = u[q]
            _mv(A_ref, u, r)
            _mv(D2, u, k1)
            for q in range(n):
                accelerations[i + 1, q] = r[q] + k1[q]
    return u


# The one signature `lawson._solve` calls lawson_blocks with (every array C-contiguous).
SIGNATURE = (float64[::1], float64[::1], int64[::1], int64[::1], boolean[::1], int64[::1],
             float64[::1], float64[::1], float64[:, :, :, ::1], float64[:, :, ::1],
             float64[:, :, ::1], int64, float64[:, ::1], float64[:, ::1])


def load() -> None:
    """Make lawson_blocks ready for `SIGNATURE`: load it from numba's cache, or compile it
    (and cache it) on a first run (`lawson.preload_compiled_loop`)."""
    lawson_blocks.compile(SIGNATURE)
