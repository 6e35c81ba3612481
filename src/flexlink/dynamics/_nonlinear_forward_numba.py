"""Compiled (numba) residual and accelerations of the nonlinear model with rigid coordinates
— `NonlinearForwardSystem.residual` and `.accelerations` (the numpy reference, docs/nonlinear.md
§7) written as loops over the tiny arrays. The applied forces are the first-order forward
kernel's (`_forward_numba.applied`: drive torques, servo laws, base loads), so each law has one
compiled and one numpy copy, both tested against each other. tests/unit/
test_nonlinear_forward.py compares this module with the numpy equations to round-off."""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._forward_numba import _solve
from ._forward_numba import applied as _applied
from ._nonlinear_numba import node_forces

NonlinearForwardData = namedtuple("NonlinearForwardData", [
    "Ay", "At", "G", "s", "m_tot", "translation", "rot_y", "rot_J", "D", "K", "n", "nu",
    "n_rigid", "free", "cart", "rail"])
NonlinearForwardData.__doc__ = ("Constant arrays of a NonlinearForwardSystem for the kernels "
                                "(SI units; columns on y = [q, p_free, σ]); cart: 0 none, 1 "
                                "its travel s is y[n], 2 s is prescribed (s̈ from the input "
                                "row); rail (2,) its direction.")


@njit(cache=True)
def residual(Y, V, X, ang, rate, acc, rot_acc, u, nd, d, out):
    """Residual (n_y,) of one state into ``out``: inertia + damping + elastic − applied on
    [q, p_free] (the actuators' forces B V on q, V from the input row), σ̈ − integral rate
    on σ (NonlinearForwardSystem.residual)."""
    nodes = nd.Ay.shape[0]
    n, nu = nd.n, nd.nu
    m = n + nu  # columns with node angles
    c = np.empty(nodes)
    s = np.empty(nodes)
    S = np.empty((nodes, 4))
    moments = np.empty(nodes)
    # The base point's acceleration minus gravity (R̈_b − g, global axes): the field enters
    # the node moments and the translation rows through it (NonlinearForwardSystem._inertia).
    rx, ry = -d.gravity[0], -d.gravity[1]
    if nd.translation:
        rx, ry = X[n] + rx, X[n + 1] + ry
    if nd.cart > 0:  # s̈ along the rail: y's, or the prescribed travel's input column
        sdd = X[n] if nd.cart == 1 else u[u.shape[0] - 2]
        rx, ry = sdd * nd.rail[0] + rx, sdd * nd.rail[1] + ry
    force = nd.translation or nd.cart == 1
    node_forces(nd.Ay, m, Y, V, X, ang, rate, acc, nd.G, nd.s, rx, ry, c, s, S, moments)
    out[:] = 0.0
    fx = fy = 0.0
    for j in range(nodes):
        uj = moments[j]
        if force:
            sj = nd.s[j]
            fx += sj * (-S[j, 1] - S[j, 2])
            fy += sj * (S[j, 0] - S[j, 3])
        for i in range(m):
            out[i] += nd.Ay[j, i] * uj
    for r in range(nd.rot_J.shape[0]):
        ar = rot_acc[r]
        for i in range(m):
            ar += nd.rot_y[r, i] * X[i]
        ar *= nd.rot_J[r]
        for i in range(m):
            out[i] += nd.rot_y[r, i] * ar
    for i in range(n):
        for k in range(n):
            out[i] += nd.D[i, k] * V[k] + nd.K[i, k] * Y[k]
    if nd.translation:
        out[n] += nd.m_tot * rx + fx
        out[n + 1] += nd.m_tot * ry + fy
    elif nd.cart == 1:  # the inertia force along the rail on s
        out[n] += (nd.m_tot * rx + fx) * nd.rail[0] + (nd.m_tot * ry + fy) * nd.rail[1]
    if nu > 0 or d.actuator_B.shape[1] > 0:
        p = np.zeros(nd.n_rigid)
        pd = np.zeros(nd.n_rigid)
        for i in range(nu):
            p[nd.free[i]] = Y[n + i]
            pd[nd.free[i]] = V[n + i]
        Q = np.empty(d.n_x)
        ns = Y.shape[0] - m
        rates = np.zeros(max(ns, 1))
        _applied(d, u, p, pd, V[m:], Q, rates)
        for i in range(nu):
            out[n + i] -= Q[nd.free[i]]
        for i in range(n):  # the actuators' forces on q (zero without actuators)
            out[i] -= Q[nd.n_rigid + i]
        for i in range(ns):
            out[m + i] = X[m + i] - rates[i]


@njit(cache=True)
def accelerations(Y, V, ang, rate, acc, rot_acc, u, nd, d):
    """ÿ (b, n_y) of b states: M's columns from the residual's change under unit
    accelerations (it is affine in ÿ), then M ÿ = −r(ÿ = 0)."""
    b, ny = Y.shape
    out = np.empty((b, ny))
    X = np.zeros(ny)
    r0 = np.empty(ny)
    r1 = np.empty(ny)
    M = np.empty((ny, ny))
    for t in range(b):
        X[:] = 0.0
        residual(Y[t], V[t], X, ang[t], rate[t], acc[t], rot_acc[t], u[t], nd, d, r0)
        for k in range(ny):
            X[k] = 1.0
            residual(Y[t], V[t], X, ang[t], rate[t], acc[t], rot_acc[t], u[t], nd, d, r1)
            X[k] = 0.0
            for i in range(ny):
                M[i, k] = r1[i] - r0[i]
        rhs = -r0
        _solve(M, rhs)
        out[t] = rhs
    return out
