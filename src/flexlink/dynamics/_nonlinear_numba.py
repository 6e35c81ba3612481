"""Compiled (numba) kernels of the nonlinear model: the residual of one state and the
accelerations of a batch of states — the numpy expressions of ``NonlinearSystem`` written as
loops (tiny sizes: BLAS calls and temporary arrays cost more than the arithmetic). The tests
compare both implementations."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation


@njit(cache=True)
def node_forces(A, cols, Q, V, X, ang, rate, acc, G, lift, ax, ay, c, s, S, u):
    """The inertia of the nodes of a link's discretisation, shared by the prescribed-joint and
    the forward nonlinear kernels. Node j turns by α_j = ang_j + Σ_i A[j, i] Q_i (the first
    ``cols`` coordinates; rates and accelerations alike from V, X); into c, s (nodes,) its cos
    and sin, into S (nodes, 4) c α̈, s α̈, c α̇², s α̇², and into u (nodes,) the generalized
    inertia moment of node j on its angle, c_j (G S)_j0 − c_j (G S)_j3 + s_j ((G S)_j1 +
    (G S)_j2), with G the nodes' coupling weights (docs/nonlinear.md), plus
    lift_j e⊥(α_j)·(a_x, a_y): the base point's acceleration minus gravity (a − g, global
    axes) acting on the masses the node carries (lift = Wᵀm). This is where gravity enters
    the nonlinear model (equivalence principle: the field is the base's acceleration −g)."""
    nodes = A.shape[0]
    for j in range(nodes):
        alpha = ang[j]
        alpha_dot = rate[j]
        alpha_ddot = acc[j]
        for i in range(cols):
            a = A[j, i]
            if a != 0.0:
                alpha += a * Q[i]
                alpha_dot += a * V[i]
                alpha_ddot += a * X[i]
        c[j] = np.cos(alpha)
        s[j] = np.sin(alpha)
        v2 = alpha_dot * alpha_dot
        S[j, 0] = c[j] * alpha_ddot
        S[j, 1] = s[j] * alpha_ddot
        S[j, 2] = c[j] * v2
        S[j, 3] = s[j] * v2
    for j in range(nodes):
        g0 = 0.0
        g1 = 0.0
        g2 = 0.0
        g3 = 0.0
        for m in range(nodes):
            w = G[j, m]
            g0 += w * S[m, 0]
            g1 += w * S[m, 1]
            g2 += w * S[m, 2]
            g3 += w * S[m, 3]
        u[j] = c[j] * (g0 - g3) + s[j] * (g1 + g2)
    if ax != 0.0 or ay != 0.0:
        for j in range(nodes):
            u[j] += lift[j] * (c[j] * ay - s[j] * ax)


@njit(cache=True)
def residual(Q, V, X, ang, rate, acc, tip_acc, load, A, At, G, tip_A, tip_At, J, D, K, lift,
             gravity):
    """Generalized inertia + damping + elastic − applied (``load``, n) forces of one state
    (n,) in the uniform field ``gravity`` (2,) — the numpy NonlinearSystem.residual written as
    loops (small sizes: no BLAS call overhead)."""
    nodes, n = A.shape
    c = np.empty(nodes)
    s = np.empty(nodes)
    S = np.empty((nodes, 4))
    u = np.empty(nodes)
    node_forces(A, n, Q, V, X, ang, rate, acc, G, lift, -gravity[0], -gravity[1], c, s, S, u)
    out = np.zeros(n)
    for j in range(nodes):
        for i in range(n):
            out[i] += A[j, i] * u[j]
    for k in range(tip_A.shape[0]):
        if J[k] != 0.0:
            tip = tip_acc[k]
            for i in range(n):
                tip += tip_A[k, i] * X[i]
            for i in range(n):
                out[i] += tip_A[k, i] * J[k] * tip
    for i in range(n):
        out[i] -= load[i]
        for m in range(n):
            out[i] += D[i, m] * V[m] + K[i, m] * Q[m]
    return out


@njit(cache=True)
def accelerations(q, qd, ang, rate, acc, tip_acc, load, A, G, tip_A, J, D, K, lift, gravity):
    """q̈ (b, n) of M q̈ = f for b states; M = Aᵀ(G ∘ cos(α_j − α_l))A + Σ J_t a_t a_tᵀ."""
    b, n = q.shape
    nodes = A.shape[0]
    out = np.empty((b, n))
    H = np.empty((nodes, nodes))
    HA = np.empty((nodes, n))
    At = np.ascontiguousarray(A.T)
    tip_At = np.ascontiguousarray(tip_A.T)
    zero = np.zeros(n)
    for t in range(b):
        f = -residual(q[t], qd[t], zero, ang[t], rate[t], acc[t], tip_acc[t], load[t], A, At, G,
                      tip_A, tip_At, J, D, K, lift, gravity)
        c = np.cos(np.dot(A, q[t]) + ang[t])
        s = np.sin(np.dot(A, q[t]) + ang[t])
        for j in range(nodes):
            for m in range(nodes):
                H[j, m] = G[j, m] * (c[j] * c[m] + s[j] * s[m])
        HA[:, :] = np.dot(H, A)
        M = np.dot(At, HA)
        for k in range(tip_A.shape[0]):
            for i in range(n):
                for m in range(n):
                    M[i, m] += J[k] * tip_A[k, i] * tip_A[k, m]
        out[t] = np.linalg.solve(M, f)
    return out
