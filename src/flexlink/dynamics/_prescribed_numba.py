"""Compiled (numba) kernels of the prescribed-joint path, built on the forward dynamics'
kernels (`_forward_numba.frames`: the kinematical synthesis at one joint state), which with a
fixed base and prescribed joints compute the frames of `kinematics.frame_motion`
(tests/unit/test_prescribed_kernel.py compares the two to round-off).

Entry points from Python: `state_rows`, M⁻¹[−K, −C, f] at joint states, and `channels`:
`solved_frames`, the frame motion along a solved run and the products of its maps with the
solution, ξ-heads [ρx, ρy, θ1] = T z and their derivatives, at every output time; the maps are
recomputed only where the joint state changes (a rest phase keeps them).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._forward_numba import frames


@njit(cache=True, no_cpython_wrapper=True)
def _scratch(d):
    """p, ṗ, p̈, θ, ω, ω̇ (N), origin accelerations (N, 2) and maps T, Ṫ, T̈ (N, 3, n_x) for
    `_forward_numba.frames`, allocated here: an argument more to unbox per call from Python
    (a Workspace of 26 arrays) lengthened the first run's compilation."""
    N, nx = d.length.shape[0], d.n_x
    return (np.empty(N), np.empty(N), np.empty(N), np.empty(N), np.empty(N), np.empty(N),
            np.empty((N, 2)), np.empty((N, 3, nx)), np.empty((N, 3, nx)), np.empty((N, 3, nx)))


@njit(cache=True, error_model="numpy")
def channels(d, angle, rate, acc, z, zd, zdd, theta, omega, alpha, origin, oacc, xi, xi_d,
             xi_dd, torque, turn):
    """solved_frames, then joint_torques from its outputs: one entry point from Python for
    both (each entry point costs compilation on a first run)."""
    solved_frames(d, angle, rate, acc, z, zd, zdd, theta, omega, alpha, origin, oacc, xi,
                  xi_d, xi_dd, turn)
    joint_torques(d, theta, omega, alpha, origin, oacc, xi, xi_d, xi_dd, z, zd, zdd, torque)


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def solved_frames(d, angle, rate, acc, z, zd, zdd, theta, omega, alpha, origin, oacc,
                  xi, xi_d, xi_dd, turn):
    """Fill, per output time i and link k: θ, ω, ω̇ (nt, N); the frame origin (global, m)
    and its acceleration (frame axes) (nt, N, 2); ξ-heads T z, Ṫ z + T ż, T̈ z + 2Ṫ ż + T z̈
    (nt, N, 3); cos θ, sin θ (nt, N, 2), computed where the joint state changes only.
    angle, rate, acc (nt, N): the joints; z, ż, z̈ (nt, n): the solution. ``d`` is the
    ForwardData of a fixed base (prescribed_kernel.forward_data)."""
    nt, N = angle.shape
    nr = d.n_rigid
    p, pd, pdd, th, om, al, oa, T, Td, Tdd = _scratch(d)
    ox = np.zeros(N)
    oy = np.zeros(N)
    cth = np.zeros(N)
    sth = np.zeros(N)
    for i in range(nt):
        same = i > 0
        if same:
            for k in range(N):
                if (angle[i, k] != angle[i - 1, k] or rate[i, k] != rate[i - 1, k]
                        or acc[i, k] != acc[i - 1, k]):
                    same = False
                    break
        if not same:
            for k in range(N):
                p[k], pd[k], pdd[k] = angle[i, k], rate[i, k], acc[i, k]
            frames(d, p, pd, pdd, th, om, al, oa, T, Td, Tdd)
            x = y = 0.0
            for k in range(N):  # origin of frame k: the rigid tip of link k − 1
                ox[k], oy[k] = x, y
                cth[k], sth[k] = np.cos(th[k]), np.sin(th[k])
                x += d.length[k] * cth[k]
                y += d.length[k] * sth[k]
        for k in range(N):
            theta[i, k], omega[i, k], alpha[i, k] = th[k], om[k], al[k]
            turn[i, k, 0], turn[i, k, 1] = cth[k], sth[k]
            origin[i, k, 0], origin[i, k, 1] = ox[k], oy[k]
            oacc[i, k, 0], oacc[i, k, 1] = oa[k, 0], oa[k, 1]
            # T_k maps the inboard links' coordinates only: its columns from link k's own on
            # are zero (frames zeroes them), and adding their zero products changed no sum.
            nc = 0 if d.attached[k] else d.offset[k - 1] + d.n_modes[k - 1] - nr
            for a in range(3):
                s0 = s1 = s2 = 0.0
                for c in range(nc):
                    t0, t1, t2 = T[k, a, nr + c], Td[k, a, nr + c], Tdd[k, a, nr + c]
                    s0 += t0 * z[i, c]
                    s1 += t0 * zd[i, c] + t1 * z[i, c]
                    s2 += t0 * zdd[i, c] + 2.0 * t1 * zd[i, c] + t2 * z[i, c]
                xi[i, k, a], xi_d[i, k, a], xi_dd[i, k, a] = s0, s1, s2


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _link_matrices(o, nk, mass, s1, J, Jt, length, stiffening, Mtot, M0, G0, phi_bar,
                   phi_tilde, tip_value, rot_slope, stiffness, damping, fore_mass, fore_moment,
                   fore_tip, k, nr, n, w, wd, ax, ay, N_out, T, Td, Tdd, Th, Thd, Thdd, X, Y, Z,
                   M, C, K, f, lateral, sy, lat_slope, lat_tilde, lat_fore, lat_fore_moment):
    """Add link k's terms to M, C, K, f (n × n, n) of the elastic coordinates, as
    first_order.add_link_terms with rigid_load and second_order_stiffness (docs/derivation.md
    §3–4): T̂ᵀ M_t T̂, T̂ᵀ(2M_t Ṫ̂ + 2ω G₀T̂), T̂ᵀ(M_t T̈̂ + 2ω G₀ Ṫ̂ + (ω̇G₀ − ω²M₀)T̂) − S₂ + K_e,
    −T̂ᵀ load, D. Link k's data (ForwardData's arrays at k; o its first coordinate in z)
    come as arguments: passing the whole ForwardData down made this slower to compile."""
    mk = 3 + nk
    # T_k depends on the coordinates of the links inboard of k only: every column of T̂ past
    # link k's own is zero, and so are the rows and columns of its terms there.
    nc = o + nk
    # T̂ = [T_k; E_k] restricted to z, E_k picking q_k (constant: its derivatives are zero).
    # Products with T̂ are written out: the three rows of T_k, plus column o + i of E_k.
    for a in range(3):
        for c in range(nc):
            Th[a, c], Thd[a, c], Thdd[a, c] = T[k, a, nr + c], Td[k, a, nr + c], \
                Tdd[k, a, nr + c]
    w2 = w * w
    # X = M_t T̂, Y = 2M_t Ṫ̂ + 2ω G₀ T̂, Z = M_t T̈̂ + 2ω G₀ Ṫ̂ + (ω̇ G₀ − ω² M₀) T̂, (3+n_k) × n.
    for a in range(mk):
        # Along rows (the inner loop vectorises), each entry summed over b = 0, 1, 2 in order
        # with the factors of the terms grouped as before: the same results, bit for bit.
        m_0, m_1, m_2 = Mtot[a, 0], Mtot[a, 1], Mtot[a, 2]
        d_0, d_1, d_2 = 2.0 * m_0, 2.0 * m_1, 2.0 * m_2
        g_0, g_1, g_2 = 2.0 * w * G0[a, 0], 2.0 * w * G0[a, 1], 2.0 * w * G0[a, 2]
        s_0 = wd * G0[a, 0] - w2 * M0[a, 0]
        s_1 = wd * G0[a, 1] - w2 * M0[a, 1]
        s_2 = wd * G0[a, 2] - w2 * M0[a, 2]
        for c in range(nc):
            X[a, c] = (m_0 * Th[0, c] + m_1 * Th[1, c]) + m_2 * Th[2, c]
        for c in range(nc):
            Y[a, c] = ((d_0 * Thd[0, c] + g_0 * Th[0, c]) + (d_1 * Thd[1, c] + g_1 * Th[1, c])
                       + (d_2 * Thd[2, c] + g_2 * Th[2, c]))
        for c in range(nc):
            Z[a, c] = (((m_0 * Thdd[0, c] + g_0 * Thd[0, c]) + s_0 * Th[0, c])
                       + ((m_1 * Thdd[1, c] + g_1 * Thd[1, c]) + s_1 * Th[1, c])
                       + ((m_2 * Thdd[2, c] + g_2 * Thd[2, c]) + s_2 * Th[2, c]))
        for i in range(nk):
            b = 3 + i
            g = G0[a, b]
            X[a, o + i] += Mtot[a, b]
            Y[a, o + i] += 2.0 * w * g
            Z[a, o + i] += wd * g - w2 * M0[a, b]
    # M += T̂ᵀ X, C += T̂ᵀ Y, K += T̂ᵀ Z, along rows (the inner loop vectorises; per entry the
    # sum over the three rows of T_k in the order a = 0, 1, 2, as a loop over a would).
    for c1 in range(nc):
        t0, t1, t2 = Th[0, c1], Th[1, c1], Th[2, c1]
        for c2 in range(nc):
            M[c1, c2] += (t0 * X[0, c2] + t1 * X[1, c2]) + t2 * X[2, c2]
        for c2 in range(nc):
            C[c1, c2] += (t0 * Y[0, c2] + t1 * Y[1, c2]) + t2 * Y[2, c2]
        for c2 in range(nc):
            K[c1, c2] += (t0 * Z[0, c2] + t1 * Z[1, c2]) + t2 * Z[2, c2]
    for i in range(nk):
        for c2 in range(nc):
            M[o + i, c2] += X[3 + i, c2]
        for c2 in range(nc):
            C[o + i, c2] += Y[3 + i, c2]
        for c2 in range(nc):
            K[o + i, c2] += Z[3 + i, c2]
    # Zero-order inertia load (first_order.rigid_load): f −= T̂ᵀ load.
    l0 = mass * ax - w2 * s1
    l1 = mass * ay + wd * s1
    l2 = s1 * ay + J * wd + Jt * wd
    if lateral:  # bodies' centres across the link
        l0 -= wd * sy
        l1 -= w2 * sy
        l2 -= ax * sy
    for c in range(nc):
        f[c] -= Th[0, c] * l0 + Th[1, c] * l1 + Th[2, c] * l2
    for i in range(nk):
        f[o + i] -= (ay * phi_bar[i] + wd * phi_tilde[i]
                     + wd * rot_slope[i])
        if lateral:
            f[o + i] -= w2 * lat_tilde[i] - ax * lat_slope[i]
    # Second-order stiffness (first_order.second_order_stiffness): K −= S₂.
    scal = ax * s1 - w2 * J + N_out * length + ay * sy
    for c1 in range(nc):
        for c2 in range(nc):
            K[c1, c2] -= scal * Th[2, c1] * Th[2, c2]
    for i in range(nk):
        vec = ax * phi_bar[i] - w2 * phi_tilde[i] + N_out * tip_value[i]
        if lateral:
            vec += ay * lat_slope[i] + wd * lat_tilde[i]
        for c in range(nc):
            K[c, o + i] -= Th[2, c] * vec
            K[o + i, c] -= Th[2, c] * vec
    for i in range(nk):
        for j in range(nk):
            if stiffening:
                K[o + i, o + j] -= (ax * fore_mass[i, j] - w2 * fore_moment[i, j]
                                    + N_out * fore_tip[i, j])
                if lateral:
                    K[o + i, o + j] -= ay * lat_fore[i, j] + wd * lat_fore_moment[i, j]
            K[o + i, o + j] += stiffness[i, j]
            C[o + i, o + j] += damping[i, j]


@njit(cache=True, error_model="numpy", nogil=True)  # nogil: `split_state_rows`
def state_rows(d, angle, rate, acc, out):
    """out[i] = M⁻¹[−K, −C, f] (n, 2n+1) of the first-order model at joint states angle, rate,
    acc (nt, N) (magnus.state_rows of FirstOrderSystem.matrices, without actuators)."""
    nt, N = angle.shape
    nr = d.n_rigid
    n = out.shape[1]
    m = 3 + d.phi_bar.shape[1]
    p, pd, pdd, th, om, al, oa, T, Td, Tdd = _scratch(d)
    Th, Thd, Thdd = np.empty((m, n)), np.empty((m, n)), np.empty((m, n))
    X, Y, Z = np.empty((m, n)), np.empty((m, n)), np.empty((m, n))
    M, C, K, f = np.empty((n, n)), np.empty((n, n)), np.empty((n, n)), np.empty(n)
    outboard = np.empty((N, 2))
    for i in range(nt):
        for k in range(N):
            p[k], pd[k], pdd[k] = angle[i, k], rate[i, k], acc[i, k]
        frames(d, p, pd, pdd, th, om, al, oa, T, Td, Tdd)
        # Σ_{j>k} ∫ a0 dm in frame k's axes (FirstOrderSystem._outboard_inertia_force).
        outboard[N - 1, 0] = outboard[N - 1, 1] = 0.0
        for k in range(N - 2, -1, -1):
            j = k + 1
            fx = (outboard[j, 0] + d.mass[j] * oa[j, 0] - om[j] * om[j] * d.s1[j]
                  - al[j] * d.sy[j])
            fy = (outboard[j, 1] + d.mass[j] * oa[j, 1] + al[j] * d.s1[j]
                  - om[j] * om[j] * d.sy[j])
            turn = th[j] - th[k]
            cb, sb = np.cos(turn), np.sin(turn)
            outboard[k, 0] = cb * fx - sb * fy
            outboard[k, 1] = sb * fx + cb * fy
        for a in range(n):
            f[a] = 0.0
            for b in range(n):
                M[a, b] = C[a, b] = K[a, b] = 0.0
        for k in range(N):
            _link_matrices(d.offset[k] - nr, d.n_modes[k], d.mass[k], d.s1[k], d.J[k],
                           d.Jt[k], d.length[k], d.stiffening, d.Mtot[k], d.M0[k], d.G0[k],
                           d.phi_bar[k], d.phi_tilde[k], d.tip_value[k], d.rot_slope[k],
                           d.stiffness[k], d.damping[k], d.fore_mass[k], d.fore_moment[k],
                           d.fore_tip[k], k, nr, n, om[k], al[k], oa[k, 0], oa[k, 1],
                           outboard[k, 0], T, Td, Tdd, Th, Thd, Thdd, X, Y, Z, M, C, K, f,
                           d.lateral[k], d.sy[k], d.lat_slope[k], d.lat_tilde[k], d.lat_fore[k],
                           d.lat_fore_moment[k])
        rhs = out[i]  # solved in place
        for a in range(n):
            for b in range(n):
                rhs[a, b] = -K[a, b]
                rhs[a, n + b] = -C[a, b]
            rhs[a, 2 * n] = f[a]
        _solve_many(M, rhs)


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _subtract_rows(B, i, L, k0, k1, transposed):
    """B[i, :] −= Σ_{k0 ≤ k < k1} c_k B[k, :], c_k = L[i, k] (transposed: L[k, i]).

    Whole rows of B (vectorised over its 2n+1 columns), four per pass over B[i, :]: a quarter
    of its loads and stores; each entry sums in a fixed order."""
    r = B.shape[1]
    k = k0
    while k + 4 <= k1:
        if transposed:
            a0, a1, a2, a3 = L[k, i], L[k + 1, i], L[k + 2, i], L[k + 3, i]
        else:
            a0, a1, a2, a3 = L[i, k], L[i, k + 1], L[i, k + 2], L[i, k + 3]
        for j in range(r):
            B[i, j] -= (a0 * B[k, j] + a1 * B[k + 1, j]) + (a2 * B[k + 2, j] + a3 * B[k + 3, j])
        k += 4
    while k < k1:
        a = L[k, i] if transposed else L[i, k]
        for j in range(r):
            B[i, j] -= a * B[k, j]
        k += 1


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def _solve_many(A, B):
    """B ← A⁻¹ B for the symmetric positive definite mass matrix A (destroyed: its Cholesky
    factor L, A = L Lᵀ, in the lower triangle), then L y = B and Lᵀ x = y row by row.

    Half the factorisation of Gaussian elimination and no pivoting; the substitutions run
    along rows of B (contiguous in memory; down its columns the solve was most of a ten-link
    sample's cost). A matrix that is not positive definite (a blown-up state) gives NaN:
    the table then reports non-finite coefficients."""
    n, r = B.shape
    for c in range(n):
        s = A[c, c]
        for k in range(c):
            s -= A[c, k] * A[c, k]
        if not s > 0.0:
            for i in range(n):
                for j in range(r):
                    B[i, j] = np.nan
            return
        d = np.sqrt(s)
        A[c, c] = d
        inv = 1.0 / d
        for i in range(c + 1, n):
            s = A[i, c]
            for k in range(c):
                s -= A[i, k] * A[c, k]
            A[i, c] = s * inv
    for i in range(n):
        _subtract_rows(B, i, A, 0, i, False)
        inv = 1.0 / A[i, i]
        for j in range(r):
            B[i, j] *= inv
    for i in range(n - 1, -1, -1):
        _subtract_rows(B, i, A, i + 1, n, True)
        inv = 1.0 / A[i, i]
        for j in range(r):
            B[i, j] *= inv


@njit(cache=True, no_cpython_wrapper=True, error_model="numpy")
def joint_torques(d, theta, omega, alpha, origin, oacc, xi, xi_d, xi_dd, z, zd, zdd, out):
    """out[i, k] = motor torque of joint k (N·m) at output time i, dynamics/torques.py's
    τ_k = Σ_{j≥k} [∫_j (r − P_k) × r̈ dm + J_t,j ϑ̈_j] to first order in z, from the frames
    along the solution (solved_frames' outputs) and z, ż, z̈ (nt, n). ``d``: ForwardData of
    a fixed base. Written out per time (torques._link_moment); compared with the numpy
    function to round-off in tests/unit/test_prescribed_kernel.py."""
    nt, N = theta.shape
    nr = d.n_rigid
    # What depends on the frames' angles and origins only (their sines and cosines were most
    # of this kernel's time), per row of joints: recomputed where the frames change, not in
    # a rest phase. dx, dy: A(θ_j)ᵀ (origin_j − origin_k); ct, st: cos, sin (θ_k − θ_j).
    dx_, dy_ = np.empty((N, N)), np.empty((N, N))
    ct_, st_ = np.empty((N, N)), np.empty((N, N))
    for i in range(nt):
        same = i > 0
        if same:
            for k in range(N):
                if (theta[i, k] != theta[i - 1, k] or origin[i, k, 0] != origin[i - 1, k, 0]
                        or origin[i, k, 1] != origin[i - 1, k, 1]):
                    same = False
                    break
        if not same:
            for j in range(N):
                cj, sj = np.cos(theta[i, j]), np.sin(theta[i, j])
                for k in range(j + 1):
                    vx = origin[i, j, 0] - origin[i, k, 0]
                    vy = origin[i, j, 1] - origin[i, k, 1]
                    dx_[j, k], dy_[j, k] = cj * vx + sj * vy, -sj * vx + cj * vy
                    turn = theta[i, k] - theta[i, j]
                    ct_[j, k], st_[j, k] = np.cos(turn), np.sin(turn)
        for k in range(N):
            out[i, k] = 0.0
        for j in range(N):
            o, nj = d.offset[j] - nr, d.n_modes[j]
            m, s1, J, Jt = d.mass[j], d.s1[j], d.J[j], d.Jt[j]
            w, wd = omega[i, j], alpha[i, j]
            w2 = w * w
            ax, ay = oacc[i, j, 0], oacc[i, j, 1]
            Fx, Fy = m * ax - w2 * s1, m * ay + wd * s1  # ∫ a⁰ dm
            # ξ_j = [ρx, ρy, θ1, q_j]: its products with ny, hy, φ̄, φ̃ and c.
            r0, r1, r2 = xi[i, j, 0], xi[i, j, 1], xi[i, j, 2]
            Gy = m * r1 + s1 * r2
            Gy_d = m * xi_d[i, j, 1] + s1 * xi_d[i, j, 2]
            Gy_dd = m * xi_dd[i, j, 1] + s1 * xi_dd[i, j, 2]
            Hy = s1 * r1 + J * r2
            Hy_dd = s1 * xi_dd[i, j, 1] + J * xi_dd[i, j, 2]
            qb = qt = 0.0
            tilt = Jt * xi_dd[i, j, 2]  # Σ J_b ϑ̈_b
            for q in range(nj):
                qb += z[i, o + q] * d.phi_bar[j, q]
                qt += z[i, o + q] * d.phi_tilde[j, q]
                Gy += d.phi_bar[j, q] * z[i, o + q]
                Gy_d += d.phi_bar[j, q] * zd[i, o + q]
                Gy_dd += d.phi_bar[j, q] * zdd[i, o + q]
                Hy += d.phi_tilde[j, q] * z[i, o + q]
                Hy_dd += d.phi_tilde[j, q] * zdd[i, o + q]
                tilt += d.rot_slope[j, q] * zdd[i, o + q]
            rx_d, rx_dd = xi_d[i, j, 0], xi_dd[i, j, 0]
            a1x = m * rx_dd - 2 * w * Gy_d - wd * Gy - w2 * m * r0  # ∫ a¹ dm
            a1y = Gy_dd + 2 * w * m * rx_d + wd * m * r0 - w2 * Gy
            x_a1y = Hy_dd + 2 * w * s1 * rx_d + wd * s1 * r0 - w2 * Hy  # ∫ x a¹_y dm
            g_cross_a0 = (r0 * (m * ay + s1 * wd) - r1 * Fx - r2 * (s1 * ax - w2 * J)
                          - qb * ax + w2 * qt)
            own = s1 * ay + (J + Jt) * wd + g_cross_a0 + x_a1y + tilt
            sy = d.sy[j]
            if d.lateral[j]:  # bodies' centres across the link (torques._link_moment)
                gx, gx_d, gx_dd = -sy * r2, -sy * xi_d[i, j, 2], -sy * xi_dd[i, j, 2]
                dot, dot_d = sy * r1, sy * xi_d[i, j, 1]
                for q in range(nj):
                    gx -= d.lat_slope[j, q] * z[i, o + q]
                    gx_d -= d.lat_slope[j, q] * zd[i, o + q]
                    gx_dd -= d.lat_slope[j, q] * zdd[i, o + q]
                    dot -= d.lat_tilde[j, q] * z[i, o + q]
                    dot_d -= d.lat_tilde[j, q] * zd[i, o + q]
                hy, hy_dd = -sy * r0, -sy * rx_dd
                a1x += gx_dd - w2 * gx
                a1y += 2 * w * gx_d + wd * gx
                own += (-sy * ax + (hy_dd + 2 * w * dot_d + wd * dot - w2 * hy)
                        + (ay * gx + wd * dot + w2 * hy))
                Fx -= wd * sy
                Fy -= w2 * sy
            for k in range(j + 1):
                # d = A(θ_j)ᵀ (origin_j − origin_k); p1 = A(θ_k − θ_j) ρ_k (frame-j axes).
                dx, dy = dx_[j, k], dy_[j, k]
                ct, st = ct_[j, k], st_[j, k]
                px = ct * xi[i, k, 0] - st * xi[i, k, 1]
                py = st * xi[i, k, 0] + ct * xi[i, k, 1]
                out[i, k] += (own + (dx * Fy - dy * Fx) - (px * Fy - py * Fx)
                              + (dx * a1y - dy * a1x))
