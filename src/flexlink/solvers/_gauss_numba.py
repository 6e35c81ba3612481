"""Compiled (numba) step loop of the Gauss collocation solver — the same algorithm as the numpy
loop in ``gauss.py`` (which the tests compare it with), without Python overhead per step.

Why numba: one step costs a few small matrix–vector products (~10⁴ flops); in numpy each call
costs more in dispatch than in arithmetic (~100 µs per Newton iteration against ~10 µs
compiled), which made the nonlinear model only ~5× faster than the finite-element reference.
Compiled functions are cached on disk (``cache=True``), so only the first run ever compiles.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ..dynamics._nonlinear_numba import residual as _residual


@njit(cache=True)
def gauss_loop(q, v, X, h, ang, rate, acc, tip_acc, load, A, G, tip_A, J, D, K, lift,
               gravity,
               nodes, coeffs, coeffs2, weights, weights2, tol, max_iterations, predict_first,
               floor=0.0):
    """Advance q, v (steps+1, n) in place from row 0; X (2, n) holds the stage accelerations
    of the step before (extrapolated first if ``predict_first``, else the guess itself).
    Node inputs are per stage: ang, rate, acc (2·steps, nodes), tip_acc (2·steps, N), the
    applied forces load (2·steps, n).
    ``floor`` (1/s²): the iteration stops when its remaining error is within tol of the
    largest stage acceleration or within floor · max|q|, the round-off of the elastic forces (at a static equilibrium under a constant load the accelerations vanish
    and no relative test can be met).
    Returns (failed step or −1, matrix rebuilds, Newton iterations)."""
    n = q.shape[1]
    steps = q.shape[0] - 1
    At = np.ascontiguousarray(A.T)
    tip_At = np.ascontiguousarray(tip_A.T)
    inverse = np.zeros((2 * n, 2 * n))
    have_inverse = False
    rebuilds = 0
    iterations = 0
    Q = np.empty((2, n))
    V = np.empty((2, n))
    R = np.empty(2 * n)
    eps = 1e-7
    for i in range(steps):
        if i > 0 or predict_first:
            slope = (X[1] - X[0]) / (nodes[1] - nodes[0])
            X[0] += slope
            X[1] += slope
        previous = np.inf
        fresh = False
        converged = False
        q_size = 0.0
        for m in range(n):
            q_size = max(q_size, abs(q[i, m]))
        for _ in range(max_iterations):
            iterations += 1
            for st in range(2):
                V[st] = v[i] + h * (coeffs[st, 0] * X[0] + coeffs[st, 1] * X[1])
                Q[st] = (q[i] + nodes[st] * h * v[i]
                         + h * h * (coeffs2[st, 0] * X[0] + coeffs2[st, 1] * X[1]))
            if not have_inverse:
                Jm = np.zeros((2 * n, 2 * n))
                for st in range(2):
                    k = 2 * i + st
                    R0 = _residual(Q[st], V[st], X[st], ang[k], rate[k], acc[k], tip_acc[k],
                                   load[k], A, At, G, tip_A, tip_At, J, D, K, lift, gravity)
                    for m in range(n):
                        Qp = Q[st].copy()
                        Qp[m] += eps
                        dq = (_residual(Qp, V[st], X[st], ang[k], rate[k], acc[k], tip_acc[k],
                                   load[k], A, At, G, tip_A, tip_At, J, D, K, lift, gravity) - R0) / eps
                        Vp = V[st].copy()
                        Vp[m] += eps
                        dv = (_residual(Q[st], Vp, X[st], ang[k], rate[k], acc[k], tip_acc[k],
                                   load[k], A, At, G, tip_A, tip_At, J, D, K, lift, gravity) - R0) / eps
                        Xp = X[st].copy()
                        Xp[m] += 1.0
                        dx = _residual(Q[st], V[st], Xp, ang[k], rate[k], acc[k], tip_acc[k],
                                   load[k], A, At, G, tip_A, tip_At, J, D, K, lift, gravity) - R0
                        for j in range(2):
                            Jm[st * n:(st + 1) * n, j * n + m] = (
                                h * h * coeffs2[st, j] * dq + h * coeffs[st, j] * dv)
                        Jm[st * n:(st + 1) * n, st * n + m] += dx
                inverse[:, :] = np.linalg.inv(Jm)
                have_inverse = True
                fresh = True
                rebuilds += 1
            for st in range(2):
                k = 2 * i + st
                R[st * n:(st + 1) * n] = _residual(Q[st], V[st], X[st], ang[k], rate[k], acc[k],
                                                   tip_acc[k], load[k], A, At, G, tip_A, tip_At,
                                                   J, D, K, lift, gravity)
            dX = np.dot(inverse, R)
            size = 0.0
            largest = 0.0
            for st in range(2):
                for m in range(n):
                    X[st, m] -= dX[st * n + m]
                    size = max(size, abs(dX[st * n + m]))
                    largest = max(largest, abs(X[st, m]))
            theta = size / previous
            # (first iteration: no rate yet, the increment itself must be small)
            remaining = size * theta / (1.0 - theta) if 0.0 < theta < 1.0 else size
            if remaining <= tol * max(largest, 1e-300) + floor * q_size:
                converged = True
                break
            if size > 0.1 * previous and not fresh:
                have_inverse = False
            previous = size
            fresh = False
        if not converged:
            return i, rebuilds, iterations
        v[i + 1] = v[i] + h * (weights[0] * X[0] + weights[1] * X[1])
        q[i + 1] = q[i] + h * v[i] + h * h * (weights2[0] * X[0] + weights2[1] * X[1])
    return -1, rebuilds, iterations
