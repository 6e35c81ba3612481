"""Compiled (numba) step loop of the Gauss collocation solver — the same algorithm as the numpy
loop in ``gauss.py`` (which the tests compare it with), without Python overhead per step.

Why numba: one step costs a few small matrix–vector products (~10⁴ flops); in numpy each call
costs more in dispatch than in arithmetic, an order of magnitude more per Newton iteration
than the compiled loop (benchmarks/nonlinear_vs_fe.py).
Compiled functions are cached on disk (``cache=True``), so only the first run ever compiles.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ..dynamics._nonlinear_numba import residual as _residual


@njit(cache=True)
def solve_stages(q0, v0, X, h, k, ang, rate, acc, tip_acc, load, A, At, G, tip_A, tip_At, J,
                 D, K, lift, gravity, nodes, coeffs, coeffs2, tol, max_iterations, floor, inverse, have, counts):
    """The stage accelerations X (2, n) of one step of h (s) from q0, v0, solved in place by
    simplified Newton from the guess in X; stage inputs in rows k, k + 1. ``inverse`` (2n, 2n)
    is the iteration matrix for h, rebuilt when ``have[0]`` is 0 or when an iteration
    contracts by less than 10×. ``floor`` (1/s²): the iteration stops when its remaining
    error is within tol of the largest stage acceleration or within floor · max|q|, the
    round-off of the elastic forces (at a static equilibrium under a constant load the
    accelerations vanish and no relative test can be met). counts[0] += matrix rebuilds,
    counts[1] += iterations. Returns whether it converged."""
    n = q0.size
    Q = np.empty((2, n))
    V = np.empty((2, n))
    R = np.empty(2 * n)
    eps = 1e-7
    previous = np.inf
    fresh = False
    q_size = 0.0
    for m in range(n):
        q_size = max(q_size, abs(q0[m]))
    for _ in range(max_iterations):
        counts[1] += 1
        for st in range(2):
            V[st] = v0 + h * (coeffs[st, 0] * X[0] + coeffs[st, 1] * X[1])
            Q[st] = q0 + nodes[st] * h * v0 + h * h * (coeffs2[st, 0] * X[0]
                                                          + coeffs2[st, 1] * X[1])
        if have[0] == 0:
            Jm = np.zeros((2 * n, 2 * n))
            for st in range(2):
                r = k + st
                R0 = _residual(Q[st], V[st], X[st], ang[r], rate[r], acc[r], tip_acc[r],
                               load[r], A, At, G, tip_A, tip_At, J, D, K, lift, gravity)
                for m in range(n):
                    Qp = Q[st].copy()
                    Qp[m] += eps
                    dq = (_residual(Qp, V[st], X[st], ang[r], rate[r], acc[r], tip_acc[r],
                                    load[r], A, At, G, tip_A, tip_At, J, D, K, lift, gravity) - R0) / eps
                    Vp = V[st].copy()
                    Vp[m] += eps
                    dv = (_residual(Q[st], Vp, X[st], ang[r], rate[r], acc[r], tip_acc[r],
                                    load[r], A, At, G, tip_A, tip_At, J, D, K, lift, gravity) - R0) / eps
                    Xp = X[st].copy()
                    Xp[m] += 1.0
                    dx = _residual(Q[st], V[st], Xp, ang[r], rate[r], acc[r], tip_acc[r],
                                   load[r], A, At, G, tip_A, tip_At, J, D, K, lift, gravity) - R0
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
            R[st * n:(st + 1) * n] = _residual(Q[st], V[st], X[st], ang[r], rate[r], acc[r],
                                               tip_acc[r], load[r], A, At, G, tip_A, tip_At,
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
            return True
        if size > 0.1 * previous and not fresh:
            have[0] = 0
        previous = size
        fresh = False
    return False


@njit(cache=True)
def gauss_loop(q, v, X, h, ang, rate, acc, tip_acc, load, A, G, tip_A, J, D, K, lift,
               gravity, nodes, coeffs, coeffs2, weights, weights2, tol, max_iterations, predict_first,
               floor=0.0):
    """Advance q, v (steps+1, n) in place from row 0 by uniform steps h; X (2, n) holds the
    stage accelerations of the step before (extrapolated first if ``predict_first``, else the
    guess itself). Node inputs are per stage: ang, rate, acc (2·steps, nodes), tip_acc
    (2·steps, N), the applied forces load (2·steps, n); ``floor`` as in solve_stages.
    Returns (failed step or −1, matrix rebuilds, Newton iterations)."""
    n = q.shape[1]
    steps = q.shape[0] - 1
    At = np.ascontiguousarray(A.T)
    tip_At = np.ascontiguousarray(tip_A.T)
    inverse = np.zeros((2 * n, 2 * n))
    have = np.zeros(1, np.int64)
    counts = np.zeros(2, np.int64)
    for i in range(steps):
        if i > 0 or predict_first:
            slope = (X[1] - X[0]) / (nodes[1] - nodes[0])
            X[0] += slope
            X[1] += slope
        if not solve_stages(q[i], v[i], X, h, 2 * i, ang, rate, acc, tip_acc, load, A, At, G,
                            tip_A, tip_At, J, D, K, lift, gravity, nodes, coeffs, coeffs2, tol,
                            max_iterations, floor, inverse, have, counts):
            return i, counts[0], counts[1]
        v[i + 1] = v[i] + h * (weights[0] * X[0] + weights[1] * X[1])
        q[i + 1] = q[i] + h * v[i] + h * h * (weights2[0] * X[0] + weights2[1] * X[1])
    return -1, counts[0], counts[1]


@njit(cache=True)
def gauss_doubling(q, v, X, h_prev, H, ang, rate, acc, tip_acc, load, A, G, tip_A, J, D, K,
                   lift, gravity, nodes, coeffs, coeffs2, weights, weights2, tol, max_iterations, floor,
                   group, peak_q, peak_v, rtol, atol, rate_floor, errors, inverse, have,
                   counts):
    """Advance q, v (count+1, n) in place from row 0 by steps H, each checked by step
    doubling: one step H and two steps H/2 from the same state, the two H/2 steps kept
    (``step_doubling`` in gauss_steps.py). Stage inputs: six rows per step (the H step's two
    stages, then the two H/2 steps'). X (2, n): the stage accelerations of the last step,
    of length h_prev (s), on return those of the last accepted step. ``errors`` (count,):
    each step's error as a fraction of its tolerance (doubling_error). ``inverse`` (2, 2n,
    2n) and ``have`` (2,): the iteration matrices for H and H/2, kept across calls while H
    is unchanged. Returns (status, accepted steps): status 0 all accepted, 1 a step's error
    above its tolerance, 2 a step whose Newton iteration did not converge."""
    n = q.shape[1]
    count = q.shape[0] - 1
    At = np.ascontiguousarray(A.T)
    tip_At = np.ascontiguousarray(tip_A.T)
    big = np.empty((2, n))
    fine = np.empty((2, n))
    q_big = np.empty(n)
    v_big = np.empty(n)
    q_mid = np.empty(n)
    v_mid = np.empty(n)
    h = 0.5 * H
    for i in range(count):
        predict(big, X, h_prev, h_prev, H, nodes)
        if not solve_stages(q[i], v[i], big, H, 6 * i, ang, rate, acc, tip_acc, load, A, At,
                            G, tip_A, tip_At, J, D, K, lift, gravity, nodes, coeffs, coeffs2, tol,
                            max_iterations, floor, inverse[0], have[0:1], counts):
            return 2, i
        v_big[:] = v[i] + H * (weights[0] * big[0] + weights[1] * big[1])
        q_big[:] = q[i] + H * v[i] + H * H * (weights2[0] * big[0] + weights2[1] * big[1])
        predict(fine, big, H, 0.0, h, nodes)
        if not solve_stages(q[i], v[i], fine, h, 6 * i + 2, ang, rate, acc, tip_acc, load, A,
                            At, G, tip_A, tip_At, J, D, K, lift, gravity, nodes, coeffs, coeffs2, tol,
                            max_iterations, floor, inverse[1], have[1:2], counts):
            return 2, i
        v_mid[:] = v[i] + h * (weights[0] * fine[0] + weights[1] * fine[1])
        q_mid[:] = q[i] + h * v[i] + h * h * (weights2[0] * fine[0] + weights2[1] * fine[1])
        predict(fine, big, H, h, h, nodes)
        if not solve_stages(q_mid, v_mid, fine, h, 6 * i + 4, ang, rate, acc, tip_acc, load,
                            A, At, G, tip_A, tip_At, J, D, K, lift, gravity, nodes, coeffs, coeffs2, tol,
                            max_iterations, floor, inverse[1], have[1:2], counts):
            return 2, i
        v[i + 1] = v_mid + h * (weights[0] * fine[0] + weights[1] * fine[1])
        q[i + 1] = q_mid + h * v_mid + h * h * (weights2[0] * fine[0] + weights2[1] * fine[1])
        errors[i] = doubling_error(q_big, v_big, q[i + 1], v[i + 1], group, peak_q, peak_v,
                                   rtol, atol, rate_floor)
        if errors[i] > 1.0:
            return 1, i
        X[:, :] = fine
        h_prev = h
    return 0, count


@njit(cache=True)
def doubling_error(q_big, v_big, q_fine, v_fine, group, peak_q, peak_v, rtol, atol,
                   rate_floor):
    """The step-doubling estimate of one step's local error, |fine − big| / 15 (fourth
    order), as a fraction of the tolerance atol + rtol · peak of its group (``group``: the
    component's group, −1 for none; ``peak_q``, ``peak_v``: each group's largest |q|, |q̇|
    so far, updated here with the fine state). The rates' peak is at least ``rate_floor``
    (1/s) times the coordinates' (a run at rest in static equilibrium, whose rates are
    round-off). Shared by both nonlinear step loops."""
    for m in range(q_fine.size):
        g = group[m]
        if g >= 0:
            peak_q[g] = max(peak_q[g], abs(q_fine[m]))
            peak_v[g] = max(peak_v[g], abs(v_fine[m]))
    err = 0.0
    for m in range(q_fine.size):
        g = group[m]
        if g >= 0:
            err = max(err, _ratio(abs(q_fine[m] - q_big[m]), atol + rtol * peak_q[g]),
                      _ratio(abs(v_fine[m] - v_big[m]),
                             atol + rtol * max(peak_v[g], rate_floor * peak_q[g])))
    return err / 15.0


@njit(cache=True)
def _ratio(difference, tolerance):
    """difference / tolerance, 0 where both vanish (a state still at rest)."""
    if difference == 0.0:
        return 0.0
    return difference / tolerance if tolerance > 0.0 else np.inf


@njit(cache=True)
def predict(X, X_prev, h_prev, start, h, nodes):
    """Stage accelerations X (2, n) of a step of h (s) starting ``start`` (s) after the start
    of the step of length h_prev whose stage accelerations were X_prev (2, n): X_prev's
    linear collocation polynomial extrapolated (the predictor of Newton)."""
    for st in range(2):
        s = (start + nodes[st] * h) / h_prev
        w = (s - nodes[0]) / (nodes[1] - nodes[0])
        X[st] = X_prev[0] + w * (X_prev[1] - X_prev[0])
