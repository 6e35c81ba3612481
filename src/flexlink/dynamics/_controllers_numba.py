"""Compiled sample update of the controllers (`controllers.py`): read the sensors from the
elastic coordinates, add the pre-drawn noise, quantise, advance every controller that samples
at this grid point, hold its output, and set the actuator voltages (open loop + outputs,
clipped to the limits) in the integrator's state."""

from __future__ import annotations

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from .controllers import CONTROL_BLOW_UP


@njit(cache=True)
def sample(d, w, i, y):
    """Controller update at grid point i; y is the integrator's state [z, …] with the
    voltages at y[d.state_at:]. Returns False when a controller state or output is
    non-finite or beyond CONTROL_BLOW_UP (an unstable loop)."""
    ok = True
    n = d.S.shape[1]
    for c in range(d.Ad.shape[0]):
        if not d.mask[c, i]:
            continue
        k = w.count[c]
        w.count[c] += 1
        for j in range(d.n_in[c]):
            acc = d.noise[c, k, j]
            row = d.in_row[c, j]
            for q in range(n):
                acc += d.S[row, q] * y[q]
            step = d.quant[c, j]
            if step > 0.0:
                acc = np.round(acc / step) * step
            w.yin[j] = acc
        for o in range(d.n_out[c]):
            acc = 0.0
            for q in range(d.n_x[c]):
                acc += d.Cd[c, o, q] * w.x[c, q]
            for j in range(d.n_in[c]):
                acc += d.Dd[c, o, j] * w.yin[j]
            w.held[c, o] = acc
            if not abs(acc) < CONTROL_BLOW_UP:
                ok = False
        for r in range(d.n_x[c]):
            acc = 0.0
            for q in range(d.n_x[c]):
                acc += d.Ad[c, r, q] * w.x[c, q]
            for j in range(d.n_in[c]):
                acc += d.Bd[c, r, j] * w.yin[j]
            w.xn[r] = acc
            if not abs(acc) < CONTROL_BLOW_UP:
                ok = False
        for r in range(d.n_x[c]):
            w.x[c, r] = w.xn[r]
    if d.update[i]:
        na = d.limit.shape[0]
        for a in range(na):
            y[d.state_at + a] = d.v_open[i, a] + w.py_held[a]
        for c in range(d.Ad.shape[0]):
            for o in range(d.n_out[c]):
                y[d.state_at + d.out_act[c, o]] += w.held[c, o]
        for a in range(na):
            v = y[d.state_at + a]
            lim = d.limit[a]
            y[d.state_at + a] = min(max(v, -lim), lim)
    return ok


@njit(cache=True)
def record(d, w, i, y):
    """Controller states, held outputs and voltages at grid point i (after its update)."""
    for c in range(w.x.shape[0]):  # loops, not slice assignments (see _lawson_numba)
        for q in range(w.x.shape[1]):
            w.x_rec[i, c, q] = w.x[c, q]
        for q in range(w.held.shape[1]):
            w.held_rec[i, c, q] = w.held[c, q]
    for a in range(d.limit.shape[0]):
        w.v_rec[i, a] = y[d.state_at + a]
