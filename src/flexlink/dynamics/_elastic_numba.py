"""Compiled twin of dynamics/elastic_joints.py: the rotors' inertia and the spring torques of
elastic joints in the forward kernels (`_forward_numba.residual`, `.applied`, `.rates`).

ForwardData's elastic arrays (dynamics/forward_kernel.py): ``motor_row[k]`` the rigid
coordinate of joint k's motor angle (−1: not elastic), ``motor_kind[k]`` its drive,
``spring_k``, ``spring_c``, ``gear`` and ``rotor_inertia`` per joint. A prescribed motor's
angle, rate and acceleration are joint k's motion columns of the input row."""

from __future__ import annotations

from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation

MOTOR_PRESCRIBED = 0  # equals _forward_numba.PRESCRIBED


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def prescribed_motors(d, u, p, pd, pdd):
    """Writes each prescribed motor's angle, rate and acceleration from the input row u."""
    N = d.motor_row.shape[0]
    for k in range(N):
        m = d.motor_row[k]
        if m >= 0 and d.motor_kind[k] == MOTOR_PRESCRIBED:
            p[m], pd[m], pdd[m] = u[k], u[N + k], u[2 * N + k]


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def spring_torques(d, u, p, pd, Q):
    """Adds τ_s = k (θ_m/N − β) + c (θ̇_m/N − β̇) on each link angle and −τ_s/N on its motor
    angle to Q (a prescribed motor's angle and rate from the input row u)."""
    N = d.motor_row.shape[0]
    nb = d.n_base
    for k in range(N):
        m = d.motor_row[k]
        if m < 0:
            continue
        if d.motor_kind[k] == MOTOR_PRESCRIBED:
            angle, rate = u[k], u[N + k]
        else:
            angle, rate = p[m], pd[m]
        g = d.gear[k]
        tau = d.spring_k[k] * (angle / g - p[nb + k]) + d.spring_c[k] * (rate / g - pd[nb + k])
        Q[nb + k] += tau
        Q[m] -= tau / g


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def rotor_inertia(d, pdd, r, M, want_M):
    """Adds J_m θ̈_m to the residual r on each motor row (and J_m to M's diagonal)."""
    for k in range(d.motor_row.shape[0]):
        m = d.motor_row[k]
        if m >= 0:
            r[m] += d.rotor_inertia[k] * pdd[m]
            if want_M:
                M[m, m] += d.rotor_inertia[k]
