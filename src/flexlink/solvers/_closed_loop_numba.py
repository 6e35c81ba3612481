"""Compiled step loop of the closed-loop Lawson integrator (``closed_loop.py``): the loop of
`_lawson_numba.lawson_blocks` over grid intervals, on the state [z, ż, 1, V] (the actuator
voltages V constant between samples: rows of zeros in the generator), with the controllers'
sample update (`dynamics._controllers_numba.sample`) at the start of every interval."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ..dynamics._controllers_numba import record, sample
from ._lawson_numba import _add, _copy, _copy2, _delta, _mv, _reach
from .solution import BLOW_UP


@njit(cache=True, error_model="numpy")
def closed_loop_intervals(u, n, grid, i_start, i_stop, block_of, first, last, static, pieces,
                          lower, upper, polyT, referenceT, ET, substeps, states, accelerations,
                          d, w, bounds, reach, beyond):
    """Advance the state u = [z, ż, 1, V] in place over grid intervals i_start … i_stop−1
    (table blocks as in lawson_blocks, block_of[i] the block of interval i). Returns −1, or
    the grid point where the loop blew up (state beyond BLOW_UP or a controller beyond its
    bound). ``bounds``, ``reach``, ``beyond``: as lawson_blocks', read at the end of every
    step (of every interval on static blocks)."""
    m = u.shape[0]
    D1 = np.empty((m, n))
    Dm = np.empty((m, n))
    D2 = np.empty((m, n))
    k1, k2, k3, k4, r = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    wv, a, Ey, v = np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    for i in range(i_start, i_stop):
        if not sample(d, w, i, u):
            return i
        record(d, w, i, u)
        for q in range(m):
            states[i, q] = u[q]
        b = block_of[i]
        P = ET[b]
        if static[b]:
            _mv(P, u, wv)
            _copy(wv, u)
            _reach(bounds, u, grid[i + 1], reach, beyond)
        else:
            A_ref = referenceT[b]
            i0, i1 = first[b], last[b]
            span = grid[i1] - grid[i0]
            p0, p1 = pieces[b], pieces[b + 1]
            h = (grid[i + 1] - grid[i]) / substeps
            _delta(polyT, lower, upper, p0, p1, A_ref, (grid[i] - grid[i0]) / span, D1)
            for j in range(substeps):
                tau = (grid[i] - grid[i0] + j * h) / span
                dtau = h / span
                _delta(polyT, lower, upper, p0, p1, A_ref, tau + 0.5 * dtau, Dm)
                _delta(polyT, lower, upper, p0, p1, A_ref, tau + dtau, D2)
                _mv(D1, u, k1)
                _copy(u, wv)
                _add(wv, n, 0.5 * h, k1)
                _mv(P, wv, a)
                _mv(Dm, a, k2)
                _mv(P, u, Ey)
                _copy(Ey, wv)
                _add(wv, n, 0.5 * h, k2)
                _mv(Dm, wv, k3)
                _copy(Ey, wv)
                _add(wv, n, h, k3)
                _mv(P, wv, a)
                _mv(D2, a, k4)
                _copy(u, wv)
                _add(wv, n, h / 6.0, k1)
                _mv(P, wv, v)
                _add(v, n, h / 3.0, k2)
                _add(v, n, h / 3.0, k3)
                _mv(P, v, u)
                _add(u, n, h / 6.0, k4)
                _copy2(D2, D1)
                _reach(bounds, u, grid[i] + (j + 1) * h, reach, beyond)
            _mv(A_ref, u, r)
            _mv(D2, u, k1)
            for q in range(n):
                accelerations[i + 1, q] = r[q] + k1[q]
        for q in range(2 * n):
            if not abs(u[q]) < BLOW_UP:
                for r in range(m):
                    states[i + 1, r] = u[r]
                return i + 1
    for q in range(m):
        states[i_stop, q] = u[q]
    record(d, w, i_stop, u)  # held values at the end (the next call's start overwrites it)
    return -1
