"""Compiled (numba) step loop of the forward-dynamics integrator (``forward_rk4.py``):
classical RK4 on the state [p_free, ṗ_free, z, ż, servo integrals], the right-hand side the
compiled kernel `dynamics._forward_numba.rates` (orders of magnitude cheaper per evaluation
than the numpy ForwardSystem behind solve_ivp: benchmarks/forward.py)."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ..dynamics._forward_numba import rates

BLOW_UP = 1e8  # |state| beyond this (SI units) is a blow-up, not a motion of the model


@njit(cache=True)
def rk4_steps(d, w, y, u, h, record, first, last, states):
    """Advance y in place through steps first … last−1. Step i has length h[i] (s) and input
    rows u[i, 0], u[i, 1], u[i, 2] at its start, middle and end (read just inside the step,
    so that a jump at a step boundary is seen from the right side); after it the state is
    stored in states[record[i]] when record[i] ≥ 0. Returns −1, or the step at which the
    state became non-finite or larger than BLOW_UP."""
    m = y.shape[0]
    k1, k2, k3, k4, tmp = np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    for i in range(first, last):
        hi = h[i]
        rates(d, w, u[i, 0], y, k1)
        for j in range(m):
            tmp[j] = y[j] + 0.5 * hi * k1[j]
        rates(d, w, u[i, 1], tmp, k2)
        for j in range(m):
            tmp[j] = y[j] + 0.5 * hi * k2[j]
        rates(d, w, u[i, 1], tmp, k3)
        for j in range(m):
            tmp[j] = y[j] + hi * k3[j]
        rates(d, w, u[i, 2], tmp, k4)
        bad = False
        for j in range(m):
            y[j] += hi / 6.0 * (k1[j] + 2.0 * (k2[j] + k3[j]) + k4[j])
            if not abs(y[j]) < BLOW_UP:  # also catches NaN
                bad = True
        if bad:
            return i
        if record[i] >= 0:
            states[record[i]] = y
    return -1


@njit(cache=True)
def rates_at(d, w, u, states, out):
    """out[i] = dy/dt at states[i] with input row u[i] (accelerations at the outputs)."""
    for i in range(states.shape[0]):
        rates(d, w, u[i], states[i], out[i])


@njit(cache=True)
def jacobian(d, w, u, y, out):
    """out = ∂(dy/dt)/∂y at state y and input row u, by one-sided differences (its spectrum
    sets the first step: the stiffest mode of the coupled system, servo loops included)."""
    m = y.shape[0]
    f0, f1, yp = np.empty(m), np.empty(m), y.copy()
    rates(d, w, u, y, f0)
    for j in range(m):
        step = 1e-7 * max(1.0, abs(y[j]))
        yp[j] = y[j] + step
        rates(d, w, u, yp, f1)
        yp[j] = y[j]
        for i in range(m):
            out[i, j] = (f1[i] - f0[i]) / step
