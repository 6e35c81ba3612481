"""Compiled (numba) kernels of closed loops on the geometrically nonlinear model
(`NonlinearLoopData`, built by `dynamics/nonlinear_loops.py`): the closure equations on the
exact arc kinematics, the projection of a state onto them and the forward rates with the
constraint forces, for the Radau IIA integrator (`solvers/_radau_numba.py`).

Positions. Every point of the chain sits at r = Σ_j W_j e(α_j), α_j = Ay_j y + (prescribed
part) the node angles of the nonlinear model (docs/nonlinear.md §7): a closure's point on its
deformed link is a constant row W of cumulative arc weights, so with D = W_link − W_other
(the other link's row, or none for the ground)

    Φ  = Σ_j D_j e(α_j) − ground                 (revolute: both axes; slider: along n),
    G  = ∂Φ/∂y = Σ_j D_j e⊥(α_j) Ay_j,
    γ  = Σ_j D_j [e⊥(α_j) α̈ᵖ_j − e(α_j) α̇_j²]    (Φ̈ = G ÿ + γ, α̈ᵖ the prescribed part),

exact for the inextensible links: the loop closes on the deformed links' arcs, with no
expansion in the deflection (a bent link's shortening is part of Σ D e(α)).

A slider inside the chain. Its line node's length is the travel s (ρ_j = s there, 1
elsewhere): Φ = Σ_j D_j ρ_j e(α_j) − ground, whose rate ρ α̇ e⊥ + ρ̇ e and acceleration
ρ(α̈ e⊥ − α̇² e) + 2ρ̇α̇ e⊥ + ρ̈ e give G the factor ρ_j on the angle columns and a travel
column D_j n·e(α_j) (a free travel; a prescribed one's ρ̇, ρ̈ are inputs, in Φ̇ₚ and γ), and
the closure forces' share along the line (the slider's joint force) the same column.

A moving base. Ground points and slider lines are fixed in the base: positions are measured
from the base's point R_b, so its translation (a free base, a cart) cancels from Φ; a cart's
constant attitude turns the ground point g and the line's normal n₀ once (`NonlinearLoopSystem`);
a turning base (pinned, free) turns them with its attitude θ_b (a coordinate of y):
Φ = n·(Σ D e(α) − a), a = A(θ_b) g, n = A(θ_b) n₀ (a revolute's n: the global axes), with
ä = θ̈_b a⊥ − θ̇_b² a, ṅ = θ̇_b n⊥, n̈ = θ̈_b n⊥ − θ̇_b² n: the θ̈_b terms join G's attitude
column, the rest γ. The base's translation moves no node angle, so the mass matrix's columns
of a free base's x, y or a cart's free travel are the residual's changes under unit
accelerations of those coordinates.

Dynamics. With r(ÿ) = M ÿ + r₀ the model's residual (`_nonlinear_forward_numba.residual`:
inertia + damping + elastic − applied on y = [q, p_free, σ]; affine in ÿ, so M's columns
are its changes under unit accelerations), the constrained accelerations solve

    [ M   −Gᵀ ] [ÿ]   [ −r₀ ]
    [ G    0  ] [λ] = [ −γ  ],

λ the force the closing joint applies to the point of ``link`` (global axes, N; a slider:
along its line's normal), as in the first-order kernels (`_loops_numba.py`). Coordinate
partitioning keeps Φ = 0: `project` solves the dependent free joint angles (`dep`) and their
rates from the others by Newton's method at every evaluation.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._forward_numba import _solve
from ._loops_numba import NEWTON_ITERATIONS, REVOLUTE
from ._nonlinear_forward_numba import residual
from ._nonlinear_numba import mass_matrix, scaled, travel_columns

NonlinearLoopWork = namedtuple("NonlinearLoopWork", [
    "yp", "c", "s", "ad", "ang", "rate", "acc", "rot_acc", "Phi", "Phid", "G", "gam", "GJ",
    "Gd", "step", "X", "r0", "r1", "H", "HA", "K", "rhs", "rho", "rhod", "rhop", "rhodd",
    "closed", "rc", "rs"])
NonlinearLoopWork.__doc__ = (
    "Scratch arrays of the kernels (allocated once per run: see workspace); closed: 1 when "
    "the last `solve_constrained` closed the loops, else 0.")


def workspace(d, n_state: int) -> NonlinearLoopWork:
    """Scratch arrays for NonlinearLoopData d and states [y, ẏ] of n_state entries."""
    f = d.fwd
    nodes, N = f.Ay.shape[0], d.B_joint.shape[1]
    ny = n_state // 2
    nc = d.dep.shape[0]
    e = np.empty
    w = NonlinearLoopWork(e(n_state), e(nodes), e(nodes), e(nodes), e(nodes), e(nodes),
                          e(nodes), e(f.rot_J.shape[0]), e(nc), e(nc), e((nc, ny)), e(nc),
                          e((nc, N)), e((nc, nc)), e(nc), e(ny), e(ny), e(ny), e((nodes, nodes)),
                          e((ny, nodes)), e((ny + nc, ny + nc)), e(ny + nc), e(nodes),
                          e(nodes), e(nodes), e(nodes), np.zeros(1, dtype=np.int64), e(nodes),
                          e(nodes))
    return w


# The kernels that allocate nothing (prescribed, positions, curvature, project) are compiled
# without numba's runtime (``_nrt=False``, as `_forward_numba`'s): with it, every call increfs
# and decrefs each array of the records it is passed (with the tree's NonlinearForwardData
# and its loads' ForwardData, over a hundred), which cost as much as the closure's arithmetic.
@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def prescribed(d, w, u):
    """The prescribed parts of the node angles, rates, accelerations and of the rotary
    inertias' accelerations from the forward input row u (joint k: u[k], u[N + k],
    u[2N + k])."""
    N = d.B_joint.shape[1]
    for j in range(d.offset.shape[0]):
        a, r, c = d.offset[j], 0.0, 0.0
        for k in range(N):
            b = d.B_pres[j, k]
            if b != 0.0:
                a += b * u[k]
                r += b * u[N + k]
                c += b * u[2 * N + k]
        w.ang[j], w.rate[j], w.acc[j] = a, r, c
        w.rho[j], w.rhod[j], w.rhop[j], w.rhodd[j] = 1.0, 0.0, 0.0, 0.0
    # a slider's line node has the travel s as its length ρ: a prescribed travel's s, ṡ, s̈
    # from its input columns (a free one's from the state, `positions`, `curvature`)
    f = d.fwd
    for i in range(f.line_node.shape[0]):
        if f.line_col[i] < 0:
            j = f.line_node[i]
            w.rho[j] = u[f.line_u[i, 0]]
            w.rhod[j] = w.rhop[j] = u[f.line_u[i, 1]]
            w.rhodd[j] = u[f.line_u[i, 2]]
    for i in range(w.rot_acc.shape[0]):
        acc = 0.0
        for k in range(N):
            acc += d.rot_pres[i, k] * u[2 * N + k]
        w.rot_acc[i] = acc


# Inlined helpers take arrays and numbers, not records: numba copies an inlined record
# argument into a new record variable, which costs LLVM seconds per call site to split again.
@njit(inline="always")
def _row_axes(kind, ground, normal, c, e, cb, sb):
    """Closure c's equation row e: the direction (ex, ey) its component of Φ is taken along
    (x or y for a revolute, the line's normal n = A(θ_b) n₀ for a slider) and the ground
    point a = A(θ_b) g (m, from the base's point); cb, sb: cos, sin of the base's attitude;
    kind, ground, normal: NonlinearLoopData's."""
    ax = cb * ground[c, 0] - sb * ground[c, 1]
    ay = sb * ground[c, 0] + cb * ground[c, 1]
    if kind[c] == REVOLUTE:
        return (1.0, 0.0, ax, ay) if e == 0 else (0.0, 1.0, ax, ay)
    return (cb * normal[c, 0] - sb * normal[c, 1], sb * normal[c, 0] + cb * normal[c, 1],
            ax, ay)


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def positions(d, w, Y, fresh):
    """The node angles' cos, sin (w.c, w.s), Φ (w.Phi), G = ∂Φ/∂y (w.G), the joints' columns
    ∂Φ/∂β (w.GJ) and the prescribed joints' share of Φ̇ (w.Phid: Φ̇ = G ẏ + Phid) at the
    coordinates of Y = [y, ẏ] (the prescribed parts already in w: `prescribed`): what the
    closure's Newton iteration and its rates need, without the rates of y. ``fresh``: cos
    and sin from the angles; otherwise w.c, w.s already hold them (`_turn`)."""
    f = d.fwd
    Ay = f.Ay
    nodes, ny = Ay.shape[0], Y.shape[0] // 2
    if fresh:
        for j in range(nodes):
            a = w.ang[j]
            for i in range(Ay.shape[1]):
                a += Ay[j, i] * Y[i]
            w.c[j], w.s[j] = np.cos(a), np.sin(a)
    for i in range(f.line_node.shape[0]):  # a free travel: ρ from the state
        col = f.line_col[i]
        if col >= 0:
            w.rho[f.line_node[i]] = Y[col]
    # a turning base (pinned, free): its attitude θ_b turns the ground points and lines
    turn = d.turn
    th = Y[turn] if turn >= 0 else 0.0
    cb, sb = np.cos(th), np.sin(th)
    for c in range(d.kind.shape[0]):
        row = d.row[c]
        rows = 2 if d.kind[c] == REVOLUTE else 1
        for e in range(rows):
            ex, ey, ax, ay = _row_axes(d.kind, d.ground, d.normal, c, e, cb, sb)
            phi = -(ex * ax + ey * ay)
            phid = 0.0
            dx, dy = 0.0, 0.0  # Σ D e(α_j)
            for i in range(ny):
                w.G[row + e, i] = 0.0
            for k in range(d.B_joint.shape[1]):
                w.GJ[row + e, k] = 0.0
            for j in range(nodes):
                D = d.D[c, j]
                if D == 0.0:
                    continue
                along = ex * w.c[j] + ey * w.s[j]  # n·e(α_j)
                across = ey * w.c[j] - ex * w.s[j]  # n·e⊥(α_j)
                # the node's share ρ e(α) (ρ = 1 but on a slider's line, ρ = its travel s):
                # its rate ρ α̇ e⊥ + ρ̇ e (its acceleration in `curvature`)
                Dr = D * w.rho[j]
                phi += Dr * along
                phid += Dr * across * w.rate[j] + D * along * w.rhop[j]
                dx += Dr * w.c[j]
                dy += Dr * w.s[j]
                # (no test for zero entries: the branch costs more than the product)
                g = Dr * across
                for i in range(Ay.shape[1]):
                    w.G[row + e, i] += g * Ay[j, i]
                for k in range(d.B_joint.shape[1]):
                    w.GJ[row + e, k] += g * d.B_joint[j, k]
            for i in range(f.line_node.shape[0]):  # ∂Φ/∂s of each slider's travel
                D = d.D[c, f.line_node[i]]
                if D != 0.0:
                    j = f.line_node[i]
                    along = D * (ex * w.c[j] + ey * w.s[j])
                    if f.line_col[i] >= 0:
                        w.G[row + e, f.line_col[i]] += along
                    w.GJ[row + e, f.line_u[i, 0]] += along
            if turn >= 0:
                # Φ = n·(Σ D e(α) − a) (a = 0 between two links): the θ̈_b parts of ä = θ̈_b a⊥
                # − θ̇_b² a and of a slider's n̈ = θ̈_b n⊥ − θ̇_b² n in G's attitude column
                w.G[row + e, turn] -= ey * ax - ex * ay  # n·a⊥
                if rows == 1:
                    w.G[row + e, turn] += ex * (dy - ay) - ey * (dx - ax)  # n⊥·d
            w.Phi[row + e], w.Phid[row + e] = phi, phid


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def curvature(d, w, Y):
    """The node rates (w.ad) and γ (w.gam: Φ̈ = G ÿ + γ) at Y = [y, ẏ], after `positions`
    at Y's coordinates."""
    f = d.fwd
    Ay = f.Ay
    nodes, ny = Ay.shape[0], Y.shape[0] // 2
    for j in range(nodes):
        ad = w.rate[j]
        for i in range(Ay.shape[1]):
            ad += Ay[j, i] * Y[ny + i]
        w.ad[j] = ad
    for i in range(f.line_node.shape[0]):  # a free travel: ρ̇ from the state
        col = f.line_col[i]
        if col >= 0:
            w.rhod[f.line_node[i]] = Y[ny + col]
    turn = d.turn
    th, om = (Y[turn], Y[ny + turn]) if turn >= 0 else (0.0, 0.0)
    cb, sb = np.cos(th), np.sin(th)
    for c in range(d.kind.shape[0]):
        row = d.row[c]
        rows = 2 if d.kind[c] == REVOLUTE else 1
        for e in range(rows):
            ex, ey, ax, ay = _row_axes(d.kind, d.ground, d.normal, c, e, cb, sb)
            gam = 0.0
            dx, dy, vx, vy = 0.0, 0.0, 0.0, 0.0  # Σ D e(α_j), Σ D e⊥(α_j) α̇_j
            for j in range(nodes):
                D = d.D[c, j]
                if D == 0.0:
                    continue
                along = ex * w.c[j] + ey * w.s[j]  # n·e(α_j)
                across = ey * w.c[j] - ex * w.s[j]  # n·e⊥(α_j)
                # the acceleration of ρ e(α): ρ(α̈ e⊥ − α̇² e) + 2ρ̇α̇ e⊥ + ρ̈ e
                rho, rhod = w.rho[j], w.rhod[j]
                Dr = D * rho
                gam += Dr * (across * w.acc[j] - along * w.ad[j] * w.ad[j]) + D * (
                    2.0 * rhod * w.ad[j] * across + along * w.rhodd[j])
                dx += Dr * w.c[j]
                dy += Dr * w.s[j]
                vx += D * (rhod * w.c[j] - rho * w.s[j] * w.ad[j])
                vy += D * (rhod * w.s[j] + rho * w.c[j] * w.ad[j])
            if turn >= 0:
                # ä = θ̈_b a⊥ − θ̇_b² a; a slider's n turns too, ṅ = θ̇_b n⊥, n̈ = θ̈_b n⊥ − θ̇_b² n
                gam += om * om * (ex * ax + ey * ay)
                if rows == 1:
                    rx, ry = dx - ax, dy - ay  # d
                    wx, wy = vx + om * ay, vy - om * ax  # ḋ
                    gam += 2.0 * om * (ex * wy - ey * wx) - om * om * (ex * rx + ey * ry)
            w.gam[row + e] = gam


# Python's entry to the closure equations (the tests; the choice of a slider loop's dependent
# joints): `prescribed`, `positions` and `curvature` have no Python wrappers (only kernels
# call them). Not cached: no warm-up run reaches it at installation.
@njit
def constraints(d, w, u, Y):
    """The prescribed parts at the input row u (`prescribed`), then Φ (w.Phi), G = ∂Φ/∂y
    (w.G), γ (w.gam), the joints' columns ∂Φ/∂β (w.GJ) and the prescribed joints' share of
    Φ̇ (w.Phid: Φ̇ = G ẏ + Phid) at the state Y = [y, ẏ]."""
    prescribed(d, w, u)
    positions(d, w, Y, bool(1))
    curvature(d, w, Y)


# Node angles that a Newton step moves by at most this (rad) have their cos and sin turned by
# the step (Taylor terms to Δα⁴: the first neglected, Δα⁵/120, is below 1e-22) instead of
# evaluated again: the step near a closed state is ~1e-9 rad, and the transcendental
# functions of every node are a large part of a rate evaluation.
SMALL_TURN = 1e-4


@njit(inline="always")
def _turn(Ay, dep, step, ad, cos, sin):
    """After a Newton step ``step`` on the dependent angles ``dep``: turn the nodes' cos, sin
    (w.c, w.s) by the node angles' change Δα = Ay[:, dep] step (scratch: ad) and return True,
    unless some |Δα| exceeds SMALL_TURN (then cos, sin are left for `positions` to evaluate
    afresh)."""
    nodes, nc = Ay.shape[0], dep.shape[0]
    big = 0.0
    for j in range(nodes):
        da = 0.0
        for k in range(nc):
            da += Ay[j, dep[k]] * step[k]
        ad[j] = da
        big = max(big, abs(da))
    if big > SMALL_TURN:
        return False
    for j in range(nodes):
        da = ad[j]
        d2 = da * da
        cd = 1.0 - d2 * (0.5 - d2 / 24.0)
        sd = da * (1.0 - d2 / 6.0)
        c, s = cos[j], sin[j]
        cos[j] = c * cd - s * sd
        sin[j] = s * cd + c * sd
    return True


@njit(cache=True, _nrt=False)
def project(d, w, u, Y):
    """Overwrite the dependent joint angles of Y = [y, ẏ] (y indices ``d.dep``) and their
    rates with those that close the loops, Newton's method from Y's values; True when
    |Φ| ≤ d.tol (then w holds the closed state's Φ, G, γ)."""
    ny = Y.shape[0] // 2
    nc = d.dep.shape[0]
    prescribed(d, w, u)
    closed = False
    fresh = bool(1)  # a plain bool: a literal True would compile `positions` once more
    for _ in range(NEWTON_ITERATIONS):
        positions(d, w, Y, fresh)
        big = 0.0
        for c in range(nc):
            big = max(big, abs(w.Phi[c]))
        if big <= d.tol:
            closed = True
            break
        for c in range(nc):
            w.step[c] = -w.Phi[c]
            for j in range(nc):
                w.Gd[c, j] = w.G[c, d.dep[j]]
        _solve(w.Gd, w.step)
        for j in range(nc):
            Y[d.dep[j]] += w.step[j]
        fresh = not _turn(d.fwd.Ay, d.dep, w.step, w.ad, w.c, w.s)
    if not closed:
        return False
    # rates: Φ̇ = G ẏ + Phid = 0 is linear in the dependent ones (one solve); then γ at those
    # rates (the coordinates, and so w's positions, unchanged)
    for c in range(nc):
        acc = w.Phid[c]
        for i in range(ny):
            acc += w.G[c, i] * Y[ny + i]
        w.step[c] = -acc
        for j in range(nc):
            w.Gd[c, j] = w.G[c, d.dep[j]]
    _solve(w.Gd, w.step)
    for j in range(nc):
        Y[ny + d.dep[j]] += w.step[j]
    curvature(d, w, Y)
    return True


# Inlined by numba into `rates` and `closed_states` (its records' fields are read, not copied
# into new records): called, as a kernel of its own, it made each rate evaluation ~7% slower.
@njit(inline="always")
def solve_constrained(d, w, u, Y):
    """Project Y (w.yp ← Y closed) and solve the constrained equations: ÿ in w.rhs[:n_y],
    λ in w.rhs[n_y:]; w.closed[0] = 0 when the loop does not close (w.rhs is then NaN),
    else 1."""
    f = d.fwd
    ny = Y.shape[0] // 2
    nc = d.dep.shape[0]
    yp = w.yp
    for i in range(Y.shape[0]):
        yp[i] = Y[i]
    if not project(d, w, u, yp):
        w.rhs[:] = np.nan
        w.closed[0] = 0
        return
    w.closed[0] = 1
    y, v = yp[:ny], yp[ny:]
    X, r0 = w.X, w.r0
    X[:] = 0.0
    residual(f, y, v, X, w.ang, w.rate, w.acc, w.rot_acc, u, r0)
    # the residual is affine in ÿ: M ÿ + r0, M the inertia's (a fixed base: no translation
    # rows) and 1 on each servo integral's row (σ̈ − its rate)
    lines = f.line_node.shape[0]
    K, rhs = w.K, w.rhs
    for i in range(ny):
        for k in range(ny):
            K[i, k] = 0.0
    if lines == 0:
        mass_matrix(f.Ay, d.At, f.G, f.rot_y, f.rot_J, w.c, w.s, w.H, w.HA, K)
    else:
        mass_matrix(f.Ay, d.At, f.G, f.rot_y, f.rot_J, scaled(w.rho, w.c, w.rc),
                    scaled(w.rho, w.s, w.rs), w.H, w.HA, K)
        travel_columns(f.Ay, f.G, f.line_node, f.line_col, w.c, w.s, w.rc, w.rs, K)
    # a translating base (free: x, y; a cart with a free travel: s) moves no node angle, so
    # mass_matrix leaves its columns out: they are the residual's change under a unit
    # acceleration (it is affine in ÿ), its rows their transposes (M symmetric)
    for k in d.moving:
        X[k] = 1.0
        residual(f, y, v, X, w.ang, w.rate, w.acc, w.rot_acc, u, w.r1)
        X[k] = 0.0
        for i in range(f.n + f.nu):
            K[i, k] = w.r1[i] - r0[i]
            K[k, i] = K[i, k]
    for i in range(f.n + f.nu, ny):
        K[i, i] = 1.0
    for i in range(ny):
        rhs[i] = -r0[i]
        for c in range(nc):
            K[i, ny + c] = -w.G[c, i]
            K[ny + c, i] = w.G[c, i]
    for c in range(nc):
        rhs[ny + c] = -w.gam[c]
        for e in range(nc):
            K[ny + c, ny + e] = 0.0
    _solve(K, rhs)


@njit(cache=True)
def rates(d, w, u, Y, dY):
    """dY/dt of Y = [y, ẏ] on the closed loops (the dependent joints' entries of Y are not
    read: see `project`)."""
    solve_constrained(d, w, u, Y)
    if w.closed[0] == 0:
        dY[:] = np.nan
        return
    ny = Y.shape[0] // 2
    for i in range(ny):
        dY[i] = w.yp[ny + i]
        dY[ny + i] = w.rhs[i]


@njit(cache=True)
def closed_states(d, w, u, states, accelerations, lam, joint_forces, residual_out):
    """After a run: each state [y, ẏ] (nt, ·) projected onto the loops in place, its ÿ
    (nt, n_y), the multipliers λ (nt, n_c), the constraint forces' torque on each joint
    (∂Φ/∂βᵀ λ, nt × N, N·m) and the largest |Φ| of the projected state (nt,; m, NaN where it
    does not close)."""
    ny = states.shape[1] // 2
    nc = d.dep.shape[0]
    for t in range(states.shape[0]):
        solve_constrained(d, w, u[t], states[t])
        ok = w.closed[0] == 1
        for i in range(states.shape[1]):
            states[t, i] = w.yp[i]
        big = 0.0
        for c in range(nc):
            lam[t, c] = w.rhs[ny + c]
            big = max(big, abs(w.Phi[c]))
        residual_out[t] = big if ok else np.nan
        for i in range(ny):
            accelerations[t, i] = w.rhs[i]
        for k in range(joint_forces.shape[1]):
            acc = 0.0
            for c in range(nc):
                acc += w.GJ[c, k] * w.rhs[ny + c]
            joint_forces[t, k] = acc
