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
from ._gauss_numba import doubling_error, predict


@njit(cache=True)
def solve_stages(y0, v0, X, h, k, ang, rate, acc, rot_acc, u, nd, d, nodes, coeffs, coeffs2,
                 tol, max_iterations, floor, inverse, have, counts, peak):
    """_gauss_numba.solve_stages on this model's residual: the stage accelerations X (2, n_y)
    of one step of h (s) from y0, v0, in place; stage inputs in rows k, k + 1; ``inverse``
    the iteration matrix for h (rebuilt when ``have[0]`` is 0 or convergence slows).
    ``peak`` (1,): the largest stage acceleration of the run so far, updated in place; Newton
    stops within tol of it, so that accelerations that vanish (a rigid arm coasting: no
    elastic term keeps them finite) meet the test, or within ``floor`` (1/s²) · max|q| (the
    elastic coordinates' share of y): the round-off of the elastic forces, at a static
    equilibrium (as `_gauss_numba.solve_stages`). Returns whether Newton converged."""
    n = y0.size
    q_size = 0.0
    for m in range(nd.n):
        q_size = max(q_size, abs(y0[m]))
    Q = np.empty((2, n))
    V = np.empty((2, n))
    R = np.empty(2 * n)
    r0 = np.empty(n)
    r1 = np.empty(n)
    eps = 1e-7
    previous = np.inf
    fresh = False
    for _ in range(max_iterations):
        counts[1] += 1
        for st in range(2):
            V[st] = v0 + h * (coeffs[st, 0] * X[0] + coeffs[st, 1] * X[1])
            Q[st] = y0 + nodes[st] * h * v0 + h * h * (coeffs2[st, 0] * X[0]
                                                          + coeffs2[st, 1] * X[1])
        if have[0] == 0:
            Jm = np.zeros((2 * n, 2 * n))
            for st in range(2):
                r = k + st
                _residual(Q[st], V[st], X[st], ang[r], rate[r], acc[r], rot_acc[r], u[r],
                          nd, d, r0)
                for m in range(n):
                    Qp = Q[st].copy()
                    Qp[m] += eps
                    _residual(Qp, V[st], X[st], ang[r], rate[r], acc[r], rot_acc[r], u[r],
                              nd, d, r1)
                    dq = (r1 - r0) / eps
                    Vp = V[st].copy()
                    Vp[m] += eps
                    _residual(Q[st], Vp, X[st], ang[r], rate[r], acc[r], rot_acc[r], u[r],
                              nd, d, r1)
                    dv = (r1 - r0) / eps
                    Xp = X[st].copy()
                    Xp[m] += 1.0
                    _residual(Q[st], V[st], Xp, ang[r], rate[r], acc[r], rot_acc[r], u[r],
                              nd, d, r1)
                    dx = r1 - r0
                    for j in range(2):
                        Jm[st * n:(st + 1) * n, j * n + m] = (
                            h * h * coeffs2[st, j] * dq + h * coeffs[st, j] * dv)
                    Jm[st * n:(st + 1) * n, st * n + m] += dx
            inverse[:, :] = np.linalg.inv(Jm)
            have[0] = 1
            fresh = True
            counts[0] += 1
        for st in range(2):
            r = k + st
            _residual(Q[st], V[st], X[st], ang[r], rate[r], acc[r], rot_acc[r], u[r], nd, d,
                      r0)
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
        if remaining <= tol * max(largest, peak[0], 1e-300) + floor * q_size:
            peak[0] = max(peak[0], largest)
            return True
        if size > 0.1 * previous and not fresh:
            have[0] = 0
        previous = size
        fresh = False
    return False


@njit(cache=True)
def gauss_forward_loop(y, v, X, h, ang, rate, acc, rot_acc, u, nd, d,
                       nodes, coeffs, coeffs2, weights, weights2, tol, max_iterations,
                       predict_first, peak, floor=0.0):
    """Advance y, v (steps+1, n_y) in place from row 0 by uniform steps h; X (2, n_y) holds
    the stage accelerations of the step before (extrapolated first if ``predict_first``).
    Stage inputs are per stage row (2·steps, ·); ``peak``, ``floor`` as in `solve_stages`. Returns
    (failed step or −1, rebuilds, iterations)."""
    n = y.shape[1]
    steps = y.shape[0] - 1
    inverse = np.zeros((2 * n, 2 * n))
    have = np.zeros(1, np.int64)
    counts = np.zeros(2, np.int64)
    for i in range(steps):
        if i > 0 or predict_first:
            slope = (X[1] - X[0]) / (nodes[1] - nodes[0])
            X[0] += slope
            X[1] += slope
        if not solve_stages(y[i], v[i], X, h, 2 * i, ang, rate, acc, rot_acc, u, nd, d, nodes,
                            coeffs, coeffs2, tol, max_iterations, floor, inverse, have, counts,
                            peak):
            return i, counts[0], counts[1]
        v[i + 1] = v[i] + h * (weights[0] * X[0] + weights[1] * X[1])
        y[i + 1] = y[i] + h * v[i] + h * h * (weights2[0] * X[0] + weights2[1] * X[1])
    return -1, counts[0], counts[1]


@njit(cache=True)
def gauss_forward_doubling(y, v, X, h_prev, H, ang, rate, acc, rot_acc, u, nd, d, nodes,
                           coeffs, coeffs2, weights, weights2, tol, max_iterations, floor, group,
                           peak_q, peak_v, rtol, atol, rate_floor, errors, inverse, have, counts,
                           peak_a):
    """_gauss_numba.gauss_doubling on this model's residual (the same arguments, with the
    forward model's stage inputs and packed data nd, d; ``peak_a`` as `solve_stages`'s
    ``peak``)."""
    n = y.shape[1]
    count = y.shape[0] - 1
    big = np.empty((2, n))
    fine = np.empty((2, n))
    y_big = np.empty(n)
    v_big = np.empty(n)
    y_mid = np.empty(n)
    v_mid = np.empty(n)
    h = 0.5 * H
    for i in range(count):
        predict(big, X, h_prev, h_prev, H, nodes)
        if not solve_stages(y[i], v[i], big, H, 6 * i, ang, rate, acc, rot_acc, u, nd, d,
                            nodes, coeffs, coeffs2, tol, max_iterations, floor, inverse[0],
                            have[0:1], counts, peak_a):
            return 2, i
        v_big[:] = v[i] + H * (weights[0] * big[0] + weights[1] * big[1])
        y_big[:] = y[i] + H * v[i] + H * H * (weights2[0] * big[0] + weights2[1] * big[1])
        predict(fine, big, H, 0.0, h, nodes)
        if not solve_stages(y[i], v[i], fine, h, 6 * i + 2, ang, rate, acc, rot_acc, u, nd, d,
                            nodes, coeffs, coeffs2, tol, max_iterations, floor, inverse[1],
                            have[1:2], counts, peak_a):
            return 2, i
        v_mid[:] = v[i] + h * (weights[0] * fine[0] + weights[1] * fine[1])
        y_mid[:] = y[i] + h * v[i] + h * h * (weights2[0] * fine[0] + weights2[1] * fine[1])
        predict(fine, big, H, h, h, nodes)
        if not solve_stages(y_mid, v_mid, fine, h, 6 * i + 4, ang, rate, acc, rot_acc, u, nd,
                            d, nodes, coeffs, coeffs2, tol, max_iterations, floor, inverse[1],
                            have[1:2], counts, peak_a):
            return 2, i
        v[i + 1] = v_mid + h * (weights[0] * fine[0] + weights[1] * fine[1])
        y[i + 1] = y_mid + h * v_mid + h * h * (weights2[0] * fine[0] + weights2[1] * fine[1])
        errors[i] = doubling_error(y_big, v_big, y[i + 1], v[i + 1], group, peak_q, peak_v,
                                   rtol, atol, rate_floor)
        if errors[i] > 1.0:
            return 1, i
        X[:, :] = fine
        h_prev = h
    return 0, count
