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
from ._forward_numba import applied as _applied
from ._nonlinear_numba import inertia_elastic


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


# A state of a run iterates with an earlier state's mass matrix (`accelerations`) while
# each iteration divides the correction by at least MASS_CONTRACTION, at most MASS_REUSE
# times, before it builds its own: along a run's step ends the correction falls by ~1e-3 an
# iteration from the last state's ÿ, one residual each, against n_y + 1 for a mass matrix
MASS_REUSE = 6
MASS_CONTRACTION = 0.02
# Each iteration's correction s and the change of the residual it caused, M s (exact: the
# residual is affine in ÿ), update M₀⁻¹ (Broyden) so that it maps M s to s: the mass matrix
# moves little from one step end to the next, and the update carries its move over. Only
# corrections above BROYDEN_STEP of ÿ update it: a smaller one's M s is mostly the
# residual's round-off.
BROYDEN_STEP = 1e-6
# … until the remaining error is within MASS_TOL of the largest |ÿ|. With the updates the
# contraction varies from one iteration to the next and the remaining error its rate gives
# is rougher: at 1e-11 the accelerations of a free base's run on uniform steps were 2–3×
# further from converged ones than without updates (their differences in the base's mass
# over 1e-4 of it, tests/unit/test_nonlinear_free_base_torque.py, then missed its
# sensitivity); at 1e-12 they are closer than without updates at 1e-11 on every coordinate,
# and on the slider cases of benchmarks/slider_vs_fe.py every step end within 1e-11 of the
# largest |ÿ|, for fewer residuals per state: 5.1 → 4.5 (Case 23, 6 modes), 8.5 → 8.3
# (large, 6 modes). (The step loop's Newton stops at 1e-7 of the stage accelerations there.)
MASS_TOL = 1e-12


@njit(cache=True)
def accelerations(d, Y, V, ang, rate, acc, rot_acc, u):
    """ÿ (b, n_y) of b states. The residual is affine in ÿ: M's columns from its change
    under unit accelerations, then M ÿ = −r(ÿ = 0). The step ends of a run have nearly the
    same M from one to the next: each state first iterates ÿ ← ÿ − M₀⁻¹ r(ÿ) from the last
    state's ÿ with M₀ the last mass matrix built, until the remaining error (the correction
    times θ/(1 − θ), θ its contraction) is below MASS_TOL of ÿ, and builds its own M when
    θ exceeds MASS_CONTRACTION or the corrections, shrinking by θ, would not reach that
    within MASS_REUSE iterations. Between iterations M₀⁻¹ takes Broyden's update with
    the pair (correction, change of the residual) (BROYDEN_STEP)."""
    b, ny = Y.shape
    out = np.empty((b, ny))
    # the residual's arguments uncounted (`borrowed`, on the stack): each count is atomic
    Y, V, ang, rate, acc = borrowed(Y), borrowed(V), borrowed(ang), borrowed(rate), borrowed(acc)
    rot_acc, u, outb = borrowed(rot_acc), borrowed(u), borrowed(out)
    X = stack_array(ny)
    X[:] = 0.0
    r0 = stack_array(ny)
    r1 = stack_array(ny)
    M = np.empty((ny, ny))
    M0 = stack_array((ny, ny))  # M₀⁻¹
    step = stack_array(ny)  # the last correction of ÿ
    r_prev = stack_array(ny)  # the residual it corrected
    reuse = False
    for t in range(b):
        done = False
        if reuse:
            for i in range(ny):
                X[i] = outb[t - 1, i]
            previous = np.inf
            for j in range(MASS_REUSE):
                residual(d, Y[t], V[t], X, ang[t], rate[t], acc[t], rot_acc[t], u[t], r1)
                if j > 0:
                    _broyden(M0, step, r1, r_prev, X, r0)
                size = 0.0
                largest = 0.0
                for i in range(ny):
                    c = 0.0
                    for k in range(ny):
                        c += M0[i, k] * r1[k]
                    X[i] -= c
                    step[i] = -c
                    r_prev[i] = r1[i]
                    size = max(size, abs(c))
                    largest = max(largest, abs(X[i]))
                theta = size / previous
                # (first iteration: no θ yet, the correction itself must be small)
                remaining = size * theta / (1.0 - theta) if 0.0 < theta < 1.0 else size
                if remaining <= MASS_TOL * largest:
                    done = True
                    break
                if theta > MASS_CONTRACTION:
                    break
                # iterations still needed at this rate: more than are left, build now
                if 0.0 < theta < 1.0 and remaining * theta ** (MASS_REUSE - 1 - j) > (
                        MASS_TOL * largest):
                    break
                previous = size
        if not done:
            X[:] = 0.0
            residual(d, Y[t], V[t], X, ang[t], rate[t], acc[t], rot_acc[t], u[t], r0)
            for k in range(ny):
                X[k] = 1.0
                residual(d, Y[t], V[t], X, ang[t], rate[t], acc[t], rot_acc[t], u[t], r1)
                X[k] = 0.0
                for i in range(ny):
                    M[i, k] = r1[i] - r0[i]
            inverse = np.linalg.inv(M)
            for i in range(ny):
                c = 0.0
                for k in range(ny):
                    M0[i, k] = inverse[i, k]
                    c -= inverse[i, k] * r0[k]
                X[i] = c
            reuse = True
        for i in range(ny):  # (a loop: a slice assignment links numba's shape error in)
            outb[t, i] = X[i]
    return out


@njit(cache=True, _nrt=False)
def _broyden(H, s, r, r_prev, X, scratch):
    """Broyden's update of H ≈ M⁻¹ (n, n) in place from the correction s of ÿ (X after it)
    and the residuals r_prev before and r after it (r − r_prev = M s): H ← H + (s − H Δr)
    sᵀH / (sᵀH Δr), after which H Δr = s; skipped when s is within BROYDEN_STEP of max|ÿ|
    or the update would be near-singular. ``scratch`` (n,): sᵀH."""
    n = s.size
    s_size = 0.0
    x_size = 0.0
    s_norm2 = 0.0
    for i in range(n):
        s_size = max(s_size, abs(s[i]))
        x_size = max(x_size, abs(X[i]))
        s_norm2 += s[i] * s[i]
    if s_size <= BROYDEN_STEP * x_size:
        return
    den = 0.0
    for k in range(n):
        c = 0.0
        for i in range(n):
            c += s[i] * H[i, k]
        scratch[k] = c
        den += c * (r[k] - r_prev[k])
    # sᵀH Δr ≈ sᵀs while H is near M⁻¹ (the iteration contracts): else keep H
    if not den > 0.5 * s_norm2:
        return
    for i in range(n):
        w = s[i]
        for k in range(n):
            w -= H[i, k] * (r[k] - r_prev[k])
        w /= den
        for k in range(n):
            H[i, k] += w * scratch[k]


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
