"""Compiled (numba) step loop of the Gauss collocation for the nonlinear model with rigid
coordinates: `_gauss_numba.gauss_loop`'s algorithm (simplified Newton on the stage
accelerations, finite-difference iteration matrix kept while it contracts) on the residual of
`dynamics/_nonlinear_forward_numba.py`, whose inputs include the load rows and whose state
includes the free rigid coordinates and the servo integrals. The numpy loop of
`gauss_forward.py` is the reference it is tested against."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ..dynamics._nonlinear_forward_numba import residual as _residual


@njit(cache=True)
def gauss_forward_loop(y, v, X, h, ang, rate, acc, rot_acc, u, nd, d,
                       nodes, coeffs, coeffs2, weights, weights2, tol, max_iterations,
                       predict_first, floor=0.0):
    """Advance y, v (steps+1, n_y) in place from row 0; X (2, n_y) holds the stage
    accelerations of the step before (extrapolated first if ``predict_first``). Stage inputs
    are per stage row (2·steps, ·). ``floor`` (1/s²): the iteration also stops when its
    remaining error is within floor · max|q| (the elastic coordinates' share of y), the
    round-off of the elastic forces — at a static equilibrium the accelerations vanish and
    no relative test can be met (as `_gauss_numba.gauss_loop`).
    Returns (failed step or −1, rebuilds, iterations)."""
    n = y.shape[1]
    steps = y.shape[0] - 1
    inverse = np.zeros((2 * n, 2 * n))
    have_inverse = False
    rebuilds = 0
    iterations = 0
    Q = np.empty((2, n))
    V = np.empty((2, n))
    R = np.empty(2 * n)
    r0 = np.empty(n)
    r1 = np.empty(n)
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
        for m in range(nd.n):
            q_size = max(q_size, abs(y[i, m]))
        for _ in range(max_iterations):
            iterations += 1
            for st in range(2):
                V[st] = v[i] + h * (coeffs[st, 0] * X[0] + coeffs[st, 1] * X[1])
                Q[st] = (y[i] + nodes[st] * h * v[i]
                         + h * h * (coeffs2[st, 0] * X[0] + coeffs2[st, 1] * X[1]))
            if not have_inverse:
                Jm = np.zeros((2 * n, 2 * n))
                for st in range(2):
                    k = 2 * i + st
                    _residual(Q[st], V[st], X[st], ang[k], rate[k], acc[k], rot_acc[k], u[k],
                              nd, d, r0)
                    for m in range(n):
                        Qp = Q[st].copy()
                        Qp[m] += eps
                        _residual(Qp, V[st], X[st], ang[k], rate[k], acc[k], rot_acc[k], u[k],
                                  nd, d, r1)
                        dq = (r1 - r0) / eps
                        Vp = V[st].copy()
                        Vp[m] += eps
                        _residual(Q[st], Vp, X[st], ang[k], rate[k], acc[k], rot_acc[k], u[k],
                                  nd, d, r1)
                        dv = (r1 - r0) / eps
                        Xp = X[st].copy()
                        Xp[m] += 1.0
                        _residual(Q[st], V[st], Xp, ang[k], rate[k], acc[k], rot_acc[k], u[k],
                                  nd, d, r1)
                        dx = r1 - r0
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
                _residual(Q[st], V[st], X[st], ang[k], rate[k], acc[k], rot_acc[k], u[k],
                          nd, d, r0)
                R[st * n:(st + 1) * n] = r0
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
        y[i + 1] = y[i] + h * v[i] + h * h * (weights2[0] * X[0] + weights2[1] * X[1])
    return -1, rebuilds, iterations
