"""Compiled (numba) kernels of closed loops: the closure equations Φ(q) = 0 of the
loop-closing joints (`model.loops.Closure`), their Jacobian and acceleration terms, the
projection of a state onto them, and the forward rates with the constraint forces
(docs/derivation.md, "Closed loops"). The data layout (`LoopData`) is built by
`dynamics/loops.py`.

Positions. Frame k (link k's joint) turns by θ_k = θ_parent + Φ'_parent(L) q_parent + β_k and
sits at the parent's deformed tip (L: the section x_a of a slider's line; a slider's frame
sits on its block at the travel s along the line, turned by the constant γ from the
section: `slide`); a point at x on link k is

    r = o_k + A(θ_k) [x − ½ q_kᵀ F_k(x) q_k, Φ_k(x) q_k],   F_k(x) = ∫₀ˣ Φ_k'ᵀ Φ_k' ds

(the foreshortening term with geometric stiffening only) — the kinematics whose first-order
expansion the forward model's maps T_k are, and whose second-order part its stiffening terms
come from: through it the closure's force along a link stiffens (tension) or softens it. Φ(q) is
written on these positions, so Φ, its Jacobian G = ∂Φ/∂q and γ (the part of Φ̈ without
second derivatives, Φ̈ = G q̈ + γ) are exact for them; q = [p; z] over the whole x of the
forward model (rigid coordinates first).

Dynamics. The loop's constraint forces G^T λ join the forward equations: with A a = b the
equations of `_forward_numba.assemble` in a = (p̈_free, z̈),

    [ A       −G_aᵀ ] [a]   [ b                          ]
    [ G_a      0    ] [λ] = [ −γ − G_prescribed p̈_prescribed ]

(G_a: G's columns of the free and elastic coordinates). λ is the force the closing joint
applies to the point of ``link`` (global axes, N; a slider: along the line's normal).
Coordinate partitioning keeps Φ = 0 to round-off: `project` solves the dependent free
coordinates (`LoopData.dep`) and their rates from the others by Newton's method at every
evaluation, so the state the rates see is always closed and the integrated copies of the
dependent coordinates are overwritten after the run.

The kernels allocate nothing and are compiled with ``_nrt=False``, as the forward model's
(`_forward_numba`'s docstring): with numba's runtime every call of `frames`, `point` or
`constraints` increfs and decrefs each array of the ForwardData and workspace records it is
handed, which cost several times their arithmetic.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from .._compiled_calls import load
from ._forward_numba import CART, FREE, PINNED, PRESCRIBED, _solve, assemble, state_rates
from ._forward_numba import workspace as forward_workspace

REVOLUTE, SLIDER = 0, 1
NEWTON_ITERATIONS = 30
# `constraints`' ``jac`` as a plain bool, not a literal True or False: numba compiles a
# function once per literal value, and the kinematics under it (`frames`, `point`, …) with
# it; one compiled version skips the Jacobians at run time
JACOBIAN, NO_JACOBIAN = np.bool_(True), np.bool_(False)

LoopWork = namedtuple("LoopWork", [
    "fw", "th", "om", "Jth", "o", "od", "og", "Jo", "r", "rd", "g", "Jr", "r2", "rd2", "g2",
    "Jr2", "q", "v", "Phi", "G", "gam", "Gd", "step", "yp", "K", "rhs"])
LoopWork.__doc__ = "Scratch arrays of the loop kernels (allocated once per run: see workspace)."


def workspace(d, n_servos: int, n_state: int, calls: bool = True) -> LoopWork:
    """Scratch arrays for LoopData d and states of n_state entries (``calls`` False: for the
    kinematics kernels only, `_forward_numba.workspace`)."""
    f = d.fwd
    N, nx = f.length.shape[0], f.n_x
    nc = d.dep.shape[0]
    m = f.free.shape[0] + nx - f.n_rigid
    e = np.empty
    return LoopWork(forward_workspace(f, n_servos, calls), e(N), e(N), e((N, nx)), e((N, 2)),
                    e((N, 2)), e((N, 2)), e((N, 2, nx)), e(2), e(2), e(2), e((2, nx)),
                    e(2), e(2), e(2), e((2, nx)), e(nx), e(nx), e(nc), e((nc, nx)), e(nc),
                    e((nc, nc)), e(nc), e(n_state), e((m + nc, m + nc)), e(m + nc))


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def point(f, k, s, phi, fore, w, r, rd, g, Jr, jac=True):
    """Position r, velocity ṙ, γ (r̈ without q̈ terms) and Jacobian Jr (2, n_x; only when
    ``jac``) of the point at s (m) on link k whose mode values there are phi, from the frames
    in w (`frames`).
    With geometric stiffening the point is drawn in by the foreshortening ½ qᵀF q along the
    link (F = ∫₀ˢ Φ'ᵀΦ' dx: ``fore``), the kinematics the stiffening terms come from."""
    c, sn = np.cos(w.th[k]), np.sin(w.th[k])
    o, nk = f.offset[k], f.n_modes[k]
    dev = 0.0
    dev_d = 0.0
    ax, ax_d, ax_g = s, 0.0, 0.0  # along the link: s − ½qᵀFq, its rate, its γ −q̇ᵀFq̇
    for i in range(nk):
        dev += phi[i] * w.q[o + i]
        dev_d += phi[i] * w.v[o + i]
        if f.stiffening:
            fq = 0.0
            fv = 0.0
            for j in range(nk):
                fq += fore[i, j] * w.q[o + j]
                fv += fore[i, j] * w.v[o + j]
            ax -= 0.5 * w.q[o + i] * fq
            ax_d -= w.v[o + i] * fq
            ax_g -= w.v[o + i] * fv
    aux, auy = c * ax - sn * dev, sn * ax + c * dev  # A u
    adx, ady = c * ax_d - sn * dev_d, sn * ax_d + c * dev_d  # A u̇
    om = w.om[k]
    r[0], r[1] = w.o[k, 0] + aux, w.o[k, 1] + auy
    rd[0] = w.od[k, 0] - om * auy + adx
    rd[1] = w.od[k, 1] + om * aux + ady
    g[0] = w.og[k, 0] - om * om * aux - 2.0 * om * ady + c * ax_g
    g[1] = w.og[k, 1] - om * om * auy + 2.0 * om * adx + sn * ax_g
    if not jac:
        return
    for col in range(Jr.shape[1]):
        Jr[0, col] = w.Jo[k, 0, col] - auy * w.Jth[k, col]
        Jr[1, col] = w.Jo[k, 1, col] + aux * w.Jth[k, col]
    for i in range(nk):
        Jr[0, o + i] += -sn * phi[i]
        Jr[1, o + i] += c * phi[i]
        if f.stiffening:
            fq = 0.0
            for j in range(nk):
                fq += fore[i, j] * w.q[o + j]
            Jr[0, o + i] -= c * fq
            Jr[1, o + i] -= sn * fq


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def base_pose(f, w):
    """The base's reference point (m), its velocity, its attitude (rad) and rate, and the
    coordinate of the attitude (−1: constant): a fixed base at the origin; a pinned base
    turning about the origin; a free base (x, y, attitude); a cart at rail_origin + s rail
    with its constant attitude. Linear in q: no γ term of its own."""
    if f.base_kind == FREE:
        return w.q[0], w.q[1], w.v[0], w.v[1], w.q[2], w.v[2], 2
    if f.base_kind == PINNED:
        return 0.0, 0.0, 0.0, 0.0, w.q[0], w.v[0], 0
    if f.base_kind == CART:
        s, sd = w.q[0], w.v[0]
        return (f.rail_origin[0] + s * f.rail[0], f.rail_origin[1] + s * f.rail[1],
                sd * f.rail[0], sd * f.rail[1], f.attitude, 0.0, -1)
    return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, -1


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def base_point(f, w, px, py, r, rd, g, Jr, jac=True):
    """Position, velocity, γ and Jacobian (2, n_x; only when ``jac``) of the point (px, py)
    fixed in the base (m, base axes): a branch's joint, a closure's ground pivot."""
    bx, by, bvx, bvy, th, om, att = base_pose(f, w)
    c, sn = np.cos(th), np.sin(th)
    ax, ay = c * px - sn * py, sn * px + c * py
    r[0], r[1] = bx + ax, by + ay
    rd[0], rd[1] = bvx - om * ay, bvy + om * ax
    g[0], g[1] = -om * om * ax, -om * om * ay
    if not jac:
        return
    Jr[:, :] = 0.0
    if f.base_kind == FREE:
        Jr[0, 0] = 1.0
        Jr[1, 1] = 1.0
    elif f.base_kind == CART:
        Jr[0, 0], Jr[1, 0] = f.rail[0], f.rail[1]
    if att >= 0:
        Jr[0, att] = -ay
        Jr[1, att] = ax


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def frames(f, w, jac=True):
    """Every frame's angle, rate, origin, its velocity and γ, and (``jac``) the Jacobians
    of the angle and the origin, from q = w.q, q̇ = w.v (a branch starts at its point of
    the base, which moves with the base's coordinates: `base_pose`)."""
    N = f.length.shape[0]
    nb = f.n_base
    for k in range(N):
        if f.attached[k]:
            _, _, _, _, th_b, om_b, att = base_pose(f, w)
            w.th[k] = th_b + w.q[nb + k]
            w.om[k] = om_b + w.v[nb + k]
            base_point(f, w, f.point[k, 0], f.point[k, 1], w.r, w.rd, w.g, w.Jr, jac)
            for a in range(2):
                w.o[k, a], w.od[k, a], w.og[k, a] = w.r[a], w.rd[a], w.g[a]
            if jac:
                w.Jth[k, :] = 0.0
                if att >= 0:
                    w.Jth[k, att] = 1.0
                for a in range(2):
                    for i in range(w.Jr.shape[1]):
                        w.Jo[k, a, i] = w.Jr[a, i]
        else:
            j = k - 1
            point(f, j, f.length[j], f.tip_value[j], f.fore_tip[j], w, w.r, w.rd, w.g, w.Jr,
                  jac)
            o, nj = f.offset[j], f.n_modes[j]
            th, om = w.th[j], w.om[j]
            if not f.slide[k]:  # a slider's coordinate is its travel (`slide`)
                th, om = th + w.q[nb + k], om + w.v[nb + k]
            for i in range(nj):
                th += f.tip_slope[j, i] * w.q[o + i]
                om += f.tip_slope[j, i] * w.v[o + i]
            w.th[k], w.om[k] = th, om
            for a in range(2):
                w.o[k, a], w.od[k, a], w.og[k, a] = w.r[a], w.rd[a], w.g[a]
            if jac:
                for i in range(w.Jth.shape[1]):
                    w.Jth[k, i] = w.Jth[j, i]
                for i in range(nj):
                    w.Jth[k, o + i] += f.tip_slope[j, i]
                for a in range(2):
                    for i in range(w.Jr.shape[1]):
                        w.Jo[k, a, i] = w.Jr[a, i]
            if f.slide[k]:
                slide(f, w, k, nb + k, th, om, jac)
                continue
        if jac:
            w.Jth[k, nb + k] += 1.0


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def slide(f, w, k, i, th, om, jac=True):
    """Frame k on a slider's block: the line through the section (w.o[k] as `frames`
    left it) turns with it (angle th, rate om; Jacobian w.Jth[k], without q[i]), and the block
    sits at s = q[i] along e = A(th) u: o += s e, ȯ += ṡ e + s om S e, γ += 2 ṡ om S e −
    s om² e, the Jacobian (``jac``) gains e on the travel and s S e times the line's angle
    row; link k turns by the constant slide_angle from the line's section."""
    c, sn = np.cos(th), np.sin(th)
    ex = c * f.slide_axis[k, 0] - sn * f.slide_axis[k, 1]
    ey = sn * f.slide_axis[k, 0] + c * f.slide_axis[k, 1]
    s, sd = w.q[i], w.v[i]
    w.o[k, 0] += s * ex
    w.o[k, 1] += s * ey
    w.od[k, 0] += sd * ex - s * om * ey
    w.od[k, 1] += sd * ey + s * om * ex
    w.og[k, 0] += -2.0 * sd * om * ey - s * om * om * ex
    w.og[k, 1] += 2.0 * sd * om * ex - s * om * om * ey
    if jac:
        for col in range(w.Jth.shape[1]):
            w.Jo[k, 0, col] -= s * ey * w.Jth[k, col]
            w.Jo[k, 1, col] += s * ex * w.Jth[k, col]
        w.Jo[k, 0, i] += ex
        w.Jo[k, 1, i] += ey
    w.th[k] = th + f.slide_angle[k]
    w.om[k] = om


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def constraints(d, w, jac=True):
    """Φ (w.Phi), γ (w.gam) and, when ``jac``, G = ∂Φ/∂q (w.G) at q = w.q, q̇ = w.v (without:
    w.G is left as it was, for a change of q̇ alone at the same q)."""
    f = d.fwd
    frames(f, w, jac)
    for c in range(d.kind.shape[0]):
        row = d.row[c]
        point(f, d.link[c], d.x[c], d.phi[c], d.fore[c], w, w.r, w.rd, w.g, w.Jr, jac)
        if d.to_link[c] >= 0:
            point(f, d.to_link[c], d.x_to[c], d.phi_to[c], d.fore_to[c], w, w.r2, w.rd2,
                  w.g2, w.Jr2, jac)
        else:  # the ground: a point (and a slider's line) fixed in the base
            base_point(f, w, d.ground[c, 0], d.ground[c, 1], w.r2, w.rd2, w.g2, w.Jr2, jac)
        if d.kind[c] == REVOLUTE:
            for a in range(2):
                w.Phi[row + a] = w.r[a] - w.r2[a]
                w.gam[row + a] = w.g[a] - w.g2[a]
                if jac:
                    for i in range(w.G.shape[1]):
                        w.G[row + a, i] = w.Jr[a, i] - w.Jr2[a, i]
        else:
            # Φ = n·(r − r2), n = A(θ_b) n₀ turning with the base: ṅ = ω_b n⊥, and n̈ has
            # −ω_b² n besides its θ̈_b part (in G through n⊥·(r − r2) on the attitude)
            _, _, _, _, th_b, om_b, att = base_pose(f, w)
            cb, sb = np.cos(th_b), np.sin(th_b)
            n0x, n0y = d.normal[c, 0], d.normal[c, 1]
            nx_, ny_ = cb * n0x - sb * n0y, sb * n0x + cb * n0y
            dx, dy = w.r[0] - w.r2[0], w.r[1] - w.r2[1]
            w.Phi[row] = nx_ * dx + ny_ * dy
            w.gam[row] = (nx_ * (w.g[0] - w.g2[0]) + ny_ * (w.g[1] - w.g2[1])
                          + 2.0 * om_b * (-ny_ * (w.rd[0] - w.rd2[0])
                                          + nx_ * (w.rd[1] - w.rd2[1]))
                          - om_b * om_b * (nx_ * dx + ny_ * dy))
            if not jac:
                continue
            for i in range(w.G.shape[1]):
                w.G[row, i] = nx_ * (w.Jr[0, i] - w.Jr2[0, i]) + ny_ * (w.Jr[1, i] - w.Jr2[1, i])
            if att >= 0:
                w.G[row, att] += -ny_ * dx + nx_ * dy


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def load_state(d, w, u, y):
    """w.q, w.v from the input row u (prescribed joints) and the state y (free, elastic)."""
    f = d.fwd
    N = f.length.shape[0]
    nb, nr, nx = f.n_base, f.n_rigid, f.n_x
    nu = f.free.shape[0]
    n = nx - nr
    w.q[:] = 0.0
    w.v[:] = 0.0
    for k in range(N):
        w.q[nb + k], w.v[nb + k] = u[k], u[N + k]
    if f.base_kind == CART and f.joint_kind[N] == PRESCRIBED:  # the travel: an input
        w.q[0], w.v[0] = u[u.shape[0] - 4], u[u.shape[0] - 3]
    for j in range(nu):
        w.q[f.free[j]], w.v[f.free[j]] = y[j], y[nu + j]
    for i in range(n):
        w.q[nr + i], w.v[nr + i] = y[2 * nu + i], y[2 * nu + n + i]


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True,
      forceinline=True)
def project(d, w, u, y):
    """Overwrite the dependent coordinates of y (`LoopData.dep`, indices into the free ones)
    and their rates with those that close the loops, Newton's method from y's values; True
    when |Φ| ≤ d.tol (then w.Phi, w.G, w.gam hold the closed state's)."""
    f = d.fwd
    nu = f.free.shape[0]
    nc = d.dep.shape[0]
    load_state(d, w, u, y)
    closed = False
    for _ in range(NEWTON_ITERATIONS):
        constraints(d, w, JACOBIAN)
        big = 0.0
        for c in range(nc):
            big = max(big, abs(w.Phi[c]))
        if big <= d.tol:
            closed = True
            break
        for c in range(nc):
            w.step[c] = -w.Phi[c]
            for j in range(nc):
                w.Gd[c, j] = w.G[c, f.free[d.dep[j]]]
        _solve(w.Gd, w.step)
        for j in range(nc):
            w.q[f.free[d.dep[j]]] += w.step[j]
    if not closed:
        return False
    # Rates: G q̇ = 0 for the dependent ones (linear: one solve), then γ at those rates.
    for c in range(nc):
        acc = 0.0
        for col in range(f.n_x):
            acc += w.G[c, col] * w.v[col]
        w.step[c] = -acc
        for j in range(nc):
            w.Gd[c, j] = w.G[c, f.free[d.dep[j]]]
    _solve(w.Gd, w.step)
    for j in range(nc):
        w.v[f.free[d.dep[j]]] += w.step[j]
        y[d.dep[j]] = w.q[f.free[d.dep[j]]]
        y[nu + d.dep[j]] = w.v[f.free[d.dep[j]]]
    constraints(d, w, NO_JACOBIAN)  # γ at the closed rates; Φ and G are those of this q
    return True


@njit(cache=True, _nrt=False)
def close(d, w, u, y, newton):
    """The closed start's kinematics, the one entry from Python to them (the kernels it
    calls carry no Python wrapper: unboxing LoopData and LoopWork is compiled once, here).
    ``newton`` 0: w.q, w.v from the input row u and the state y, then Φ, G, γ there
    (`load_state`, `constraints`; returns True); 1: `project` y in place (True when the
    loops close)."""
    if newton == 0:
        load_state(d, w, u, y)
        constraints(d, w, JACOBIAN)
        return True
    return project(d, w, u, y)


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def solve_constrained(d, w, u, y):
    """Project y (w.yp ← y closed) and solve the constrained equations: accelerations
    (p̈_free, z̈) in w.rhs[:m], multipliers λ in w.rhs[m:]. False when the loop does not
    close (a singular configuration): w.rhs is then NaN."""
    f = d.fwd
    N = f.length.shape[0]
    nb, nr, nx = f.n_base, f.n_rigid, f.n_x
    nu = f.free.shape[0]
    n = nx - nr
    m = nu + n
    nc = d.dep.shape[0]
    yp = w.yp
    for i in range(y.shape[0]):
        yp[i] = y[i]
    if not project(d, w, u, yp):
        w.rhs[:] = np.nan
        return False
    fw = w.fw
    assemble(f, fw, u, yp)
    K, rhs = w.K, w.rhs
    K[:, :] = 0.0
    for r in range(m):
        col = f.free[r] if r < nu else nr + r - nu
        rhs[r] = fw.b[r]
        for s in range(m):
            K[r, s] = fw.A[r, s]
        for c in range(nc):
            K[r, m + c] = -w.G[c, col]
            K[m + c, r] = w.G[c, col]
    for c in range(nc):
        acc = -w.gam[c]
        for k in range(N):
            if f.joint_kind[k] == PRESCRIBED:
                acc -= w.G[c, nb + k] * u[2 * N + k]
        if f.base_kind == CART and f.joint_kind[N] == PRESCRIBED:
            acc -= w.G[c, 0] * u[u.shape[0] - 2]
        rhs[m + c] = acc
    _solve(K, rhs)
    return True


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def rates_in(context, u, y, dy, records_type):
    """dy/dt of y = [p_free, ṗ_free, z, ż, servo integrals] on the closed loops (the
    dependent coordinates' entries of y are not read: see `project`), for the kernel data d
    and LoopWork w that the compiled loops' context holds (solvers/_radau_model.py; (d, w)'s
    type given): the loops call it through its address, and the records are read from the
    context, not handed over array by array. From Python: `_radau_numba.rates_function`
    (one compiled version of the rates, not a second one with a Python wrapper)."""
    d, w = load(context, records_type)
    if not solve_constrained(d, w, u, y):
        dy[:] = np.nan
        return
    state_rates(d.fwd, w.fw, w.yp, w.rhs, dy)


@njit(cache=True, _nrt=False)
def closed_states(d, w, u, states, dy, lam, joint_forces, residual):
    """After a run: each state (nt, ·) projected onto the loops in place, its rates dy
    (nt, ·; `rates_in` of the projected state, from the same solve), the multipliers λ
    (nt, n_c), the constraint forces' torques on the joints' rows (G^T λ, nt × N) and the largest |Φ|
    of the projected state (nt,; NaN where it does not close)."""
    f = d.fwd
    N = f.length.shape[0]
    nu = f.free.shape[0]
    m = nu + f.n_x - f.n_rigid
    nc = d.dep.shape[0]
    for t in range(states.shape[0]):
        ok = solve_constrained(d, w, u[t], states[t])
        for i in range(states.shape[1]):
            states[t, i] = w.yp[i]
        state_rates(f, w.fw, w.yp, w.rhs, dy[t])
        big = 0.0
        for c in range(nc):
            lam[t, c] = w.rhs[m + c]
            big = max(big, abs(w.Phi[c]))
        residual[t] = big if ok else np.nan
        for k in range(N):
            acc = 0.0
            for c in range(nc):
                acc += w.G[c, f.n_base + k] * w.rhs[m + c]
            joint_forces[t, k] = acc
