"""Compiled twin of `prismatic.lever_stiffness` (sliders inside a chain): the second-order
terms of each slider's line, times x, in the residual r = C ẋ + K x − f of
`_forward_numba.residual` (the lever's first-order kinematics are in `_forward_numba.frames`)."""

from __future__ import annotations

from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation


@njit(cache=True, _nrt=False, no_cpython_wrapper=True, no_cfunc_wrapper=True)
def lever_stiffness(d, p, T, out, x, r):
    """r −= S x for each slider k on link j = k − 1's tip, with the outboard force
    F = out[j] (frame j axes), φ = T[k, 2] (the tip's rotation map):
    S = s (F·u) φ φᵀ − (F·Su)(e_s φᵀ + φ e_sᵀ), x with δs = 0 (prismatic.py)."""
    N = d.length.shape[0]
    nb, nx = d.n_base, d.n_x
    for k in range(1, N):
        if not d.slide[k]:
            continue
        j = k - 1
        ux, uy = d.slide_axis[k, 0], d.slide_axis[k, 1]
        fu = out[j, 0] * ux + out[j, 1] * uy
        fsu = -out[j, 0] * uy + out[j, 1] * ux
        phx = 0.0
        for c in range(nx):
            phx += T[k, 2, c] * x[c]
        scale = p[nb + k] * fu * phx
        for c in range(nx):
            r[c] -= scale * T[k, 2, c]
        r[nb + k] += fsu * phx
