"""Compiled (numba) kernels of the nonlinear model (records: `nonlinear_kernel.py`): the
inertia and elastic forces of one state, shared by both nonlinear paths
(`inertia_elastic`); the residual of the model with every rigid coordinate prescribed
(`NonlinearData`: those forces minus the given loads on q) and the accelerations of a
batch of its states. The numpy expressions of ``NonlinearSystem`` and
``NonlinearForwardSystem`` written as loops (tiny sizes: BLAS calls and temporary arrays
cost more than the arithmetic); the tests compare both implementations."""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from .._compiled_calls import stack_array

# A node's angle is its link's rigid angle θ (the nodes of one link share it, to the bit) plus
# the elastic slope φ = Σ A_ji q_i, mostly well below SMALL_ANGLE rad: cos and sin of α = θ + φ
# by the angle-addition formulas, θ's computed once per run of equal values and φ's by their
# Taylor series, to x¹⁵ and x¹⁶ (the next terms below 10⁻¹⁹ of the result at 0.5 rad: within
# an ulp), a branch-free loop the compiler vectorises; a slope beyond SMALL_ANGLE takes libm's.
SMALL_ANGLE = 0.5
_S3, _S5, _S7, _S9, _S11, _S13, _S15 = (
    (-1.0) ** k / math.factorial(2 * k + 1) for k in range(1, 8))
_C2, _C4, _C6, _C8, _C10, _C12, _C14, _C16 = (
    (-1.0) ** k / math.factorial(2 * k) for k in range(1, 9))


@njit(inline="always")
def small_sin_cos(x):
    """sin x and cos x for |x| ≤ SMALL_ANGLE (their Taylor series, Horner's rule in x²)."""
    x2 = x * x
    s = x + x * x2 * (_S3 + x2 * (_S5 + x2 * (_S7 + x2 * (_S9 + x2 * (_S11 + x2 * (
        _S13 + x2 * _S15))))))
    c = 1.0 + x2 * (_C2 + x2 * (_C4 + x2 * (_C6 + x2 * (_C8 + x2 * (_C10 + x2 * (
        _C12 + x2 * (_C14 + x2 * _C16)))))))
    return s, c


@njit(inline="always")
def directions(theta, phi, c, s):
    """cos and sin (c, s) of each node's angle θ + φ from its rigid angle θ and elastic slope
    φ (nodes,): θ's once per run of equal values, φ's by `small_sin_cos` up to SMALL_ANGLE
    (libm's beyond). With this and `inertia_elastic`'s product with G by rows the residual
    costs 11% (Case 23's slider on a cart, 4 modes, 15 nodes) to 13% (Case 23, 6 modes, 23
    nodes) less than with libm's sincos at every node and G's rows summed one by one."""
    nodes = theta.shape[0]
    for j in range(nodes):  # (no call, no branch: vectorised)
        s[j], c[j] = small_sin_cos(phi[j])
    last = np.nan
    c_last = 1.0
    s_last = 0.0
    for j in range(nodes):
        if not abs(phi[j]) <= SMALL_ANGLE:
            s[j] = np.sin(phi[j])
            c[j] = np.cos(phi[j])
        if theta[j] != last:
            last = theta[j]
            c_last = np.cos(last)
            s_last = np.sin(last)
        c_phi, s_phi = c[j], s[j]
        c[j] = c_last * c_phi - s_last * s_phi
        s[j] = s_last * c_phi + c_last * s_phi


@njit(inline="always")
def node_angles(Ay, n, m, ang, rate, acc, Y, V, X, theta, phi, alpha_d, alpha_dd):
    """Each node's rigid angle θ = ang + Ay[:, n:m]·Y[n:m] and elastic slope φ =
    Ay[:, :n]·Y[:n] (α = θ + φ, `directions`), rad, its rate α̇ = rate + Ay·V and
    acceleration α̈ = acc + Ay·X (nodes,), from the first m columns of Ay. Column by column,
    the inner loop along the nodes (vectorised; each sum in the order of the columns)."""
    nodes = Ay.shape[0]
    for j in range(nodes):
        theta[j] = ang[j]
        phi[j] = 0.0
        alpha_d[j] = rate[j]
        alpha_dd[j] = acc[j]
    for i in range(m):
        y, v, x = Y[i], V[i], X[i]
        sums = phi if i < n else theta
        for j in range(nodes):
            a = Ay[j, i]
            sums[j] += a * y
            alpha_d[j] += a * v
            alpha_dd[j] += a * x


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
    rail drives row n. G must be symmetric (its rows are read as its columns)."""
    nodes = Ay.shape[0]
    m = n + nu  # columns with node angles
    c = stack_array(nodes)
    s = stack_array(nodes)
    theta = stack_array(nodes)  # each node's rigid angle (columns n … m of Ay)
    phi = stack_array(nodes)  # … and its elastic slope (columns 0 … n)
    alpha_d = stack_array(nodes)
    alpha_dd = stack_array(nodes)
    # S = [c T, s T, c R, s R] (nodes, 4) as four rows (vectorised; (nodes, 4) was not)
    S0s = stack_array(nodes)
    S1s = stack_array(nodes)
    S2s = stack_array(nodes)
    S3s = stack_array(nodes)
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
    node_angles(Ay, n, m, ang, rate, acc, Y, V, X, theta, phi, alpha_d, alpha_dd)
    directions(theta, phi, c, s)
    for j in range(nodes):
        # a_j = T e⊥ − R e: T = ρα̈ + 2ρ̇α̇, R = ρα̇² − ρ̈ (α̈ and α̇² where ρ = 1)
        tangential = rho[j] * alpha_dd[j] + 2.0 * rho_d[j] * alpha_d[j]
        radial = rho[j] * (alpha_d[j] * alpha_d[j]) - rho_dd[j]
        S0s[j] = c[j] * tangential
        S1s[j] = s[j] * tangential
        S2s[j] = c[j] * radial
        S3s[j] = s[j] * radial
    # g = G S (nodes, 4) as sums of G's rows (G symmetric): the inner loop runs along a row
    # and vectorises, which a sum along each row (a reduction, ordered) does not; four rows
    # of their own, which the compiler keeps apart from G (one (4, nodes) array measured up to
    # a sixth slower on the residual of a 20-node link)
    g0s = stack_array(nodes)
    g1s = stack_array(nodes)
    g2s = stack_array(nodes)
    g3s = stack_array(nodes)
    for j in range(nodes):
        g0s[j] = g1s[j] = g2s[j] = g3s[j] = 0.0
    for k in range(nodes):
        S0, S1, S2, S3 = S0s[k], S1s[k], S2s[k], S3s[k]
        for j in range(nodes):
            w = G[k, j]
            g0s[j] += w * S0
            g1s[j] += w * S1
            g2s[j] += w * S2
            g3s[j] += w * S3
    out[:] = 0.0
    fx = fy = 0.0
    for j in range(nodes):
        g0, g1, g2, g3 = g0s[j], g1s[j], g2s[j], g3s[j]
        # F_j = Σ_l G_jl a_l + lift_j (R̈_b − g) = (−g1 − g2, g0 − g3) + lift_j (rx, ry)
        uj = c[j] * (g0 - g3) + s[j] * (g1 + g2)
        if rx != 0.0 or ry != 0.0:
            uj += lift[j] * (c[j] * ry - s[j] * rx)
        if force:
            fx += lift[j] * (-S1s[j] - S2s[j])
            fy += lift[j] * (S0s[j] - S3s[j])
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
    HA = np.empty((n, nodes))
    M = np.empty((n, n))
    At = np.ascontiguousarray(A.T)
    zero = np.zeros(n)
    f = np.empty(n)
    for t in range(b):
        residual(d, q[t], qd[t], zero, ang[t], rate[t], acc[t], rot_acc[t], load[t], f)
        c = np.cos(np.dot(A, q[t]) + ang[t])
        s = np.sin(np.dot(A, q[t]) + ang[t])
        mass_matrix(A, At, d.G, d.rot_y, d.rot_J, c, s, H, HA, M)
        solved = np.linalg.solve(M, -f)
        for i in range(n):  # (a loop: a slice assignment links numba's shape error in)
            out[t, i] = solved[i]
    return out


@njit(cache=True, _nrt=False)
def mass_matrix(A, At, G, rot_y, rot_J, c, s, H, HA, M):
    """M[:m, :m] = Aᵀ(G ∘ cos(α_j − α_l))A + Σ J_r a_r a_rᵀ (A (nodes, m), At its transpose,
    contiguous; rot_y's first m columns) from c = cos α, s = sin α of the nodes (a slider's
    line node: times its length ρ, `scaled`); H (nodes, nodes), HA (≥ m, nodes) scratch.
    The inertia forces' coefficients of the accelerations (`inertia_elastic` is affine in
    them). Loops, not BLAS products: at these sizes a call costs more than the arithmetic."""
    nodes, m = A.shape
    for j in range(nodes):
        for l in range(nodes):
            H[j, l] = G[j, l] * (c[j] * c[l] + s[j] * s[l])
    # (H A)ᵀ by rows of H (symmetric), the inner loop along a row
    for i in range(m):
        for j in range(nodes):
            HA[i, j] = 0.0
    for l in range(nodes):
        for i in range(m):
            a = A[l, i]
            if a != 0.0:
                for j in range(nodes):
                    HA[i, j] += a * H[l, j]
    for i in range(m):
        for k in range(i, m):
            acc = 0.0
            for j in range(nodes):
                acc += At[i, j] * HA[k, j]
            for r in range(rot_J.shape[0]):
                acc += rot_J[r] * rot_y[r, i] * rot_y[r, k]
            M[i, k] = acc
            M[k, i] = acc


@njit(inline="always")
def scaled(rho, x, out):
    """out = ρ x elementwise (each node's cos or sin times its length)."""
    for j in range(x.shape[0]):
        out[j] = rho[j] * x[j]
    return out


@njit(inline="always")
def travel_columns(Ay, G, line_node, line_col, c, s, rc, rs, K):
    """A slider's free travel s in the mass matrix K: its line node L carries the point
    acceleration s̈ e(α_L), so with the angle columns' b_j = ρ_j e⊥(α_j) its column holds
    Σ_j Ay_jk G_jL ρ_j e⊥_j·e_L = Σ_j Ay_jk G_jL ρ_j sin(α_L − α_j) and its entry with a
    travel s' on node L' G_LL' cos(α_L − α_L') (the residual's change under a unit s̈;
    rc, rs: ρ cos, ρ sin of the nodes). The angle columns themselves are `mass_matrix`'s with
    ρ cos, ρ sin: b_j·b_l = ρ_j ρ_l cos(α_j − α_l)."""
    nodes, m = Ay.shape[0], line_col.shape[0]
    for a in range(m):
        col = line_col[a]
        if col < 0:
            continue
        L = line_node[a]
        for k in range(Ay.shape[1]):
            acc = 0.0
            for j in range(nodes):
                x = Ay[j, k]
                if x != 0.0:
                    acc += x * G[j, L] * (s[L] * rc[j] - c[L] * rs[j])
            K[k, col] = acc
            K[col, k] = acc
        for b in range(m):
            other = line_col[b]
            if other >= 0:
                L2 = line_node[b]
                K[col, other] = G[L, L2] * (c[L] * c[L2] + s[L] * s[L2])
