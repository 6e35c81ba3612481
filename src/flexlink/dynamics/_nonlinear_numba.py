"""Compiled (numba) kernels of the nonlinear model (records: `nonlinear_kernel.py`): the
inertia and elastic forces of one state, shared by both nonlinear paths
(`inertia_elastic`); the residual of the model with every rigid coordinate prescribed
(`NonlinearData`: those forces minus the given loads on q) and the accelerations of a
batch of its states. The numpy expressions of ``NonlinearSystem`` and
``NonlinearForwardSystem`` written as loops (tiny sizes: BLAS calls and temporary arrays
cost more than the arithmetic); the tests compare both implementations."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from .._compiled_calls import stack_array


# inertia_elastic and the residuals are compiled without numba's runtime (``_nrt=False``, as
# `_forward_numba`'s kernels), their scratch on the stack: with it, each call allocated its
# scratch arrays and counted every array it was passed, at each call level, with atomic
# operations that cost a third of the residual (a Gauss run calls it some 10⁴ times).
@njit(cache=True, _nrt=False)
def inertia_elastic(Ay, G, lift, m_tot, translation, rot_y, rot_J, D, K, n, nu, gravity, cart,
                    rail, rail_acc, line_node, line_col, line_s, Y, V, X, ang, rate, acc,
                    rot_acc, out):
    """Generalized inertia + damping + elastic forces of one state into ``out`` (rows
    [q, p_free] of y; rows beyond them zeroed) — NonlinearSystem.residual and
    NonlinearForwardSystem._inertia written as loops, for either record of
    `nonlinear_kernel.py`, whose fields (Ay … rail, line_node, line_col) it takes one by one:
    each call of a compiled function takes a record's arrays one by one, so the residuals
    unpack theirs once. Y, V, X: the unknowns' values, rates and accelerations; ang, rate,
    acc (nodes,), rot_acc (n_rot,): the prescribed parts; rail_acc: a cart's s̈ along
    ``rail``, m/s² (cart 1: X[n]; cart 2: its prescribed travel's); line_s (n_lines, 3): each
    slider's travel s, ṡ, s̈ (m, m/s, m/s²), the length of its line node ``line_node``.

    Node j turns by α_j = ang_j + Ay_j·y (rates and accelerations alike) and has the length
    ρ_j (1, a slider's line node its travel s). Its contribution to the accelerations of the
    points it carries is a_j = ρ(α̈ e⊥ − α̇² e) + 2ρ̇α̇ e⊥ + ρ̈ e (e = e(α_j)); with
    F_j = Σ_l G_jl a_l + lift_j (R̈_b − g) its generalized inertia moment on its angle is
    u_j = ρ_j e⊥_j·F_j and a line's force on its travel e_j·F_j (docs/nonlinear.md §7), G the
    nodes' coupling weights, lift = Wᵀm the mass each node carries, R̈_b − g the base point's
    acceleration minus gravity (global axes). This is where gravity enters the nonlinear model
    (equivalence principle: the field is the base's acceleration −g); on a free base the same
    R̈_b − g drives the translation rows, on a cart with a free travel its component along the
    rail drives row n."""
    nodes = Ay.shape[0]
    m = n + nu  # columns with node angles
    c = stack_array(nodes)
    s = stack_array(nodes)
    S = stack_array((nodes, 4))
    line_f = stack_array(line_node.shape[0])  # the inertia force along each line
    rho = stack_array(nodes)
    rho_d = stack_array(nodes)
    rho_dd = stack_array(nodes)
    for j in range(nodes):
        rho[j], rho_d[j], rho_dd[j] = 1.0, 0.0, 0.0
    for i in range(line_node.shape[0]):
        rho[line_node[i]] = line_s[i, 0]
        rho_d[line_node[i]] = line_s[i, 1]
        rho_dd[line_node[i]] = line_s[i, 2]
    rx, ry = -gravity[0], -gravity[1]
    if translation:
        rx, ry = X[n] + rx, X[n + 1] + ry
    if cart > 0:
        rx, ry = rail_acc * rail[0] + rx, rail_acc * rail[1] + ry
    force = translation or cart == 1  # the base's inertia force is a row of the residual
    for j in range(nodes):
        alpha = ang[j]
        alpha_dot = rate[j]
        alpha_ddot = acc[j]
        for i in range(m):
            a = Ay[j, i]
            if a != 0.0:
                alpha += a * Y[i]
                alpha_dot += a * V[i]
                alpha_ddot += a * X[i]
        c[j] = np.cos(alpha)
        s[j] = np.sin(alpha)
        # a_j = T e⊥ − R e: T = ρα̈ + 2ρ̇α̇, R = ρα̇² − ρ̈ (α̈ and α̇² where ρ = 1)
        tangential = rho[j] * alpha_ddot + 2.0 * rho_d[j] * alpha_dot
        radial = rho[j] * (alpha_dot * alpha_dot) - rho_dd[j]
        S[j, 0] = c[j] * tangential
        S[j, 1] = s[j] * tangential
        S[j, 2] = c[j] * radial
        S[j, 3] = s[j] * radial
    out[:] = 0.0
    fx = fy = 0.0
    for j in range(nodes):
        g0 = 0.0
        g1 = 0.0
        g2 = 0.0
        g3 = 0.0
        for k in range(nodes):
            w = G[j, k]
            g0 += w * S[k, 0]
            g1 += w * S[k, 1]
            g2 += w * S[k, 2]
            g3 += w * S[k, 3]
        # F_j = Σ_l G_jl a_l + lift_j (R̈_b − g) = (−g1 − g2, g0 − g3) + lift_j (rx, ry)
        uj = c[j] * (g0 - g3) + s[j] * (g1 + g2)
        if rx != 0.0 or ry != 0.0:
            uj += lift[j] * (c[j] * ry - s[j] * rx)
        if force:
            fx += lift[j] * (-S[j, 1] - S[j, 2])
            fy += lift[j] * (S[j, 0] - S[j, 3])
        for i in range(m):
            out[i] += Ay[j, i] * rho[j] * uj
        for i in range(line_node.shape[0]):
            if line_node[i] == j:
                line_f[i] = (c[j] * (lift[j] * rx - g1 - g2)
                             + s[j] * (g0 - g3 + lift[j] * ry))
    for i in range(line_node.shape[0]):
        if line_col[i] >= 0:  # a free travel: the inertia force along its line
            out[line_col[i]] += line_f[i]
    for r in range(rot_J.shape[0]):
        if rot_J[r] == 0.0:
            continue
        ar = rot_acc[r]
        for i in range(m):
            ar += rot_y[r, i] * X[i]
        ar *= rot_J[r]
        for i in range(m):
            out[i] += rot_y[r, i] * ar
    for i in range(n):
        for k in range(n):
            out[i] += D[i, k] * V[k] + K[i, k] * Y[k]
    if translation:
        out[n] += m_tot * rx + fx
        out[n + 1] += m_tot * ry + fy
    elif cart == 1:  # the inertia force along the rail on s
        out[n] += (m_tot * rx + fx) * rail[0] + (m_tot * ry + fy) * rail[1]


@njit(cache=True, _nrt=False)
def residual(d, Y, V, X, ang, rate, acc, rot_acc, u, out):
    """Inertia + damping + elastic − applied (u, n) forces of one state (n,) of the model
    with prescribed joints (d: NonlinearData) into ``out`` — NonlinearSystem.residual
    (rot_acc: the tips' prescribed angular accelerations)."""
    inertia_elastic(d.Ay, d.G, d.s, d.m_tot, d.translation, d.rot_y, d.rot_J, d.Dq, d.Kq, d.n,
                    d.nu, d.gravity, d.cart, d.rail, 0.0, d.line_node, d.line_col,
                    stack_array((0, 3)), Y, V, X, ang, rate, acc, rot_acc, out)
    for i in range(d.n):
        out[i] -= u[i]


@njit(cache=True)
def accelerations(d, q, qd, ang, rate, acc, rot_acc, load):
    """q̈ (b, n) of M q̈ = f for b states (d: NonlinearData); M = Aᵀ(G ∘ cos(α_j − α_l))A +
    Σ J_t a_t a_tᵀ."""
    b, n = q.shape
    A = d.Ay
    nodes = A.shape[0]
    out = np.empty((b, n))
    H = np.empty((nodes, nodes))
    HA = np.empty((nodes, n))
    At = np.ascontiguousarray(A.T)
    zero = np.zeros(n)
    f = np.empty(n)
    for t in range(b):
        residual(d, q[t], qd[t], zero, ang[t], rate[t], acc[t], rot_acc[t], load[t], f)
        c = np.cos(np.dot(A, q[t]) + ang[t])
        s = np.sin(np.dot(A, q[t]) + ang[t])
        M = mass_matrix(A, At, d.G, d.rot_y, d.rot_J, c, s, H, HA)
        solved = np.linalg.solve(M, -f)
        for i in range(n):  # (a loop: a slice assignment links numba's shape error in)
            out[t, i] = solved[i]
    return out


@njit(cache=True)
def mass_matrix(A, At, G, rot_y, rot_J, c, s, H, HA):
    """M = Aᵀ(G ∘ cos(α_j − α_l))A + Σ J_r a_r a_rᵀ (the columns of A: A (nodes, m), At its
    transpose, contiguous; rot_y's first m columns) from c = cos α, s = sin α of the nodes;
    H (nodes, nodes), HA (nodes, m) scratch. The inertia forces' coefficients of the
    accelerations (`inertia_elastic` is affine in them)."""
    nodes, n = A.shape
    for j in range(nodes):
        for m in range(nodes):
            H[j, m] = G[j, m] * (c[j] * c[m] + s[j] * s[m])
    product = np.dot(H, A)
    for j in range(nodes):  # (a loop: a slice assignment links numba's shape error in)
        for m in range(n):
            HA[j, m] = product[j, m]
    M = np.dot(At, HA)
    for k in range(rot_J.shape[0]):
        for i in range(n):
            for m in range(n):
                M[i, m] += rot_J[k] * rot_y[k, i] * rot_y[k, m]
    return M
