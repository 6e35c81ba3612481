"""Compiled (numba) kernels of the forward dynamics: the coupled equations of
`dynamics.forward.ForwardSystem` at one state, written as loops over tiny arrays.

The numpy `ForwardSystem` stays the reference (docs/derivation.md §10); `tests/unit/
test_forward_kernel.py` compares the two to round-off on random states of several systems.
The data layout (`ForwardData`, the input row) is built by `dynamics/forward_kernel.py`.

Differences of form, not of physics: the kernel never forms C and K. With x = [0; z] only
their products with ż and z enter, so it forms

    r(p̈) = C ẋ + K(p̈) x − f(p̈)   (n_x,)

link by link from ξ = T̂ z, ξ̇ = Ṫ̂ z + T̂ ż, … (mat-vec, not mat-mat), M once, and the columns
∂r/∂p̈_j (r is affine in p̈, §10) as differences of the terms p̈ enters (`acceleration_terms`,
with the frames' accelerations) at unit p̈_j and at p̈ = 0: the terms it does not enter
(`velocity_terms`, the larger part) are evaluated once. The attachment-turn term of K
(ForwardSystem._attachment_turn) multiplies δθ_b = 0 and drops out.

The kernels that allocate nothing (these, and their helpers in _elastic_numba,
_prismatic_numba, _momentum_numba) are compiled with ``_nrt=False``, numba's flag for code
without runtime allocation (its own allocation-free helpers use it): otherwise every call
increfs and decrefs each array of the ForwardData and Workspace records it is passed, ~60
atomic pairs, which cost more than the arithmetic of a servo's drive. A kernel that needs to
allocate fails to compile under the flag rather than running slowly.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit, typeof, types
from numba.extending import intrinsic

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from .._compiled_calls import MATRIX, ROW, address, call_codegen, check, load, type_key
from . import _elastic_numba as elastic
from ._prismatic_numba import lever_stiffness

Workspace = namedtuple("Workspace", [
    "theta", "omega", "alpha", "oacc", "T", "Td", "Tdd", "own", "out", "xi", "xi_d", "xi_dd", "v", "TM",
    "p", "pd", "pdd", "x", "xd", "r0", "rj", "M", "Q", "srates", "A", "b", "ra", "g0xi", "t1x",
    "foreq", "calls"])
Workspace.__doc__ = ("Scratch arrays of the kernels (allocated once per run: see workspace); "
                     "calls: the addresses of the compiled code they call (`_call_residual`).")


def workspace(d, n_servos: int, calls: bool = True) -> Workspace:
    """Scratch arrays for ForwardData d: allocation inside the kernels cost more than the
    arithmetic of the tiny matrices. ``calls`` False: w.calls left 0 (nothing compiled), for
    kernels that never evaluate the model (a closed loop's kinematics)."""
    N, nx, nr = d.length.shape[0], d.n_x, d.n_rigid
    m = 3 + d.phi_bar.shape[1]
    nu = d.free.shape[0]
    e = np.empty
    w = Workspace(e(N), e(N), e(N), e((N, 2)), e((N, 3, nx)), e((N, 3, nx)), e((N, 3, nx)),
                  e((N, 2)), e((N, 2)), e(m), e(m), e(m), e(m), e((m, nx)),
                  e(nr), e(nr), e(nr), e(nx), e(nx), e(nx), e(nx), e((nx, nx)), e(nx),
                  e(max(n_servos, 1)), e((nu + nx - nr, nu + nx - nr)), e(nu + nx - nr),
                  e(nx), e((N, m)), e(N), e((N, 4, m - 3)), np.zeros(1, dtype=np.int64))
    if calls:
        w.calls[0] = _residual_address(d, w)
    return w


_RESIDUALS: dict[object, int] = {}  # type_key of (d, w) → address of their compiled residual


def _residual_address(d, w: Workspace) -> int:
    """The address of `residual` compiled for ForwardData d and Workspace w."""
    key = type_key((d, w))
    found = _RESIDUALS.get(key)
    if found is None:
        found = _RESIDUALS[key] = address(residual, (typeof(d), typeof(w)) + _RESIDUAL_ROWS)
    return found

# Joint kinds in ForwardData.joint_kind.
PRESCRIBED, TORQUE, VELOCITY_SERVO, POSITION_SERVO, ELASTIC = 0, 1, 2, 3, 4
# Base kinds in ForwardData.base_kind.
FIXED, PINNED, FREE, CART = 0, 1, 2, 3


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def base_acceleration(d, pdd):
    """The base reference point's acceleration minus gravity, global axes (m/s²): where
    gravity enters the compiled first-order model (kinematics.inertial_acceleration: by the
    equivalence principle, the field g is the base's extra acceleration −g in the synthesis
    and in the free base's own inertia)."""
    if d.base_kind == FREE:
        return pdd[0] - d.gravity[0], pdd[1] - d.gravity[1]
    if d.base_kind == CART:  # s̈ along the rail
        return pdd[0] * d.rail[0] - d.gravity[0], pdd[0] * d.rail[1] - d.gravity[1]
    return -d.gravity[0], -d.gravity[1]


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def map_columns(d, k):
    """How many leading columns of x = [δp; z] frame k's maps T̂_k can have nonzero (s):
    the rigid coordinates' and the modes of the links it hangs on, which come before its
    own. The loops over a map's columns stop there: the rest are zero."""
    columns = d.n_rigid
    j = k
    while j > 0 and not d.attached[j]:
        j -= 1
        columns = max(columns, d.offset[j] + d.n_modes[j])
    return columns


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def frames(d, p, pd, pdd, theta, omega, alpha, oacc, T, Td, Tdd):
    """Fill the zero-order frame angles, rates, accelerations, origin accelerations (frame
    axes) and the maps x → [ρx, ρy, θ1] of every link with their time derivatives
    (ForwardSystem.frames; docs/derivation.md §2 and §10: rigid perturbations are extra
    columns)."""
    N = d.length.shape[0]
    nb = d.n_base
    T[:] = 0.0
    Td[:] = 0.0
    Tdd[:] = 0.0
    bax, bay = base_acceleration(d, pdd)  # its position does not enter
    th_b = w_b = a_b = 0.0
    if d.base_kind == FREE or d.base_kind == PINNED:
        th_b, w_b, a_b = p[nb - 1], pd[nb - 1], pdd[nb - 1]
    elif d.base_kind == CART:  # its attitude is constant
        th_b = d.attitude
    for k in range(N):
        beta, bd, bdd = p[nb + k], pd[nb + k], pdd[nb + k]
        if d.slide[k]:  # a slider: its coordinate is the travel, the angle constant
            beta, bd, bdd = d.slide_angle[k], 0.0, 0.0
        cb, sb = np.cos(beta), np.sin(beta)
        # back = A(−β), back_d = −β̇ S back, back_dd = (−β̈ S − β̇² I) back
        b00, b01, b10, b11 = cb, sb, -sb, cb
        d00, d01, d10, d11 = -bd * sb, bd * cb, -bd * cb, -bd * sb
        e00 = -bdd * (-b10) - bd * bd * b00
        e01 = -bdd * (-b11) - bd * bd * b01
        e10 = -bdd * b00 - bd * bd * b10
        e11 = -bdd * b01 - bd * bd * b11
        if d.attached[k]:
            theta[k] = th_b + beta
            omega[k] = w_b + bd
            alpha[k] = a_b + bdd
            ct, st = np.cos(th_b), np.sin(th_b)
            px, py = d.point[k, 0], d.point[k, 1]
            cx, cy = ct * px - st * py, st * px + ct * py
            ax = bax - a_b * cy - w_b * w_b * cx
            ay = bay + a_b * cx - w_b * w_b * cy
            ck, sk = np.cos(theta[k]), np.sin(theta[k])
            oacc[k, 0] = ck * ax + sk * ay
            oacc[k, 1] = -sk * ax + ck * ay
            if d.base_kind == FREE:  # δx, δy: a global translation seen in frame k
                w, a = omega[k], alpha[k]
                A00, A01, A10, A11 = ck, sk, -sk, ck  # A(−θ)
                T[k, 0, 0], T[k, 0, 1], T[k, 1, 0], T[k, 1, 1] = A00, A01, A10, A11
                Td[k, 0, 0], Td[k, 0, 1] = w * A10, w * A11
                Td[k, 1, 0], Td[k, 1, 1] = -w * A00, -w * A01
                Tdd[k, 0, 0] = a * A10 - w * w * A00
                Tdd[k, 0, 1] = a * A11 - w * w * A01
                Tdd[k, 1, 0] = -a * A00 - w * w * A10
                Tdd[k, 1, 1] = -a * A01 - w * w * A11
            elif d.base_kind == CART:  # δs: a translation along the rail seen in frame k
                w, a = omega[k], alpha[k]
                ex, ey = d.rail[0], d.rail[1]
                u0, u1 = ck * ex + sk * ey, -sk * ex + ck * ey  # A(−θ) e
                T[k, 0, 0], T[k, 1, 0] = u0, u1
                Td[k, 0, 0], Td[k, 1, 0] = w * u1, -w * u0
                Tdd[k, 0, 0] = a * u1 - w * w * u0
                Tdd[k, 1, 0] = -a * u0 - w * w * u1
            if d.base_kind == FREE or d.base_kind == PINNED:  # δθ_b turns the attachment
                # point and the frame
                scx, scy = -py, px
                j = nb - 1
                T[k, 0, j] = b00 * scx + b01 * scy
                T[k, 1, j] = b10 * scx + b11 * scy
                Td[k, 0, j] = d00 * scx + d01 * scy
                Td[k, 1, j] = d10 * scx + d11 * scy
                Tdd[k, 0, j] = e00 * scx + e01 * scy
                Tdd[k, 1, j] = e10 * scx + e11 * scy
                T[k, 2, j] = 1.0
        else:  # on the deformed tip of link k − 1: T_k = blockdiag(back, 1) P̃ T̂_{k−1}
            j = k - 1
            L = d.length[j]
            theta[k] = theta[j] + beta
            omega[k] = omega[j] + bd
            alpha[k] = alpha[j] + bdd
            tx = oacc[j, 0] - L * omega[j] * omega[j]
            ty = oacc[j, 1] + L * alpha[j]
            ux = uy = s = sd = sdd = 0.0
            if d.slide[k]:  # the block on its line (prismatic.lever)
                ux, uy = d.slide_axis[k, 0], d.slide_axis[k, 1]
                s, sd, sdd = p[nb + k], pd[nb + k], pdd[nb + k]
                along = sdd - omega[j] * omega[j] * s
                across = 2.0 * omega[j] * sd + alpha[j] * s
                tx += along * ux - across * uy
                ty += along * uy + across * ux
            oacc[k, 0] = b00 * tx + b01 * ty
            oacc[k, 1] = b10 * tx + b11 * ty
            o, nj = d.offset[j], d.n_modes[j]
            for c in range(map_columns(d, k)):
                # U = P̃ T̂_{j}: rows ρx, ρy + L θ1 (+ Φ(L) q), θ1 (+ Φ'(L) q)
                u0, u1, u2 = T[j, 0, c], T[j, 1, c] + L * T[j, 2, c], T[j, 2, c]
                v0, v1, v2 = Td[j, 0, c], Td[j, 1, c] + L * Td[j, 2, c], Td[j, 2, c]
                w0, w1, w2 = Tdd[j, 0, c], Tdd[j, 1, c] + L * Tdd[j, 2, c], Tdd[j, 2, c]
                if o <= c < o + nj:
                    u1 += d.tip_value[j, c - o]
                    u2 += d.tip_slope[j, c - o]
                if d.slide[k]:  # the lever L(s) and its derivatives
                    w0 -= uy * (s * w2 + 2.0 * sd * v2 + sdd * u2)
                    w1 += ux * (s * w2 + 2.0 * sd * v2 + sdd * u2)
                    v0 -= uy * (s * v2 + sd * u2)
                    v1 += ux * (s * v2 + sd * u2)
                    u0 -= uy * s * u2
                    u1 += ux * s * u2
                T[k, 0, c] = b00 * u0 + b01 * u1
                T[k, 1, c] = b10 * u0 + b11 * u1
                T[k, 2, c] = u2
                Td[k, 0, c] = d00 * u0 + d01 * u1 + b00 * v0 + b01 * v1
                Td[k, 1, c] = d10 * u0 + d11 * u1 + b10 * v0 + b11 * v1
                Td[k, 2, c] = v2
                Tdd[k, 0, c] = e00 * u0 + e01 * u1 + 2.0 * (d00 * v0 + d01 * v1) \
                    + b00 * w0 + b01 * w1
                Tdd[k, 1, c] = e10 * u0 + e11 * u1 + 2.0 * (d10 * v0 + d11 * v1) \
                    + b10 * w0 + b11 * w1
                Tdd[k, 2, c] = w2
        if d.slide[k]:  # δs_k moves frame k along the line
            ux, uy = d.slide_axis[k, 0], d.slide_axis[k, 1]
            T[k, 0, nb + k] += b00 * ux + b01 * uy
            T[k, 1, nb + k] += b10 * ux + b11 * uy
        else:
            T[k, 2, nb + k] += 1.0  # δβ_k turns frame k


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def residual(d, w_, p, pd, pdd, x, xd, r, M, want_M):
    """r = C ẋ + K x − f (n_x,) at rigid state (p, ṗ, p̈) for x = [0; z], ẋ = [0; ż], and
    (want_M) the mass matrix M (n_x, n_x): ForwardSystem.matrices through its products.

    Per link (first_order.add_link_terms, docs/derivation.md §3–4), with ξ = T̂x:
    T̂ᵀ[M_t(ξ̈ + 2ξ̇) + 2ω G₀(ξ̇ + ξ) + (ω̇ G₀ − ω² M₀)ξ + load] − S₂x + K_e q + D q̇,
    in two parts: the terms p̈ does not enter (`velocity_terms`) and those it does
    (`acceleration_terms`, affine in p̈)."""
    frames(d, p, pd, pdd, w_.theta, w_.omega, w_.alpha, w_.oacc, w_.T, w_.Td, w_.Tdd)
    r[:] = 0.0
    if want_M:
        M[:] = 0.0
    velocity_terms(d, w_, x, xd, r, M, want_M)
    acceleration_terms(d, w_, p, pdd, x, r, M, want_M)


@njit(inline="always")
def velocity_terms(d, w_, x, xd, r, M, want_M):
    """Add to r the terms of `residual` that p̈ does not enter (the frames' maps and rates
    from `frames`), and (want_M) T̂ᵀ M_t T̂ to M; keep per link the products with x that
    `acceleration_terms` weighs by the accelerations (w_.g0xi: G₀ξ, w_.t1x: θ1 = T̂[2] x,
    w_.foreq: the stiffening matrices times q)."""
    N = d.length.shape[0]
    omega, T, Td = w_.omega, w_.T, w_.Td
    xi = w_.xi
    xi_d = w_.xi_d  # Ṫ̂ x + T̂ ẋ
    xi_dd = w_.xi_dd  # 2 Ṫ̂ ẋ: ξ̈'s part without T̈̂ x
    v = w_.v
    TM = w_.TM  # M_t T̂
    g0xi, t1x_, foreq = w_.g0xi, w_.t1x, w_.foreq
    for k in range(N):
        nk, o = d.n_modes[k], d.offset[k]
        mk = 3 + nk
        w = omega[k]
        w2 = w * w
        nc = map_columns(d, k)  # T̂_k's columns beyond are zero
        for a in range(3):
            s0 = s1 = s2 = 0.0
            for c in range(nc):
                s0 += T[k, a, c] * x[c]
                s1 += Td[k, a, c] * x[c] + T[k, a, c] * xd[c]
                s2 += 2.0 * Td[k, a, c] * xd[c]
            xi[a], xi_d[a], xi_dd[a] = s0, s1, s2
        for i in range(nk):
            xi[3 + i] = x[o + i]
            xi_d[3 + i] = xd[o + i]
        # Zero-order inertia load's velocity terms (first_order.rigid_load).
        s1k, sy, lateral = d.s1[k], d.sy[k], d.lateral[k]
        v[0] = -w2 * s1k
        v[1] = 0.0
        v[2] = 0.0
        for i in range(nk):
            v[3 + i] = 0.0
        if lateral:  # bodies' centres across the link (first_order.rigid_load)
            v[1] -= w2 * sy
            for i in range(nk):
                v[3 + i] += w2 * d.lat_tilde[k, i]
        for a in range(mk):
            acc = 0.0
            for b in range(3):
                acc += d.Mtot[k, a, b] * xi_dd[b]
            g = 0.0
            for b in range(mk):
                g += d.G0[k, a, b] * xi[b]
                acc += 2.0 * w * d.G0[k, a, b] * xi_d[b] - w2 * d.M0[k, a, b] * xi[b]
            g0xi[k, a] = g
            v[a] += acc
        # r += T̂ᵀ v
        for c in range(nc):
            acc = 0.0
            for a in range(3):
                acc += T[k, a, c] * v[a]
            r[c] += acc
        for i in range(nk):
            r[o + i] += v[3 + i]
        # Second-order stiffness (first_order.second_order_stiffness) times x: its
        # velocity terms.
        t1x = 0.0
        for c in range(nc):
            t1x += T[k, 2, c] * x[c]
        t1x_[k] = t1x
        vq = 0.0
        for i in range(nk):
            vec_i = -w2 * d.phi_tilde[k, i]
            vq += vec_i * x[o + i]
            r[o + i] -= vec_i * t1x
        for c in range(nc):
            r[c] -= T[k, 2, c] * (-w2 * d.J[k] * t1x + vq)
        for i in range(nk):
            acc = 0.0
            fm = ft = lf = lm = 0.0
            for j in range(nk):
                if d.stiffening:
                    acc += w2 * d.fore_moment[k, i, j] * x[o + j]
                    fm += d.fore_mass[k, i, j] * x[o + j]
                    ft += d.fore_tip[k, i, j] * x[o + j]
                    if lateral:
                        lf += d.lat_fore[k, i, j] * x[o + j]
                        lm += d.lat_fore_moment[k, i, j] * x[o + j]
                acc += d.stiffness[k, i, j] * x[o + j] + d.damping[k, i, j] * xd[o + j]
            foreq[k, 0, i], foreq[k, 1, i], foreq[k, 2, i], foreq[k, 3, i] = fm, ft, lf, lm
            r[o + i] += acc
        if want_M:  # M += T̂ᵀ M_t T̂ (TM's columns beyond its own modes are zero)
            nt = max(nc, o + nk)
            for a in range(mk):
                for c in range(nt):
                    acc = 0.0
                    for b in range(3):
                        acc += d.Mtot[k, a, b] * T[k, b, c]
                    TM[a, c] = acc
                for i in range(nk):
                    TM[a, o + i] += d.Mtot[k, a, 3 + i]
            for c1 in range(nc):
                for c2 in range(nt):
                    acc = 0.0
                    for b in range(3):
                        acc += T[k, b, c1] * TM[b, c2]
                    M[c1, c2] += acc
            for i in range(nk):
                for c2 in range(nt):
                    M[o + i, c2] += TM[3 + i, c2]


@njit(inline="always")
def acceleration_terms(d, w_, p, pdd, x, r, M, want_M):
    """Add to r the terms of `residual` that p̈ enters (affine in it: the frames'
    accelerations from `frames` at p̈, the products `velocity_terms` kept at the same
    state), and (want_M) the rigid base's and the motors' inertia to M."""
    N = d.length.shape[0]
    omega, alpha, oacc, T, Tdd = w_.omega, w_.alpha, w_.oacc, w_.T, w_.Tdd
    # Outboard inertia force Σ_{j>k, same branch} ∫a0 dm along frame k's x (its x part is
    # all the second-order stiffness needs; both components are carried for the turn).
    own, out = w_.own, w_.out
    out[:] = 0.0
    for k in range(N):
        w, wd = omega[k], alpha[k]
        own[k, 0] = d.mass[k] * oacc[k, 0] - w * w * d.s1[k] - wd * d.sy[k]
        own[k, 1] = d.mass[k] * oacc[k, 1] + wd * d.s1[k] - w * w * d.sy[k]
    for k in range(N - 2, -1, -1):
        if d.attached[k + 1]:
            continue
        fx, fy = out[k + 1, 0] + own[k + 1, 0], out[k + 1, 1] + own[k + 1, 1]
        beta = p[d.n_base + k + 1]  # θ_{k+1} − θ_k
        if d.slide[k + 1]:
            beta = d.slide_angle[k + 1]
        cb, sb = np.cos(beta), np.sin(beta)
        out[k, 0] = cb * fx - sb * fy
        out[k, 1] = sb * fx + cb * fy
    xi_dd = w_.xi_dd  # T̈̂ x
    v = w_.v
    g0xi, t1x_, foreq = w_.g0xi, w_.t1x, w_.foreq
    for k in range(N):
        nk, o = d.n_modes[k], d.offset[k]
        mk = 3 + nk
        wd = alpha[k]
        nc = map_columns(d, k)  # T̂_k's columns beyond are zero
        for a in range(3):
            s2 = 0.0
            for c in range(nc):
                s2 += Tdd[k, a, c] * x[c]
            xi_dd[a] = s2
        # Zero-order inertia load (first_order.rigid_load), then the body terms.
        ax, ay = oacc[k, 0], oacc[k, 1]
        mass, s1k, J, Jt = d.mass[k], d.s1[k], d.J[k], d.Jt[k]
        v[0] = mass * ax
        v[1] = mass * ay + wd * s1k
        v[2] = s1k * ay + J * wd + Jt * wd
        for i in range(nk):
            v[3 + i] = ay * d.phi_bar[k, i] + wd * d.phi_tilde[k, i] + wd * d.rot_slope[k, i]
        sy, lateral = d.sy[k], d.lateral[k]
        if lateral:  # bodies' centres across the link (first_order.rigid_load)
            v[0] -= wd * sy
            v[2] -= ax * sy
            for i in range(nk):
                v[3 + i] -= ax * d.lat_slope[k, i]
        for a in range(mk):
            acc = wd * g0xi[k, a]
            for b in range(3):
                acc += d.Mtot[k, a, b] * xi_dd[b]
            v[a] += acc
        # r += T̂ᵀ v
        for c in range(nc):
            acc = 0.0
            for a in range(3):
                acc += T[k, a, c] * v[a]
            r[c] += acc
        for i in range(nk):
            r[o + i] += v[3 + i]
        # Second-order stiffness (first_order.second_order_stiffness) times x: the terms
        # of the accelerations.
        N_out = out[k, 0]
        scal = ax * s1k + N_out * d.length[k] + ay * sy
        t1x = t1x_[k]
        vq = 0.0
        for i in range(nk):
            vec_i = ax * d.phi_bar[k, i] + N_out * d.tip_value[k, i]
            if lateral:
                vec_i += ay * d.lat_slope[k, i] + wd * d.lat_tilde[k, i]
            vq += vec_i * x[o + i]
            r[o + i] -= vec_i * t1x
        for c in range(nc):
            r[c] -= T[k, 2, c] * (scal * t1x + vq)
        if d.stiffening:
            for i in range(nk):
                acc = ax * foreq[k, 0, i] + N_out * foreq[k, 1, i]
                if lateral:
                    acc += ay * foreq[k, 2, i] + wd * foreq[k, 3, i]
                r[o + i] -= acc
    lever_stiffness(d, p, T, out, x, r)
    # The rigid base's mass and inertia and their zero-order load (ForwardSystem._base_inertia).
    nb = d.n_base
    if d.base_kind == FREE:
        bax, bay = base_acceleration(d, pdd)
        r[0] += d.base_mass * bax
        r[1] += d.base_mass * bay
        if want_M:
            M[0, 0] += d.base_mass
            M[1, 1] += d.base_mass
    elif d.base_kind == CART:  # the cart's mass along its rail
        bax, bay = base_acceleration(d, pdd)
        r[0] += d.base_mass * (bax * d.rail[0] + bay * d.rail[1])
        if want_M:
            M[0, 0] += d.base_mass
    if d.base_kind == FREE or d.base_kind == PINNED:
        r[nb - 1] += d.base_inertia * pdd[nb - 1]
        if want_M:
            M[nb - 1, nb - 1] += d.base_inertia
    for k in range(N):  # motor inertia of a driven joint: J_m β̈ on its row
        i = nb + k
        r[i] += d.motor_inertia[k] * pdd[i]
        if want_M:
            M[i, i] += d.motor_inertia[k]
    elastic.rotor_inertia(d, pdd, r, M, want_M)


# residual's arguments after (d, w_): p, pd, pdd, x, xd, r, M, want_M
_RESIDUAL_ROWS = (ROW, ROW, ROW, ROW, ROW, ROW, MATRIX, types.boolean)


@intrinsic
def _call_residual(typingctx, at, d, w_, p, pd, pdd, x, xd, r, M, want_M):
    """`residual` through the address ``at`` of its code compiled for (d, w_) (w_.calls[0]):
    the kernels that evaluate the model hold this call, not a copy of it
    (`_compiled_calls`)."""
    check("the compiled residual", (p, pd, pdd, x, xd, r, M, want_M), _RESIDUAL_ROWS)
    return types.none(at, d, w_, p, pd, pdd, x, xd, r, M, want_M), call_codegen(0)


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def applied(d, u, p, pd, integral, Q, rates):
    """Generalized applied forces Q (n_x,) and servo integral rates at one time
    (ForwardSystem.applied, dynamics/servos.py). u is the input row (forward_kernel.inputs):
    [motion or reference angle, rate, acceleration (N each), torque (N), per base load
    F_x, F_y (N), moment (N·m), per actuator its voltage (V)]: the actuators' forces
    B V act on z (dynamics/actuators.py)."""
    N = d.length.shape[0]
    nb = d.n_base
    Q[:] = 0.0
    for k in range(N):
        kind, i = d.joint_kind[k], nb + k
        if kind == ELASTIC:  # its drive turns the motor angle
            kind, i = d.motor_kind[k], d.motor_row[k]
        Q[i] = _drive(d, k, kind, u[k], u[N + k], u[3 * N + k], p[i], pd[i], integral, rates)
    elastic.spring_torques(d, u, p, pd, Q)
    if d.base_kind == CART:
        c = u.shape[0] - 4  # the cart's input columns
        Q[0] = _drive(d, N, d.joint_kind[N], u[c], u[c + 1], u[c + 3], p[0], pd[0],
                      integral, rates)
        base = 4 * N
        nl = d.load_point.shape[0]
        ct, st = 1.0, 0.0
        if nl > 0:  # (two libm calls at every evaluation otherwise)
            ct, st = np.cos(d.attitude), np.sin(d.attitude)
        for j in range(nl):  # the rail takes the loads across it and their moment
            fx, fy = u[base + j], u[base + nl + j]
            if d.load_body[j]:
                fx, fy = ct * fx - st * fy, st * fx + ct * fy
            Q[0] += fx * d.rail[0] + fy * d.rail[1]
    elif d.base_kind != FIXED:
        th = p[nb - 1]
        ct, st = np.cos(th), np.sin(th)
        base = 4 * N
        nl = d.load_point.shape[0]
        for j in range(nl):
            fx, fy, mz = u[base + j], u[base + nl + j], u[base + 2 * nl + j]
            if d.load_body[j]:
                fx, fy = ct * fx - st * fy, st * fx + ct * fy
            px, py = d.load_point[j, 0], d.load_point[j, 1]
            arm_x, arm_y = ct * px - st * py, st * px + ct * py
            Q[nb - 1] += mz + arm_x * fy - arm_y * fx
            if d.base_kind == FREE:
                Q[0] += fx
                Q[1] += fy
    na = d.actuator_B.shape[1]
    if na > 0:
        nr = d.n_rigid
        at = 4 * N + 3 * d.load_point.shape[0]
        for i in range(d.actuator_B.shape[0]):
            acc = 0.0
            for j in range(na):
                acc += d.actuator_B[i, j] * u[at + j]
            Q[nr + i] += acc


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _drive(d, k, kind, ref, ref_rate, torque, pos, rate, integral, rates):
    """The torque (force) of drive k (joint k, or the cart's at k = N) of the given kind (an
    elastic joint's: its motor's) from its input columns (reference or motion, its rate, a
    torque drive's torque) at coordinate pos and rate; writes a servo's integral rate into
    ``rates``. Zero for a prescribed coordinate."""
    if kind == TORQUE:
        return torque
    if kind == PRESCRIBED:
        return 0.0
    error = ref - pos
    if kind == VELOCITY_SERVO:
        s = d.servo_index[k]
        held = integral[s] if s >= 0 else 0.0
        raw = d.P[k] * error + d.I[k] * held + d.D[k] * (ref_rate - rate)
        volts = min(max(raw, -d.saturation[k]), d.saturation[k])
        command = d.rate_per_volt[k] * volts
        # Conditional integration: no wind-up while the command is saturated.
        if s >= 0:
            rates[s] = error if (volts == raw and d.I[k] != 0.0) else 0.0
    else:
        command = min(max(d.bandwidth[k] * error, -d.rate_limit[k]), d.rate_limit[k])
    tau = d.loop_gain[k] * (command - rate)
    return min(max(tau, -d.torque_limit[k]), d.torque_limit[k])


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def _solve(A, b):
    """Solve A y = b in place (b ← y) by Gaussian elimination with partial pivoting."""
    n = b.shape[0]
    for c in range(n):
        piv = c
        big = abs(A[c, c])
        for i in range(c + 1, n):
            if abs(A[i, c]) > big:
                big, piv = abs(A[i, c]), i
        if piv != c:
            for j in range(n):
                A[c, j], A[piv, j] = A[piv, j], A[c, j]
            b[c], b[piv] = b[piv], b[c]
        if A[c, c] == 0.0:  # singular (a blown-up state): NaN, which the loop reports
            b[:] = np.nan
            return
        inv = 1.0 / A[c, c]
        for i in range(c + 1, n):
            f = A[i, c] * inv
            if f != 0.0:
                for j in range(c, n):
                    A[i, j] -= f * A[c, j]
                b[i] -= f * b[c]
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, n):
            acc -= A[i, j] * b[j]
        b[i] = acc / A[i, i]


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def rates_in(context, u, y, dy, records_type):
    """dy/dt of the state y = [p_free, ṗ_free, z, ż, servo integrals] at one time with input
    row u (ForwardSystem.accelerations) for the kernel data d and Workspace w_ that the
    compiled loops' context holds (solvers/_radau_model.py; (d, w_)'s type given): the
    loops call it through its address, and it reads only the fields it uses (a call that
    took the records would hand over every array of both). The equations are linear in
    (p̈_free, z̈),

        [∂r/∂p̈_free | M[:, z]] (p̈_free, z̈) = Q − r(p̈_free = 0)   on the free and z rows."""
    d, w_ = load(context, records_type)
    assemble(d, w_, u, y)
    _solve(w_.A, w_.b)
    state_rates(d, w_, y, w_.b, dy)


@njit(cache=True, _nrt=False)
def rates(d, w_, u, y, dy):
    """dy (in place) = `rates_in` of kernel data d and Workspace w_ at state y with input
    row u: for Python and for kernels that hold the records."""
    assemble(d, w_, u, y)
    _solve(w_.A, w_.b)
    state_rates(d, w_, y, w_.b, dy)


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def state_rates(d, w_, y, acc, dy):
    """dy from the state y and the accelerations acc = (p̈_free, z̈) (the servo integrals'
    rates from the last `assemble`)."""
    nu = d.free.shape[0]
    n = d.n_x - d.n_rigid
    ns = y.shape[0] - 2 * nu - 2 * n
    for j in range(nu):
        dy[j] = y[nu + j]
        dy[nu + j] = acc[j]
    for i in range(n):
        dy[2 * nu + i] = y[2 * nu + n + i]
        dy[2 * nu + n + i] = acc[nu + i]
    for s in range(ns):
        dy[2 * nu + 2 * n + s] = w_.srates[s]


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def load_state(d, w_, u, y):
    """The rigid state (w_.p, w_.pd, w_.pdd with p̈_free = 0) and x = [0; z], ẋ = [0; ż]
    (w_.x, w_.xd) at state y and input row u."""
    N = d.length.shape[0]
    nb, nr, nx = d.n_base, d.n_rigid, d.n_x
    free = d.free
    nu = free.shape[0]
    n = nx - nr
    p, pd, pdd, x, xd = w_.p, w_.pd, w_.pdd, w_.x, w_.xd
    for k in range(N):  # prescribed joints from the input row, driven ones from the state
        p[nb + k], pd[nb + k], pdd[nb + k] = u[k], u[N + k], u[2 * N + k]
    elastic.prescribed_motors(d, u, p, pd, pdd)
    if d.base_kind == CART:  # a prescribed cart's travel (a driven one's: from the state)
        c = u.shape[0] - 4
        p[0], pd[0], pdd[0] = u[c], u[c + 1], u[c + 2]
    for j in range(nu):
        p[free[j]] = y[j]
        pd[free[j]] = y[nu + j]
        pdd[free[j]] = 0.0
    x[:] = 0.0
    xd[:] = 0.0
    for i in range(n):
        x[nr + i] = y[2 * nu + i]
        xd[nr + i] = y[2 * nu + n + i]


# A kernel of its own, inlined by LLVM (forceinline) rather than by numba: numba's inlining
# would copy the records into new variables of each caller, costly to compile.
@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def assemble(d, w_, u, y):
    """The linear equations of `rates` in (p̈_free, z̈) at state y and input row u: their
    matrix into w_.A, right-hand side into w_.b, the servo integrals' rates into w_.srates
    (w_.p, w_.pd, w_.pdd hold the rigid state, w_.M the mass matrix, w_.Q the applied
    forces, w_.r0 the residual at p̈_free = 0)."""
    nr, nx = d.n_rigid, d.n_x
    free = d.free
    nu = free.shape[0]
    n = nx - nr
    p, pd, pdd, x, xd = w_.p, w_.pd, w_.pdd, w_.x, w_.xd
    load_state(d, w_, u, y)
    integral = y[2 * nu + 2 * n:]
    # bool(): a plain bool, not a literal, so that both calls share one compiled residual
    want = bool(1)
    r0, ra, rj, M, Q, srates, A, b = w_.r0, w_.ra, w_.rj, w_.M, w_.Q, w_.srates, w_.A, w_.b
    # `residual` in its two parts: the terms p̈ does not enter once, those it enters (affine
    # in it) at p̈_free = 0 and at each unit p̈_free, whose differences are ∂r/∂p̈_free
    frames(d, p, pd, pdd, w_.theta, w_.omega, w_.alpha, w_.oacc, w_.T, w_.Td, w_.Tdd)
    r0[:] = 0.0
    M[:] = 0.0
    velocity_terms(d, w_, x, xd, r0, M, want)
    ra[:] = 0.0
    acceleration_terms(d, w_, p, pdd, x, ra, M, want)
    for i in range(nx):
        r0[i] += ra[i]
    srates[:] = 0.0
    applied(d, u, p, pd, integral, Q, srates)
    m = nu + n
    for row in range(m):
        a = free[row] if row < nu else nr + row - nu
        b[row] = Q[a] - r0[a]
        for i in range(n):
            A[row, nu + i] = M[a, nr + i]
    for j in range(nu):
        pdd[free[j]] = 1.0
        frames(d, p, pd, pdd, w_.theta, w_.omega, w_.alpha, w_.oacc, w_.T, w_.Td, w_.Tdd)
        rj[:] = 0.0
        acceleration_terms(d, w_, p, pdd, x, rj, M, not want)
        pdd[free[j]] = 0.0
        for row in range(m):
            a = free[row] if row < nu else nr + row - nu
            A[row, j] = rj[a] - ra[a]


@njit(cache=True, _nrt=False)
def joint_torques(d, w_, p, pd, pdd, z, zd, zdd, out):
    """out[t, k] = torque of joint k's motor (N·m) at rigid states p, ṗ, p̈ (nt, n_rigid) and
    z, ż, z̈ (nt, n): the joint row of M ẍ + C ẋ + K x − f with x = [0; z] (motor inertia
    included), as ForwardSystem.joint_torques."""
    N = d.length.shape[0]
    nb, nr, nx = d.n_base, d.n_rigid, d.n_x
    x, xd, r, M = w_.x, w_.xd, w_.r0, w_.M
    x[:] = 0.0
    xd[:] = 0.0
    for t in range(p.shape[0]):
        for i in range(nx - nr):
            x[nr + i] = z[t, i]
            xd[nr + i] = zd[t, i]
        _call_residual(w_.calls[0], d, w_, p[t], pd[t], pdd[t], x, xd, r, M, bool(1))
        for k in range(N):
            row = nb + k
            acc = r[row]
            for i in range(nx - nr):
                acc += M[row, nr + i] * zdd[t, i]
            out[t, k] = acc
