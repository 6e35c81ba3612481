"""Compiled (numba) residual and accelerations of the nonlinear model with rigid coordinates
(d: `nonlinear_kernel.NonlinearForwardData`) — `NonlinearForwardSystem.residual` and
`.accelerations` (the numpy reference, docs/nonlinear.md §7) written as loops over the tiny
arrays. The inertia and elastic forces are the prescribed model's
(`_nonlinear_numba.inertia_elastic`, the same code; a cart's travel enters it as the base's
acceleration along the rail); the applied forces are the first-order forward kernel's
(`_forward_numba.applied`: drive torques, servo laws — a cart's drive force by the joints'
drive law —, base loads), so each law has one compiled and one numpy copy, both tested
against each other. tests/unit/test_nonlinear_forward.py compares this module with the
numpy equations to round-off."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from .._compiled_calls import borrowed, stack_array
from ._forward_numba import _solve
from ._forward_numba import applied as _applied
from ._nonlinear_numba import (
    directions,
    inertia_elastic,
    mass_matrix,
    node_angles,
    scaled,
    travel_columns,
)


@njit(cache=True, _nrt=False)  # (no runtime: see _nonlinear_numba.inertia_elastic)
def residual(d, Y, V, X, ang, rate, acc, rot_acc, u, out):
    """Residual (n_y,) of one state into ``out``: inertia + damping + elastic − applied on
    [q, p_free] (the actuators' forces B V on q, V from the input row u), σ̈ − integral rate
    on σ (NonlinearForwardSystem.residual)."""
    n, nu = d.n, d.nu
    m = n + nu
    # a cart's s̈ along its rail: y's, or the prescribed travel's input column
    rail_acc = X[n] if d.cart == 1 else (u[u.shape[0] - 2] if d.cart == 2 else 0.0)
    # each slider's travel, speed, acceleration: y's, or its prescribed input columns
    lines = d.line_node.shape[0]
    line_s = stack_array((lines, 3))
    for i in range(lines):
        col = d.line_col[i]
        if col >= 0:
            line_s[i, 0], line_s[i, 1], line_s[i, 2] = Y[col], V[col], X[col]
        else:
            for r in range(3):
                line_s[i, r] = u[d.line_u[i, r]]
    inertia_elastic(d.Ay, d.G, d.s, d.m_tot, d.translation, d.rot_y, d.rot_J, d.Dq, d.Kq, n, nu,
                    d.gravity, d.cart, d.rail, rail_acc, d.line_node, d.line_col, line_s, Y, V,
                    X, ang, rate, acc, rot_acc, out)
    ns = Y.shape[0] - m
    p = stack_array(d.n_rigid)
    pd = stack_array(d.n_rigid)
    Q = stack_array(d.n_x)
    rates = stack_array(max(ns, 1))
    if nu > 0 or d.actuator_B.shape[1] > 0:
        p[:] = 0.0
        pd[:] = 0.0
        for i in range(nu):
            p[d.free[i]] = Y[n + i]
            pd[d.free[i]] = V[n + i]
        rates[:] = 0.0
        _applied(d, u, p, pd, V[m:], Q, rates)
        for i in range(nu):
            out[n + i] -= Q[d.free[i]]
        for i in range(n):  # the actuators' forces on q (zero without actuators)
            out[i] -= Q[d.n_rigid + i]
        for i in range(ns):
            out[m + i] = X[m + i] - rates[i]


@njit(cache=True)
def accelerations(d, Y, V, ang, rate, acc, rot_acc, u):
    """ÿ (b, n_y) of b states: M ÿ = −r(ÿ = 0), the residual being affine in ÿ. M from the
    node angles (`mass_matrix` on the angle columns, `travel_columns` on a slider's free
    travel, 1 on each servo integral's row), the columns of a translating base's coordinates
    (a free base: x, y; a cart with a free travel: s), which move no node angle, as the
    residual's change under a unit acceleration (their rows: M symmetric). One residual a
    state, two on a cart, and no iteration: a quarter (Case 23's slider on a cart, 4 modes)
    to two fifths (Case 23, 6 modes) less CPU than iterating with an earlier state's
    (Broyden-updated) inverse mass matrix, and equal to the numpy equations' direct solve
    to round-off."""
    b, ny = Y.shape
    n, m = d.n, d.n + d.nu
    Ay = d.Ay
    nodes = Ay.shape[0]
    lines = d.line_node.shape[0]
    out = np.empty((b, ny))
    # the residual's arguments uncounted (`borrowed`, on the stack): each count is atomic
    Y, V, ang, rate, acc = borrowed(Y), borrowed(V), borrowed(ang), borrowed(rate), borrowed(acc)
    rot_acc, u, outb = borrowed(rot_acc), borrowed(u), borrowed(out)
    X = stack_array(ny)
    X[:] = 0.0
    r0 = stack_array(ny)
    r1 = stack_array(ny)
    K = stack_array((ny, ny))
    rhs = stack_array(ny)
    theta = stack_array(nodes)
    phi = stack_array(nodes)
    c = stack_array(nodes)
    s = stack_array(nodes)
    rc = stack_array(nodes)
    rs = stack_array(nodes)
    rho = stack_array(nodes)
    H = stack_array((nodes, nodes))
    columns = Ay.shape[1]  # (those of the servo integrals zero)
    HA = stack_array((columns, nodes))
    At = stack_array((columns, nodes))
    for j in range(nodes):
        for i in range(columns):
            At[i, j] = Ay[j, i]
    moving = 2 if d.translation else (1 if d.cart == 1 else 0)  # columns n, n + 1
    for t in range(b):
        y = Y[t]
        residual(d, y, V[t], X, ang[t], rate[t], acc[t], rot_acc[t], u[t], r0)
        # (rc, rs take the node rates unread: scratch until `scaled` below)
        node_angles(Ay, n, m, ang[t], rate[t], acc[t], y, V[t], X, theta, phi, rc, rs)
        directions(theta, phi, c, s)
        for j in range(nodes):
            rho[j] = 1.0
        for i in range(lines):  # a line node's length: its travel, y's or the input's
            col = d.line_col[i]
            rho[d.line_node[i]] = y[col] if col >= 0 else u[t, d.line_u[i, 0]]
        for i in range(ny):
            for k in range(ny):
                K[i, k] = 0.0
        mass_matrix(Ay, At, d.G, d.rot_y, d.rot_J, scaled(rho, c, rc), scaled(rho, s, rs), H,
                    HA, K)
        if lines > 0:
            travel_columns(Ay, d.G, d.line_node, d.line_col, c, s, rc, rs, K)
        for e in range(moving):
            k = n + e
            X[k] = 1.0
            residual(d, y, V[t], X, ang[t], rate[t], acc[t], rot_acc[t], u[t], r1)
            X[k] = 0.0
            for i in range(m):
                K[i, k] = r1[i] - r0[i]
                K[k, i] = K[i, k]
        for i in range(m, ny):  # σ̈ − its rate
            K[i, i] = 1.0
        finite = True
        for i in range(ny):
            rhs[i] = -r0[i]
            finite = finite and np.isfinite(r0[i])
        _solve(K, rhs)
        if finite and not np.isfinite(rhs[0]):  # (`_solve`'s zero pivot)
            raise np.linalg.LinAlgError("singular mass matrix")
        for i in range(ny):  # (a loop: a slice assignment links numba's shape error in)
            outb[t, i] = rhs[i]
    return out


@njit(cache=True)
def joint_torques(d, A_joint, rot_joint, line_rows, Y, V, X, ang, rate, acc, rot_acc, u, out):
    """Each joint's generalized inertia force (b, N) of b states y, ẏ, ÿ into ``out`` —
    `NonlinearForwardSystem.joint_torques`, N·m (a slider's: N). The model's inertia
    (`inertia_elastic`) with the joints' columns appended to the unknowns' (A_joint = [Ay's
    first n + nu columns | B's joint columns], rot_joint likewise from rot_y and rot_B) at
    zero values, rates and accelerations of those columns: the node angles are unchanged and
    row n + nu + k is Σ_j B_jk ρ_j u_j + Σ_r rot_B_rk J_r α̈_r, joint k's torque; each
    slider's line force goes to row ``line_rows`` (n_lines,) of its joint instead of its
    travel's (whose B and rot_joint columns are zero: a travel turns nothing)."""
    b = Y.shape[0]
    m = d.n + d.nu
    N = out.shape[1]
    Yj = np.zeros(m + N)
    Vj = np.zeros(m + N)
    Xj = np.zeros(m + N)
    r = np.empty(m + N)
    lines = d.line_node.shape[0]
    line_s = np.empty((lines, 3))
    for t in range(b):
        for i in range(m):
            Yj[i], Vj[i], Xj[i] = Y[t, i], V[t, i], X[t, i]
        # a cart's s̈ along its rail: y's, or the prescribed travel's input column
        rail_acc = X[t, d.n] if d.cart == 1 else (u[t, u.shape[1] - 2] if d.cart == 2
                                                   else 0.0)
        for i in range(lines):  # each slider's travel: y's, or its prescribed input columns
            col = d.line_col[i]
            if col >= 0:
                line_s[i, 0], line_s[i, 1], line_s[i, 2] = Y[t, col], V[t, col], X[t, col]
            else:
                for k in range(3):
                    line_s[i, k] = u[t, d.line_u[i, k]]
        inertia_elastic(A_joint, d.G, d.s, d.m_tot, d.translation, rot_joint, d.rot_J, d.Dq,
                        d.Kq, d.n, d.nu + N, d.gravity, d.cart, d.rail, rail_acc, d.line_node,
                        line_rows, line_s, Yj, Vj, Xj, ang[t], rate[t], acc[t], rot_acc[t], r)
        for k in range(N):
            out[t, k] = r[m + k]
