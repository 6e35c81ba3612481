"""Compiled (numba) pass over a forward run's output states (`forward_outputs.py`): per
state one evaluation of the rates, the frames at the solved accelerations (with a
prescribed joint: the joint rows there, `_forward_numba.joint_torques`), and the
momentum."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._forward_numba import (
    CART,
    FIXED,
    FREE,
    PRESCRIBED,
    applied,
    frames,
    joint_torques,
    load_state,
    rates,
    state_rates,
)
from ._momentum_numba import momentum


@njit(cache=True, _nrt=False)
def outputs(d, w_, u, states, dy, theta, omega, alpha, origin, oacc, T, Td, Tdd, torques,
            momenta, pj, given, rows):
    """Fill, per output i: dy[i] = the rates at states[i] (input row u[i]; with rows in
    ``given``, their accelerations (p̈_free, z̈) are given[i], not solved for); the frames at
    the solved rigid state (angles, rates, accelerations (nt, N), origins (global) and their
    accelerations (frame axes) (nt, N, 2), maps (nt, N, 3, n_x)); torques[i, k] = joint k's
    row of M ẍ + C ẋ + K x − f with x = [0; z] (ForwardSystem.joint_torques: for a driven
    joint, the applied torque its row was solved for); momenta[i] =
    L_x, L_y, H about the origin (when momenta has rows). pj: a momentum-projection record
    (its scratch arrays); rows: six scratch arrays, three (1, n_rigid) and three (1, n) (the
    kernel allocates nothing)."""
    N = d.length.shape[0]
    nb, nr, nx = d.n_base, d.n_rigid, d.n_x
    free = d.free
    nu = free.shape[0]
    n = nx - nr
    out = pj.c0
    prescribed = False
    p1, pd1, pdd1, z1, zd1, zdd1 = rows
    for k in range(N):
        if d.joint_kind[k] == PRESCRIBED:
            prescribed = True
    for i in range(states.shape[0]):
        y = states[i]
        if given.shape[0] > 0:
            load_state(d, w_, u[i], y)
            w_.srates[:] = 0.0
            applied(d, u[i], w_.p, w_.pd, y[2 * nu + 2 * n:], w_.Q, w_.srates)
            state_rates(d, w_, y, given[i], dy[i])
        else:
            rates(d, w_, u[i], y, dy[i])
        # rates left p, ṗ, x, ẋ and M at this state in the workspace, p̈_free = 0
        for j in range(nu):
            w_.pdd[free[j]] = dy[i, nu + j]
        if prescribed:  # their rows are not solved for: the joint rows at the solved p̈
            for c in range(nr):
                p1[0, c], pd1[0, c], pdd1[0, c] = w_.p[c], w_.pd[c], w_.pdd[c]
            for c in range(n):
                z1[0, c] = y[2 * nu + c]
                zd1[0, c] = y[2 * nu + n + c]
                zdd1[0, c] = dy[i, 2 * nu + n + c]
            joint_torques(d, w_, p1, pd1, pdd1, z1, zd1, zdd1, torques[i:i + 1])
        else:  # every joint row is an equation solved for: it equals the applied torque Q
            frames(d, w_.p, w_.pd, w_.pdd, w_.theta, w_.omega, w_.alpha, w_.oacc, w_.T, w_.Td,
                   w_.Tdd)
            for k in range(N):
                torques[i, k] = w_.Q[nb + k]
        th_b = 0.0
        bx = by = 0.0
        if d.base_kind == CART:  # R_b = R_0 + s e, its attitude constant
            th_b = d.attitude
            bx = d.rail_origin[0] + w_.p[0] * d.rail[0]
            by = d.rail_origin[1] + w_.p[0] * d.rail[1]
        elif d.base_kind != FIXED:
            th_b = w_.p[nb - 1]
        if d.base_kind == FREE:
            bx, by = w_.p[0], w_.p[1]
        for k in range(N):
            theta[i, k] = w_.theta[k]
            omega[i, k] = w_.omega[k]
            alpha[i, k] = w_.alpha[k]
            oacc[i, k, 0] = w_.oacc[k, 0]
            oacc[i, k, 1] = w_.oacc[k, 1]
            if d.attached[k]:
                ct, st = np.cos(th_b), np.sin(th_b)
                px, py = d.point[k, 0], d.point[k, 1]
                origin[i, k, 0] = bx + ct * px - st * py
                origin[i, k, 1] = by + st * px + ct * py
            else:
                L = d.length[k - 1]
                origin[i, k, 0] = origin[i, k - 1, 0] + L * np.cos(w_.theta[k - 1])
                origin[i, k, 1] = origin[i, k - 1, 1] + L * np.sin(w_.theta[k - 1])
                if d.slide[k]:  # the block on its line: s A(θ_{k−1}) u
                    c, sn = np.cos(w_.theta[k - 1]), np.sin(w_.theta[k - 1])
                    ux, uy = d.slide_axis[k, 0], d.slide_axis[k, 1]
                    origin[i, k, 0] += w_.p[nb + k] * (c * ux - sn * uy)
                    origin[i, k, 1] += w_.p[nb + k] * (sn * ux + c * uy)
            for a in range(3):
                for c in range(nx):
                    T[i, k, a, c] = w_.T[k, a, c]
                    Td[i, k, a, c] = w_.Td[k, a, c]
                    Tdd[i, k, a, c] = w_.Tdd[k, a, c]
        if momenta.shape[0] > 0:
            momentum(d, w_, w_.p, w_.pd, w_.x, w_.xd, pj, out)
            momenta[i, 0], momenta[i, 1], momenta[i, 2] = out[0], out[1], out[2]
