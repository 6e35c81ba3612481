"""Compiled (numba) Jacobian ∂f/∂y of the forward rates (`_forward_numba.rates`) at many
states, for the sensitivities of a forward run (`solvers.radau_sensitivity`).

The state is y = [p_free, ṗ_free, z, ż, servo integrals]. The rates solve

    E(a; y) = M[:, z] z̈ + r(p̈_free; x, ẋ) − Q = 0   (free and z rows),   a = (p̈_free, z̈),

where M and Q depend on the rigid state only and r = C ẋ + K(p̈) x − f(p̈) is affine in
x = [0; z] and ẋ = [0; ż] at a fixed rigid state and p̈ (docs/derivation.md §10). So along
an elastic coordinate the accelerations move by

    ∂a/∂z_j = −A⁻¹ [r(p̈ = a; x + e_j, ẋ) − r(p̈ = a; x, ẋ)],   A = ∂E/∂a,

exactly for a unit step (likewise ż_j): one residual per column, not two evaluations of the
rates. The rigid coordinates, their rates and the servo integrals (trigonometric, saturating)
take central differences of the rates.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._forward_numba import _solve, assemble, rates, residual


@njit(cache=True)
def _solve_columns(A, B):
    """Solve A X = B in place (B ← X, A destroyed) by Gaussian elimination with partial
    pivoting, for all of B's columns."""
    n, k = B.shape
    for c in range(n):
        piv = c
        big = abs(A[c, c])
        for i in range(c + 1, n):
            if abs(A[i, c]) > big:
                big, piv = abs(A[i, c]), i
        if piv != c:
            for j in range(n):
                A[c, j], A[piv, j] = A[piv, j], A[c, j]
            for j in range(k):
                B[c, j], B[piv, j] = B[piv, j], B[c, j]
        if A[c, c] == 0.0:
            B[:, :] = np.nan
            return
        inv = 1.0 / A[c, c]
        for i in range(c + 1, n):
            f = A[i, c] * inv
            if f != 0.0:
                for j in range(c, n):
                    A[i, j] -= f * A[c, j]
                for j in range(k):
                    B[i, j] -= f * B[c, j]
    for j in range(k):
        for i in range(n - 1, -1, -1):
            acc = B[i, j]
            for c in range(i + 1, n):
                acc -= A[i, c] * B[c, j]
            B[i, j] = acc / A[i, i]


@njit(cache=True)
def forward_jacobians(d, w_, u, states, step, J):
    """J[i] = ∂f/∂y (m, m) of the forward rates at states[i] (n, m) with input rows u[i];
    the central differences' steps are step · max(1, |y_c|)."""
    nu = d.free.shape[0]
    nr = d.n_rigid
    n = d.n_x - nr
    m = states.shape[1]
    q = nu + n
    free = d.free
    yp = np.empty(m)
    f1, f2 = np.empty(m), np.empty(m)
    A0 = np.empty((q, q))
    acc = np.empty(q)
    base = np.empty(d.n_x)
    R = np.empty((q, 2 * n))
    for i in range(states.shape[0]):
        y = states[i]
        ui = u[i]
        for c in range(m):  # rigid coordinates, their rates, servo integrals
            if 2 * nu <= c < 2 * nu + 2 * n:
                continue
            yp[:] = y
            h = step * max(1.0, abs(y[c]))
            yp[c] = y[c] + h
            hi = yp[c]
            rates(d, w_, ui, yp, f1)
            yp[c] = y[c] - h
            span = hi - yp[c]
            rates(d, w_, ui, yp, f2)
            for r in range(m):
                J[i, r, c] = (f1[r] - f2[r]) / span
        if n == 0:
            continue
        for r in range(m):
            for c in range(2 * nu, 2 * nu + 2 * n):
                J[i, r, c] = 0.0
        assemble(d, w_, ui, y)  # w_.p, pd, x, xd at y; A and b of the accelerations
        for r in range(q):
            acc[r] = w_.b[r]
            for c in range(q):
                A0[r, c] = w_.A[r, c]
        _solve(w_.A, acc)  # A0 kept for the columns
        for j in range(nu):
            w_.pdd[free[j]] = acc[j]
        want = bool(0)
        residual(d, w_, w_.p, w_.pd, w_.pdd, w_.x, w_.xd, base, w_.M, want)
        for j in range(n):
            for s in range(2):
                v = w_.x if s == 0 else w_.xd
                v[nr + j] += 1.0
                residual(d, w_, w_.p, w_.pd, w_.pdd, w_.x, w_.xd, w_.rj, w_.M, want)
                v[nr + j] -= 1.0
                for row in range(q):
                    a = free[row] if row < nu else nr + row - nu
                    R[row, s * n + j] = base[a] - w_.rj[a]
        _solve_columns(A0, R)
        for j in range(n):
            for s in range(2):
                c = 2 * nu + s * n + j
                for a in range(nu):
                    J[i, nu + a, c] = R[a, s * n + j]
                for a in range(n):
                    J[i, 2 * nu + n + a, c] = R[nu + a, s * n + j]
            J[i, 2 * nu + j, 2 * nu + n + j] = 1.0  # dż/dt = ż
        for j in range(nu):
            w_.pdd[free[j]] = 0.0
