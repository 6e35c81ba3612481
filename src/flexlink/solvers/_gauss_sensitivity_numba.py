"""Compiled pieces of the Gauss collocation's sensitivities (`gauss_sensitivity.py`): the
stage residuals of a batch of states, and the replay of a run's accepted steps that
recovers each Gauss step's converged stage accelerations (the run keeps its step ends
only). Both reach the model through `_gauss_numba.model_residual` (either nonlinear
model, by its kernel-data record)."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._gauss_numba import _advance, model_residual, solve_stages


@njit(cache=True)
def residuals(d, rows, index, Q, V, X, out):
    """The residuals out (b, n) of b stage states Q, V, X (b, n) with stage inputs in rows
    ``index`` (b,) of ``rows`` (a StageInputs)."""
    angle, rate, acc, rot, u = rows
    for b in range(Q.shape[0]):
        r = index[b]
        model_residual(d, Q[b], V[b], X[b], angle[r], rate[r], acc[r], rot[r], u[r], out[b])


@njit(cache=True)
def replay(d, rows, y0, v0, H, parts, tab, newton, starts_y, starts_v, stages, ends_y, ends_v):
    """Each accepted step i from y0[i], v0[i] (S, n) of length H[i] (s) taken again as
    ``parts`` Gauss steps of H/parts (stage rows 2g, 2g + 1 for Gauss step g): their start
    states starts_y, starts_v (S·parts, n), converged stage accelerations stages
    (S·parts, 2, n) and each accepted step's end ends_y, ends_v (S, n), in place. Returns
    the Gauss step whose Newton iteration failed, or −1."""
    n = y0.shape[1]
    inverse = np.zeros((2 * n, 2 * n))
    have = np.zeros(1, np.int64)
    counts = np.zeros(2, np.int64)
    peak = np.zeros(1)
    X = np.zeros((2, n))
    y = np.empty(n)
    v = np.empty(n)
    y1 = np.empty(n)
    v1 = np.empty(n)
    h_last = -1.0
    g = 0
    for i in range(y0.shape[0]):
        h = H[i] / parts
        y[:] = y0[i]
        v[:] = v0[i]
        for _ in range(parts):
            if h != h_last:
                have[0] = 0
                h_last = h
            if not solve_stages(d, rows, 2 * g, y, v, X, h, tab, newton, inverse, have,
                                counts, peak):
                return g
            starts_y[g] = y
            starts_v[g] = v
            stages[g] = X
            _advance(y, v, X, h, tab, y1, v1)
            y[:] = y1
            v[:] = v1
            g += 1
        ends_y[i] = y
        ends_v[i] = v
    return -1
