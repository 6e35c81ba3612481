"""Compiled pieces of the Gauss collocation's sensitivities (`gauss_sensitivity.py`): the
stage residuals of a batch of states, and the replay of a run's accepted steps that
recovers each Gauss step's converged stage accelerations (the run keeps its step ends
only). Both reach the model through `_gauss_numba.model_residual` (either nonlinear
model, by the ``model`` `_gauss_numba.residual_model` makes of its kernel-data record)."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._gauss_numba import MATRIX_0, _advance, model_residual, solve_stages


@njit(cache=True)
def residuals(model, rows, index, Q, V, X, out):
    """The residuals out (b, n) of b stage states Q, V, X (b, n) with stage inputs in rows
    ``index`` (b,) of ``rows`` (a StageInputs)."""
    angle, rate, acc, rot, u = rows
    for b in range(Q.shape[0]):
        r = index[b]
        model_residual(model, Q[b], V[b], X[b], angle[r], rate[r], acc[r], rot[r], u[r], out[b])


@njit(cache=True)
def replay(model, rows, y0, v0, H, parts, tab, newton, starts_y, starts_v, stages, ends_y, ends_v):
    """Each accepted step i from y0[i], v0[i] (S, n) of length H[i] (s) taken again as
    ``parts`` Gauss steps of H/parts (stage rows 2g, 2g + 1 for Gauss step g): their start
    states starts_y, starts_v (S·parts, n), converged stage accelerations stages
    (S·parts, 2, n) and each accepted step's end ends_y, ends_v (S, n), in place. Returns
    the Gauss step whose Newton iteration failed, or −1."""
    n = y0.shape[1]
    inverse = np.zeros((2 * n, 2 * n))
    have = np.zeros(2, np.int64)
    partials = np.empty((2, n, 3 * n))
    counts = np.zeros(2, np.int64)
    peak = np.zeros(1)
    X = np.zeros((2, n))
    y = np.empty(n)
    v = np.empty(n)
    y1 = np.empty(n)
    v1 = np.empty(n)
    h_last = -1.0
    g = 0
    for i in range(y0.shape[0]):
        h = H[i] / parts
        for m in range(n):  # (loops, not slice copies: `_gauss_numba.solve_stages`)
            y[m] = y0[i, m]
            v[m] = v0[i, m]
        for _ in range(parts):
            if h != h_last:
                have[0] = 0
                h_last = h
            if not solve_stages(model, rows, 2 * g, y, v, X, h, tab, newton, inverse, have,
                                MATRIX_0, partials, counts, peak):
                return g
            for m in range(n):
                starts_y[g, m] = y[m]
                starts_v[g, m] = v[m]
                stages[g, 0, m] = X[0, m]
                stages[g, 1, m] = X[1, m]
            _advance(y, v, X, h, tab, y1, v1)
            for m in range(n):
                y[m] = y1[m]
                v[m] = v1[m]
            g += 1
        for m in range(n):
            ends_y[i, m] = y[m]
            ends_v[i, m] = v[m]
    return -1


@njit(cache=True)
def prescribed_jacobians(d, rows, index, Q, V, X, RQ, RV, RX):
    """∂R/∂q, ∂R/∂q̇, ∂R/∂q̈ (b, n, n) of the residual of the model with every joint
    prescribed (d: NonlinearData without sliders) at b stage states, in place. With
    α = ang + Ay q (rates and accelerations alike) the nodes' inertia moments are
    u_j = Σ_k G_jk [cos(α_j − α_k) α̈_k + sin(α_j − α_k) α̇_k²] + lift_j (c_j r_y − s_j r_x)
    (r = −g): ∂u_j/∂α̈_k = G_jk cos(α_j − α_k), ∂u_j/∂α̇_k = 2 G_jk sin(α_j − α_k) α̇_k,
    ∂u_j/∂α_k = G_jk [sin(α_j − α_k) α̈_k − cos(α_j − α_k) α̇_k²] (k ≠ j) and the diagonal
    minus their sum plus the gravity term; R = Ayᵀu + (tips' rotary inertia) + D q̇ + K q
    − load, so each Jacobian is Ayᵀ (∂u/∂·) Ay plus D, K or the tips' Jᵣ aᵣ aᵣᵀ."""
    Ay, G, lift = d.Ay, d.G, d.s
    nodes, n = Ay.shape[0], d.n
    angle, rate, acc = rows[0], rows[1], rows[2]
    rx, ry = -d.gravity[0], -d.gravity[1]
    al = np.empty(nodes)
    ad = np.empty(nodes)
    aa = np.empty(nodes)
    UA = np.empty((nodes, nodes))
    UD = np.empty((nodes, nodes))
    UX = np.empty((nodes, nodes))
    rot = np.zeros((n, n))
    for r in range(d.rot_J.shape[0]):
        for i in range(n):
            for m in range(n):
                rot[i, m] += d.rot_J[r] * d.rot_y[r, i] * d.rot_y[r, m]
    for b in range(Q.shape[0]):
        w = index[b]
        for j in range(nodes):
            al[j] = angle[w, j]
            ad[j] = rate[w, j]
            aa[j] = acc[w, j]
            for i in range(n):
                a = Ay[j, i]
                if a != 0.0:
                    al[j] += a * Q[b, i]
                    ad[j] += a * V[b, i]
                    aa[j] += a * X[b, i]
        c = np.cos(al)
        s = np.sin(al)
        for j in range(nodes):
            diagonal = 0.0
            for k in range(nodes):
                g = G[j, k]
                cjk = c[j] * c[k] + s[j] * s[k]  # cos(α_j − α_k)
                sjk = s[j] * c[k] - c[j] * s[k]  # sin(α_j − α_k)
                UX[j, k] = g * cjk
                UD[j, k] = 2.0 * g * sjk * ad[k]
                if k != j:
                    t = g * (sjk * aa[k] - cjk * ad[k] * ad[k])
                    UA[j, k] = t
                    diagonal -= t
            UA[j, j] = diagonal + lift[j] * (-s[j] * ry - c[j] * rx)
        JQ = Ay.T @ (UA @ Ay)
        JV = Ay.T @ (UD @ Ay)
        JX = Ay.T @ (UX @ Ay)
        for i in range(n):  # (loops, not slice assignments: `_gauss_numba.solve_stages`)
            for m in range(n):
                RQ[b, i, m] = JQ[i, m] + d.Kq[i, m]
                RV[b, i, m] = JV[i, m] + d.Dq[i, m]
                RX[b, i, m] = JX[i, m] + rot[i, m]
