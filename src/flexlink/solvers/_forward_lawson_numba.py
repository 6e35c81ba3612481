"""Compiled (numba) step loop of the forward Lawson integrator (``forward_lawson.py``).

dy/dt = f(t, y) is split as L y + N(t, y), N = f − L y, with L the Jacobian of f frozen at
the state where it was last refreshed. One step of length h (Lawson's integrating-factor
RK4, as the prescribed `_lawson_numba.py`, with E = exp(h/2 · L)):

    k1 = N(t, y),              k2 = N(t + h/2, E(y + h/2 k1)),
    k3 = N(t + h/2, E y + h/2 k2),   k4 = N(t + h, E(E y + h k3)),
    y ← E(E(y + h/6 k1) + h/3 (k2 + k3)) + h/6 k4.

E carries the stiff elastic oscillation (and a stiff servo loop) exactly; RK4 only sees
the remainder, whose derivatives scale with how far the state has moved since L was frozen.
L is refreshed when a free rigid coordinate or its rate has moved by more than a threshold
(the Jacobian depends on the configuration, not on z: the equations are first order in z).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ..dynamics._forward_numba import rates
from ._forward_rk4_numba import BLOW_UP, jacobian

# [7/7] Padé approximant of exp, accurate to double precision for ‖X‖₁ ≤ 0.95 (Higham 2005).
_PADE = np.array([math.factorial(14 - j) * math.factorial(7)
                  / (math.factorial(14) * math.factorial(j) * math.factorial(7 - j))
                  for j in range(8)])
_THETA7 = 9.504178996162932e-1


@njit(cache=True)
def expm(A, out):
    """out = exp(A) for a small square matrix: scaling and squaring with the [7/7] Padé
    approximant (as solvers/batched_expm.py, one matrix)."""
    n = A.shape[0]
    norm = 0.0
    for j in range(n):
        s = 0.0
        for i in range(n):
            s += abs(A[i, j])
        norm = max(norm, s)
    squarings = 0
    if norm > _THETA7:
        squarings = math.ceil(math.log2(norm / _THETA7))
    # Copies into C-ordered arrays: the caller may pass a view, and '@' on views of any
    # layout is slow (numba warns, and the tests turn warnings into errors).
    X = np.empty((n, n))
    X[:, :] = A
    X *= 0.5 ** squarings
    X2 = X @ X
    power = np.eye(n)
    odd = _PADE[1] * power
    even = _PADE[0] * power
    for i in range(1, 4):
        power = power @ X2
        even += _PADE[2 * i] * power
        odd += _PADE[2 * i + 1] * power
    U = X @ odd
    E = np.empty((n, n))
    E[:, :] = np.linalg.solve(even - U, even + U)
    for _ in range(squarings):
        E = E @ E
    out[:, :] = E


@njit(cache=True)
def _mv(A, x, out):
    """out = A x (no allocation)."""
    n = A.shape[0]
    for i in range(n):
        acc = 0.0
        for j in range(x.shape[0]):
            acc += A[i, j] * x[j]
        out[i] = acc


@njit(cache=True)
def _emv(E, g, x, out):
    """out = E x + g: the exponential of the augmented generator on (x, 1)."""
    _mv(E, x, out)
    for i in range(out.shape[0]):
        out[i] += g[i]


@njit(cache=True)
def _remainder(d, w, u, L, c, y, k, tmp):
    """k = f(y) − L y − c at input row u."""
    rates(d, w, u, y, k)
    _mv(L, y, tmp)
    for j in range(k.shape[0]):
        k[j] -= tmp[j] + c[j]


@njit(cache=True)
def lawson_steps(d, w, y, u, h, record, first, last, states, nu, dp, dpd, frozen, L, c, E,
                 g, counters):
    """Advance y in place through steps first … last−1 (step i: length h[i] in s, input rows
    u[i, 0…2] at its start, middle, end as in `_forward_rk4_numba.rk4_steps`; the state after
    it stored in states[record[i]] when record[i] ≥ 0).

    frozen (len(y)) is the state y* the linear part was last taken at (NaN: none yet): L the
    Jacobian of f there and c = f(y*) − L y*, so that the affine part L y + c — constant
    loads included, which RK4 would otherwise integrate against the oscillating factor —
    is carried by the exponential of the augmented generator [[L, c], [0, 0]]:
    (E, g) = its exp(h/2 ·) on (x, 1) ↦ E x + g. They are refreshed when a free coordinate
    y[:nu] has moved by more than dp or a rate y[nu:2nu] by more than dpd. counters[0]
    counts refreshes, counters[1] is 1 while (E, g) is valid for the step counters[2].
    Returns −1 or the step of a blow-up."""
    m = y.shape[0]
    k1, k2, k3, k4 = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    a, b, tmp = np.empty(m), np.empty(m), np.empty(m)
    half = np.empty((m + 1, m + 1))
    E_aug = np.empty((m + 1, m + 1))
    for i in range(first, last):
        hi = h[i]
        stale = np.isnan(frozen[0])  # never frozen
        for j in range(nu):
            if abs(y[j] - frozen[j]) > dp or abs(y[nu + j] - frozen[nu + j]) > dpd:
                stale = True
        if stale:
            jacobian(d, w, u[i, 0], y, L)
            rates(d, w, u[i, 0], y, c)
            _mv(L, y, tmp)
            for j in range(m):
                c[j] -= tmp[j]
            frozen[:] = y
            counters[0] += 1
            counters[1] = 0  # E is out of date
        # The grid's steps differ in the last bits (differences of output times): one E
        # serves steps equal to 1e-9.
        if counters[1] == 0 or abs(hi - counters[2]) > 1e-9 * hi:
            half[:, :] = 0.0
            for r in range(m):
                for q in range(m):
                    half[r, q] = 0.5 * hi * L[r, q]
                half[r, m] = 0.5 * hi * c[r]
            expm(half, E_aug)
            E[:, :] = E_aug[:m, :m]
            g[:] = E_aug[:m, m]
            counters[1] = 1
            counters[2] = hi
        _remainder(d, w, u[i, 0], L, c, y, k1, tmp)
        for j in range(m):
            a[j] = y[j] + 0.5 * hi * k1[j]
        _emv(E, g, a, b)  # stage 2
        _remainder(d, w, u[i, 1], L, c, b, k2, tmp)
        _emv(E, g, y, a)  # E y + g
        for j in range(m):
            b[j] = a[j] + 0.5 * hi * k2[j]
        _remainder(d, w, u[i, 1], L, c, b, k3, tmp)
        for j in range(m):
            a[j] += hi * k3[j]
        _emv(E, g, a, b)  # stage 4
        _remainder(d, w, u[i, 2], L, c, b, k4, tmp)
        for j in range(m):
            a[j] = y[j] + hi / 6.0 * k1[j]
        _emv(E, g, a, b)
        for j in range(m):
            b[j] += hi / 3.0 * (k2[j] + k3[j])
        _emv(E, g, b, a)
        bad = False
        for j in range(m):
            y[j] = a[j] + hi / 6.0 * k4[j]
            if not abs(y[j]) < BLOW_UP:  # also catches NaN
                bad = True
        if bad:
            return i
        if record[i] >= 0:
            states[record[i]] = y
    return -1
