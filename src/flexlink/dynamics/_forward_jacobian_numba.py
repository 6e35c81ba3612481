"""Compiled (numba) Jacobian ∂f/∂y of the forward rates (`_forward_numba.rates`) at many
states, for the sensitivities of a forward run (`solvers.radau_sensitivity`).

The state is y = [p_free, ṗ_free, z, ż, servo integrals]. The rates solve

    E(a; y) = M[:, z] z̈ + r(p̈_free; x, ẋ) − Q = 0   (free and z rows),   a = (p̈_free, z̈),

where M and Q depend on the rigid state only and r = C ẋ + K(p̈) x − f(p̈) is affine in
x = [0; z] and ẋ = [0; ż] at a fixed rigid state and p̈ (docs/derivation.md §10). So along
an elastic coordinate the accelerations move by

    ∂a/∂z_j = −A⁻¹ [r(p̈ = a; x + e_j, ẋ) − r(p̈ = a; x, ẋ)],   A = ∂E/∂a,

exactly for a unit step (likewise ż_j): one residual per column, not two evaluations of the
rates (each 1 + free-coordinate residuals). The rigid coordinates, their rates and the servo
integrals (trigonometric, saturating) take central differences of E at fixed a (one
residual each), ∂a/∂y_c = −A⁻¹ ∂E/∂y_c; a model parameter likewise (`forward_equations`
of the moved model at the nominal a). `project_rows`: the momentum projection of many
states in one call.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._forward_numba import _call_residual, _solve, applied, assemble, load_state
from ._momentum_numba import project


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
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


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _equations(d, w_, u, y, acc, E, want):
    """E = M[:, z] z̈ + r(p̈_free) − Q (free and z rows) at state y, input row u and
    accelerations acc = (p̈_free, z̈): zero at the rates' own accelerations. The servo
    integrals' rates into w_.srates. ``want``: the mass matrix made at y; else w_.M's
    (M reads the configuration only: valid where only rates or integrals moved)."""
    nr = d.n_rigid
    n = d.n_x - nr
    free = d.free
    nu = free.shape[0]
    load_state(d, w_, u, y)
    for j in range(nu):
        w_.pdd[free[j]] = acc[j]
    _call_residual(w_.calls[0], d, w_, w_.p, w_.pd, w_.pdd, w_.x, w_.xd, w_.r0, w_.M, want)
    w_.srates[:] = 0.0
    applied(d, u, w_.p, w_.pd, y[2 * nu + 2 * n:], w_.Q, w_.srates)
    for row in range(nu + n):
        a = free[row] if row < nu else nr + row - nu
        e = w_.r0[a] - w_.Q[a]
        for i in range(n):
            e += w_.M[a, nr + i] * acc[nu + i]
        E[row] = e


def jacobian_scratch(d, w_, m: int) -> tuple:
    """Scratch arrays of `forward_jacobians` for ForwardData d, its Workspace w_ and
    states of m entries (allocated by the caller: the kernel allocates nothing)."""
    q = d.free.shape[0] + d.n_x - d.n_rigid
    e = np.empty
    return (e(m), e(q), e(q), e(w_.srates.shape[0]), e(q), e((q, q)), e(d.n_x), e((q, m)))


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _applied_rows(d, w_, u, y, Q):
    """Q (q,): the applied forces on the free and elastic rows at state y and input row u;
    the servo integrals' rates into w_.srates."""
    nu = d.free.shape[0]
    nr = d.n_rigid
    n = d.n_x - nr
    free = d.free
    load_state(d, w_, u, y)
    w_.srates[:] = 0.0
    applied(d, u, w_.p, w_.pd, y[2 * nu + 2 * n:], w_.Q, w_.srates)
    for row in range(nu + n):
        Q[row] = w_.Q[free[row] if row < nu else nr + row - nu]


@njit(cache=True, _nrt=False)
def forward_jacobians(d, w_, u, states, step, J, A, acc, scratch):
    """J[i] = ∂f/∂y (m, m) of the forward rates at states[i] (n, m) with input rows u[i];
    A[i] = ∂E/∂a (q, q) and acc[i] = a there (`_equations`, q = free + elastic
    coordinates). The rigid coordinates, their rates and the servo integrals: central
    differences of E at fixed a (steps of step · max(1, |y_c|)), ∂a/∂y_c = −A⁻¹ ∂E/∂y_c.
    scratch: `jacobian_scratch`."""
    nu = d.free.shape[0]
    nr = d.n_rigid
    n = d.n_x - nr
    m = states.shape[1]
    q = nu + n
    free = d.free
    yp, E1, E2, s1, a, A0, base, R = scratch
    for i in range(states.shape[0]):
        y = states[i]
        ui = u[i]
        J[i, :, :] = 0.0
        assemble(d, w_, ui, y)  # A and b of the accelerations at y
        for r in range(q):
            a[r] = w_.b[r]
            for c in range(q):
                A0[r, c] = w_.A[r, c]
                A[i, r, c] = w_.A[r, c]
        _solve(w_.A, a)
        for r in range(q):
            acc[i, r] = a[r]
        # rigid rates and servo integrals first, at the mass matrix assemble made at y
        # (M reads the configuration only), then the rigid coordinates with theirs
        for k in range(m - 2 * n):
            c = nu + k if k < m - 2 * n - nu else k - (m - 2 * n - nu)
            if c >= 2 * nu:
                c += 2 * n
            for e in range(m):
                yp[e] = y[e]
            h = step * max(1.0, abs(y[c]))
            yp[c] = y[c] + h
            hi = yp[c]
            moves = c < nu
            drives = c >= 2 * nu + 2 * n  # a servo integral: only the drives read it
            if drives:
                _applied_rows(d, w_, ui, yp, E1)
            else:
                _equations(d, w_, ui, yp, a, E1, moves)
            for e in range(s1.shape[0]):
                s1[e] = w_.srates[e]
            yp[c] = y[c] - h
            span = hi - yp[c]
            if drives:  # E = r + M z̈ − Q: its change, Q's
                _applied_rows(d, w_, ui, yp, E2)
                for r in range(q):
                    R[r, c] = (E1[r] - E2[r]) / span
            else:
                _equations(d, w_, ui, yp, a, E2, moves)
                for r in range(q):
                    R[r, c] = (E2[r] - E1[r]) / span
            for s in range(m - 2 * nu - 2 * n):
                J[i, 2 * nu + 2 * n + s, c] = (s1[s] - w_.srates[s]) / span
        # elastic coordinates and rates: exact (r is affine in them at fixed p̈)
        load_state(d, w_, ui, y)
        for j in range(nu):
            w_.pdd[free[j]] = a[j]
        want = bool(0)
        _call_residual(w_.calls[0], d, w_, w_.p, w_.pd, w_.pdd, w_.x, w_.xd, base, w_.M, want)
        for j in range(n):
            for s in range(2):
                v = w_.x if s == 0 else w_.xd
                held = v[nr + j]
                v[nr + j] = held + 1.0
                _call_residual(w_.calls[0], d, w_, w_.p, w_.pd, w_.pdd, w_.x, w_.xd, w_.rj,
                               w_.M, want)
                v[nr + j] = held  # by value: z + 1 − 1 is not z, and later columns read it
                for row in range(q):
                    b = free[row] if row < nu else nr + row - nu
                    R[row, 2 * nu + s * n + j] = base[b] - w_.rj[b]
        _solve_columns(A0, R)
        for c in range(m):
            for r in range(nu):
                J[i, nu + r, c] = R[r, c]
            for r in range(n):
                J[i, 2 * nu + n + r, c] = R[nu + r, c]
        for j in range(nu):
            J[i, j, nu + j] = 1.0  # dp/dt = ṗ
        for j in range(n):
            J[i, 2 * nu + j, 2 * nu + n + j] = 1.0  # dz/dt = ż


@njit(cache=True, _nrt=False)
def forward_equations(d, w_, u, states, acc, E, srates):
    """E[i] (`_equations`) and the servo integrals' rates srates[i] at states[i] with input
    rows u[i] and accelerations acc[i] (those of another model: E's change with the model
    at fixed accelerations gives their derivative, −A⁻¹ ∂E/∂p)."""
    for i in range(states.shape[0]):
        _equations(d, w_, u[i], states[i], acc[i], E[i], bool(1))
        for s in range(srates.shape[1]):
            srates[i, s] = w_.srates[s]


@njit(cache=True, _nrt=False)
def forward_accelerations(d, w_, u, states, A, acc):
    """A[i] = ∂E/∂a (q, q) and the accelerations acc[i] = a (q,) the rates solve for at
    states[i] with input rows u[i] (`_equations`)."""
    q = acc.shape[1]
    for i in range(states.shape[0]):
        assemble(d, w_, u[i], states[i])
        for r in range(q):
            acc[i, r] = w_.b[r]
            for c in range(q):
                A[i, r, c] = w_.A[r, c]
        _solve(w_.A, acc[i])


@njit(cache=True, _nrt=False)
def project_rows(d, w_, pj, u, U, t, states):
    """Each of states[i] projected in place onto the known momentum at time t[i]
    (`_momentum_numba.project`) with input row u[i] and the inputs' integrals U[i]."""
    for i in range(states.shape[0]):
        project(d, w_, pj, u[i], U[i], t[i], states[i])


@njit(cache=True, _nrt=False)
def forward_applied(d, w_, u, states, Q, srates):
    """The applied forces Q[i] on the free and elastic rows (q,) and the servo integrals'
    rates srates[i] at states[i] with input rows u[i] (`_forward_numba.applied`): the part
    of E (`_equations`, −Q) that a drive's gains move."""
    for i in range(states.shape[0]):
        _applied_rows(d, w_, u[i], states[i], Q[i])
        for s in range(srates.shape[1]):
            srates[i, s] = w_.srates[s]
