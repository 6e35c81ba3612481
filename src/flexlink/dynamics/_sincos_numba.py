"""Cosines and sines of a row of angles in one loop that the compiler vectorises (numba):
the nonlinear model's residual turns every node of the beams by its angle at each call,
and libm's scalar ``sincos`` took an eighth of a nonlinear slider run's CPU (23 nodes,
~0.27 µs a residual, against ~0.08 µs here).

The method of fdlibm (Sun Microsystems' freely distributable libm, ``k_sin.c``,
``k_cos.c``, ``e_rem_pio2.c``): x = k π/2 + r with π/2 in three parts (Cody–Waite, exact
products for |k| < 2²⁰), |r| ≤ π/4 as a head and a tail, then fdlibm's minimax polynomials
of sin and cos on r and the quadrant k mod 4 choosing and signing them. Every result is
within one unit in the last place of libm's (tests/unit/test_sincos.py); angles beyond
LIMIT (or not finite) take libm's own.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation

# fdlibm's polynomial coefficients: sin r = r + r³ (S1 + r² P(r²)), cos r = 1 − r²/2 + r⁴ Q(r²)
S1, S2, S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
S4, S5, S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
C1, C2, C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
C4, C5, C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11
INV_PIO2 = 6.36619772367581382433e-01  # 2/π
# π/2 = PIO2_1 + PIO2_2 + PIO2_2T (first 33, next 33 bits, then the rest)
PIO2_1, PIO2_2, PIO2_2T = 1.57079632673412561417e+00, 6.07710050630396597660e-11, \
    2.02226624879595063154e-21
LIMIT = 1e5  # rad: |k| < 2²⁰ with margin; beyond, libm


@njit(inline="always")
def _sincos(x):
    """(sin x, cos x) for |x| ≤ LIMIT, branch-free but for selects."""
    k = np.floor(x * INV_PIO2 + 0.5)
    r = x - k * PIO2_1  # exact
    w = k * PIO2_2
    head = r - w
    tail = (r - head) - w
    w = k * PIO2_2T
    r = head
    head = r - w
    tail += (r - head) - w
    z = head * head
    w = z * z
    p = S2 + z * (S3 + z * S4) + z * w * (S5 + z * S6)
    v = z * head
    sin_r = head - ((z * (0.5 * tail - v * p) - tail) - v * S1)
    q = z * (C1 + z * (C2 + z * C3)) + w * w * (C4 + z * (C5 + z * C6))
    half = 0.5 * z
    w = 1.0 - half
    cos_r = w + (((1.0 - w) - half) + (z * q - head * tail))
    quadrant = np.int64(k)
    odd = (quadrant & 1) != 0
    s = cos_r if odd else sin_r
    c = sin_r if odd else cos_r
    s = -s if (quadrant & 2) != 0 else s
    c = -c if ((quadrant + 1) & 2) != 0 else c
    return s, c


@njit(cache=True, _nrt=False)
def sincos_rows(x, c, s):
    """c[j], s[j] = cos x[j], sin x[j] (rows of equal length)."""
    n = x.shape[0]
    large = False
    for j in range(n):
        s[j], c[j] = _sincos(x[j])
        large |= not abs(x[j]) <= LIMIT
    if large:
        for j in range(n):
            if not abs(x[j]) <= LIMIT:
                c[j] = np.cos(x[j])
                s[j] = np.sin(x[j])
