"""Compiled (numba) momentum of a forward system and its projection onto the known
momentum (`momentum_projection.py`).

`momentum` is `dynamics.forward.momentum` at one state, written as loops (the numpy function
stays the reference; `tests/unit/test_momentum_projection.py` compares them to round-off).
`project` corrects the rates of a state so that the projected components of the momentum
equal their known values: a velocity change along the system's rigid-body motions
(translations of the base or of a cart along its rail, a rotation about the centre of mass
or the pin), whose
amplitudes solve a linear system of at most 3 × 3. Momentum is affine in the rates at a fixed
configuration, so one solve puts the state on the manifold to round-off.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from .._compiled_calls import load
from ._forward_numba import CART, FREE, PINNED, frames


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def momentum(d, w_, p, pd, x, xd, pj, out):
    """out[:] = [L_x, L_y (N·s), H about the origin (N·m·s), first moment S_x, S_y (kg·m)] of
    base and links at rigid state p, ṗ (n_rigid,) and x = [0; z], ẋ = [0; ż] (n_x,), global
    axes, to first order in z (dynamics.forward.momentum; S = ∫r dm, so L = dS/dt). A link
    hangs on its parent's section at d.length (x_a), a slider's block at s along its line."""
    frames(d, p, pd, pj.zero_rigid, w_.theta, w_.omega, w_.alpha, w_.oacc, w_.T, w_.Td, w_.Tdd)
    theta, omega, T, Td = w_.theta, w_.omega, w_.T, w_.Td
    origin, vel = pj.origin, pj.velocity
    N = d.length.shape[0]
    nb, nx = d.n_base, d.n_x
    lx = ly = h = sx = sy = 0.0
    bx = by = bvx = bvy = 0.0
    th_b = w_b = 0.0
    if d.base_kind == FREE:
        bx, by, bvx, bvy = p[0], p[1], pd[0], pd[1]
    elif d.base_kind == CART:  # R_b = R_0 + s e, its attitude constant
        bx, by = d.rail_origin[0] + p[0] * d.rail[0], d.rail_origin[1] + p[0] * d.rail[1]
        bvx, bvy = pd[0] * d.rail[0], pd[0] * d.rail[1]
        th_b = d.attitude
    if d.base_kind == FREE or d.base_kind == CART:
        mb = d.base_mass
        lx += mb * bvx
        ly += mb * bvy
        h += mb * (bx * bvy - by * bvx)
        sx += mb * bx
        sy += mb * by
    if d.base_kind == FREE or d.base_kind == PINNED:
        th_b, w_b = p[nb - 1], pd[nb - 1]
        h += d.base_inertia * w_b
    for k in range(N):
        if d.attached[k]:
            ct, st = np.cos(th_b), np.sin(th_b)
            px, py = d.point[k, 0], d.point[k, 1]
            cx, cy = ct * px - st * py, st * px + ct * py
            ox, oy = bx + cx, by + cy
            vx, vy = bvx - w_b * cy, bvy + w_b * cx
        else:
            j = k - 1
            L = d.length[j]
            cj, sj = np.cos(theta[j]), np.sin(theta[j])
            ox, oy = origin[j, 0] + L * cj, origin[j, 1] + L * sj
            vx, vy = vel[j, 0] - L * omega[j] * sj, vel[j, 1] + L * omega[j] * cj
            if d.slide[k]:  # the block at s along its line u (frame j axes)
                s, sd = p[nb + k], pd[nb + k]
                gx = cj * d.slide_axis[k, 0] - sj * d.slide_axis[k, 1]
                gy = sj * d.slide_axis[k, 0] + cj * d.slide_axis[k, 1]
                ox, oy = ox + s * gx, oy + s * gy
                vx, vy = vx + sd * gx - s * omega[j] * gy, vy + sd * gy + s * omega[j] * gx
        origin[k, 0], origin[k, 1] = ox, oy
        vel[k, 0], vel[k, 1] = vx, vy
        nk, o = d.n_modes[k], d.offset[k]
        x0 = x1 = x2 = v0 = v1 = v2 = 0.0
        for c in range(nx):
            x0 += T[k, 0, c] * x[c]
            x1 += T[k, 1, c] * x[c]
            x2 += T[k, 2, c] * x[c]
            v0 += T[k, 0, c] * xd[c] + Td[k, 0, c] * x[c]
            v1 += T[k, 1, c] * xd[c] + Td[k, 1, c] * x[c]
            v2 += T[k, 2, c] * xd[c] + Td[k, 2, c] * x[c]
        m, s1, J, Jt, sy_k = d.mass[k], d.s1[k], d.J[k], d.Jt[k], d.sy[k]
        # Bodies' centres across the link (sy = Σ m_b c_y): ∫g_x dm = M0[0]·ξ, X = [x, c_y].
        g0 = m * x0 - sy_k * x2
        gd0 = m * v0 - sy_k * v2
        g1 = m * x1 + s1 * x2
        gd1 = m * v1 + s1 * v2
        hy = s1 * v1 + J * v2 - sy_k * v0
        rot = Jt * v2  # the bodies' rotary inertia: J_t ξ̇_2 + Σ J_b Φ'(x_b) q̇
        lat = sy_k * x1
        for i in range(nk):
            g0 -= d.lat_slope[k, i] * x[o + i]
            gd0 -= d.lat_slope[k, i] * xd[o + i]
            g1 += d.phi_bar[k, i] * x[o + i]
            gd1 += d.phi_bar[k, i] * xd[o + i]
            hy += d.phi_tilde[k, i] * xd[o + i]
            rot += d.rot_slope[k, i] * xd[o + i]
            lat -= d.lat_tilde[k, i] * x[o + i]
        X0, X1 = s1 + g0, sy_k + g1  # ∫(X + g) dm, frame axes
        w = omega[k]
        in0, in1 = gd0 - w * X1, gd1 + w * X0  # ∫ġ dm + ω S ∫(X + g) dm
        ck, sk = np.cos(theta[k]), np.sin(theta[k])
        R0, R1 = ck * ox + sk * oy, -sk * ox + ck * oy
        V0, V1 = ck * vx + sk * vy, -sk * vx + ck * vy
        lx += m * vx + ck * in0 - sk * in1
        ly += m * vy + sk * in0 + ck * in1
        h += (m * (R0 * V1 - R1 * V0) + (R0 * in1 - R1 * in0) + (X0 * V1 - X1 * V0) + hy
              + w * (J + 2.0 * s1 * x0 + 2.0 * lat) + Jt * w + rot)
        sx += m * ox + ck * X0 - sk * X1
        sy += m * oy + sk * X0 + ck * X1
    out[0], out[1], out[2], out[3], out[4] = lx, ly, h, sx, sy


@njit(cache=True, _nrt=False, forceinline=True)
def _state(d, w_, u, y):
    """Rigid state p, ṗ (prescribed joints and cart from the input row) and x, ẋ into the
    workspace."""
    N = d.length.shape[0]
    nb, nr = d.n_base, d.n_rigid
    free = d.free
    nu = free.shape[0]
    n = d.n_x - nr
    p, pd, x, xd = w_.p, w_.pd, w_.x, w_.xd
    for k in range(N):
        p[nb + k], pd[nb + k] = u[k], u[N + k]
    if d.base_kind == CART:  # a prescribed cart's travel (a driven one's: from y)
        c = u.shape[0] - 4
        p[0], pd[0] = u[c], u[c + 1]
    for j in range(nu):
        p[free[j]] = y[j]
        pd[free[j]] = y[nu + j]
    x[:] = 0.0
    xd[:] = 0.0
    for i in range(n):
        x[nr + i] = y[2 * nu + i]
        xd[nr + i] = y[2 * nu + n + i]


@njit(cache=True, _nrt=False, forceinline=True)
def components(d, w_, pj, pd, out):
    """out[:3] = L_x (on a cart: L along its rail), L_y and H (about the centre of mass if
    pj.about_cm, else the origin) at the workspace's configuration with rigid rates pd;
    out[3:5] the first moment."""
    momentum(d, w_, w_.p, pd, w_.x, w_.xd, pj, out)
    if d.base_kind == CART:
        out[0] = out[0] * d.rail[0] + out[1] * d.rail[1]
    if pj.about_cm:  # H_cm = H_O − r_cm × L
        cx, cy = out[3] / pj.total_mass, out[4] / pj.total_mass
        out[2] -= cx * out[1] - cy * out[0]


@njit(cache=True, _nrt=False)
def invariants(d, w_, pj, u, y, out):
    """out[:3] = the projected components' values (L_x, L_y, H) at state y, input row u."""
    _state(d, w_, u, y)
    components(d, w_, pj, w_.pd, pj.c0)
    out[0], out[1], out[2] = pj.c0[0], pj.c0[1], pj.c0[2]


# A kernel of its own, inlined by LLVM into `project_in` (forceinline), where the records
# are read from the context: a call that took them would hand over every array of three.
@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def project(d, w_, pj, u, U, t, y):
    """Correct the free rigid rates of y (in place) so that each projected component of the
    momentum equals pj.start + pj.rate · (t − pj.t0) + pj.impulse @ U (U: the inputs'
    integrals from pj.t0 to t). The correction is a sum of rigid-body velocities of the whole
    system — base translations for L, a turn about the centre of mass (free base) or the pin
    for H — so the elastic rates and the joints' relative rates stay as integrated."""
    na = pj.active.shape[0]
    if na == 0:
        return
    _state(d, w_, u, y)
    pd, c0, c1, A, lam, dirs = w_.pd, pj.c0, pj.c1, pj.A, pj.lam, pj.dirs
    components(d, w_, pj, pd, c0)
    small = True
    for a in range(na):
        comp = pj.active[a]
        target = pj.start[comp] + pj.rate[comp] * (t - pj.t0)
        for c in range(U.shape[0]):
            target += pj.impulse[comp, c] * U[c]
        lam[a] = target - c0[comp]
        if abs(lam[a]) > 1e-15 * pj.size[comp]:
            small = False
    if small:
        return
    # Directions in the rigid rates: base x, y velocity; a turn about the reference point
    # (its velocity ω × (r_b − c)) with c the centre of mass (free base) or the pin.
    nr = d.n_rigid
    nb = d.n_base
    cmx, cmy = c0[3] / pj.total_mass, c0[4] / pj.total_mass
    for a in range(na):
        comp = pj.active[a]
        for i in range(nr):
            dirs[a, i] = 0.0
        if comp == 2:
            dirs[a, nb - 1] = 1.0
            if d.base_kind == FREE:
                dirs[a, 0] = -(w_.p[1] - cmy)
                dirs[a, 1] = w_.p[0] - cmx
        else:  # on a cart, component 0's direction is the travel's rate: index 0 too
            dirs[a, comp] = 1.0
    if d.base_kind == CART:
        # the momentum along the rail, the one component a cart projects: a unit travel rate
        # carries every mass along the (unit) rail, so A = the total mass (the difference of
        # two momenta, the other bases' way, gives it to round-off at twice the cost)
        A[0, 0] = pj.total_mass
    else:
        for b in range(na):
            for i in range(nr):
                pj.pd1[i] = pd[i] + dirs[b, i]
            components(d, w_, pj, pj.pd1, c1)
            for a in range(na):
                A[a, b] = c1[pj.active[a]] - c0[pj.active[a]]
    # A λ = target − c (na ≤ 3, A ≈ the rigid body's mass and inertia: Gauss without pivots
    # would do; partial pivoting for safety)
    for col in range(na):
        piv = col
        for r in range(col + 1, na):
            if abs(A[r, col]) > abs(A[piv, col]):
                piv = r
        if A[piv, col] == 0.0:  # no mass to carry the momentum: nothing to correct
            return
        if piv != col:
            for j in range(na):
                A[col, j], A[piv, j] = A[piv, j], A[col, j]
            lam[col], lam[piv] = lam[piv], lam[col]
        for r in range(col + 1, na):
            f = A[r, col] / A[col, col]
            for j in range(col, na):
                A[r, j] -= f * A[col, j]
            lam[r] -= f * lam[col]
    for r in range(na - 1, -1, -1):
        acc = lam[r]
        for j in range(r + 1, na):
            acc -= A[r, j] * lam[j]
        lam[r] = acc / A[r, r]
    nu = d.free.shape[0]
    for j in range(nu):
        i = d.free[j]
        acc = 0.0
        for a in range(na):
            acc += lam[a] * dirs[a, i]
        y[nu + j] += acc


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def project_in(context, u, U, t, y, records_type):
    """`project` for the kernel data d, Workspace w_ and projection record pj that the
    compiled loops' context holds (solvers/_radau_model.py; (d, w_, pj)'s type given): the
    loops call it through its address, and it reads only the fields it uses, not every
    array of the three records handed over at each call (1 µs of a 1.3 µs projection of a
    cart's momentum)."""
    d, w_, pj = load(context, records_type)
    project(d, w_, pj, u, U, t, y)
