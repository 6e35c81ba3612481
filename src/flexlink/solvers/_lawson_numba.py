"""Compiled (numba) step loop of the Lawson integrator (``lawson.py``).

One step is five products with the 17 × 17 block propagator and three evaluations of a
degree-5 polynomial of 8 × 17 matrices for the paper arm: ~4·10³ flops, ~2 µs compiled against
~40 µs as a sequence of numpy calls. Compiled functions are cached on disk (``cache=True``).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _delta(poly, lower, upper, p0, p1, reference, tau, out):  # noqa: ANN001, ANN202
    """out = A(τ) − A_ref for one block whose pieces are p0 … p1−1 (Horner in τ)."""
    p = p0
    while p < p1 - 1 and tau > upper[p]:
        p += 1
    local = (tau - lower[p]) / (upper[p] - lower[p])
    degree = poly.shape[1] - 1
    out[:, :] = poly[p, degree]
    for d in range(degree - 1, -1, -1):
        out *= local
        out += poly[p, d]
    out -= reference


@njit(cache=True)
def _mv(A, x, out):  # noqa: ANN001, ANN202
    """out = A x without allocating (numba's @ allocates a result per call)."""
    for i in range(A.shape[0]):
        acc = 0.0
        for j in range(A.shape[1]):
            acc += A[i, j] * x[j]
        out[i] = acc


@njit(cache=True)
def lawson_blocks(y, t_out, first, last, static, pieces, lower, upper, poly, reference, E,  # noqa: ANN001, ANN201
                  substeps, states, accelerations):
    """Advance the augmented state y = [z, ż, 1] through the blocks, in place.

    Block b spans output indices first[b]..last[b], its polynomials are pieces[b]…pieces[b+1]−1
    (coefficient_table.CoefficientTable); E[b] = exp(h/2 Ã_ref) for its step h (for a
    static block, exp(h Ã) itself, the exact step). Writes y at every output index reached into
    ``states`` and z̈ = A y into ``accelerations``. Returns y after the last block.
    """
    m = y.shape[0]
    n = (m - 1) // 2
    D1 = np.empty((n, m))
    Dm = np.empty((n, m))
    D2 = np.empty((n, m))
    k1, k2, k3, k4, r = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    u, w, a, Ey, v = np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    u[:] = y
    for b in range(first.size):
        i0, i1 = first[b], last[b]
        P = np.ascontiguousarray(E[b])
        A_ref = reference[b]
        if static[b]:
            Q = P.copy()  # one output interval: P^substeps
            for _ in range(substeps - 1):
                Q = Q @ P
            for i in range(i0, i1):
                _mv(Q, u, w)
                u[:] = w
                states[i + 1] = u
                _mv(A_ref, u, r)
                accelerations[i + 1] = r
            continue
        steps = (i1 - i0) * substeps
        h = (t_out[i1] - t_out[i0]) / steps
        delta = 1.0 / steps
        _delta(poly, lower, upper, pieces[b], pieces[b + 1], A_ref, 0.0, D1)
        for j in range(steps):
            tau = j * delta
            _delta(poly, lower, upper, pieces[b], pieces[b + 1], A_ref, tau + 0.5 * delta, Dm)
            _delta(poly, lower, upper, pieces[b], pieces[b + 1], A_ref, tau + delta, D2)
            _mv(D1, u, k1)
            w[:] = u
            w[n:2 * n] += 0.5 * h * k1
            _mv(P, w, a)
            _mv(Dm, a, k2)
            _mv(P, u, Ey)
            w[:] = Ey
            w[n:2 * n] += 0.5 * h * k2
            _mv(Dm, w, k3)
            w[:] = Ey
            w[n:2 * n] += h * k3
            _mv(P, w, a)  # stage c
            _mv(D2, a, k4)
            w[:] = u
            w[n:2 * n] += (h / 6.0) * k1
            _mv(P, w, v)
            v[n:2 * n] += (h / 3.0) * (k2 + k3)
            _mv(P, v, u)
            u[n:2 * n] += (h / 6.0) * k4
            D1[:, :] = D2
            if (j + 1) % substeps == 0:
                i = i0 + (j + 1) // substeps
                states[i] = u
                _mv(A_ref, u, r)
                _mv(D2, u, k1)
                accelerations[i] = r + k1
    return u
