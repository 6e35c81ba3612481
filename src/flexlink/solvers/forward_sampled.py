"""Sampled controllers on the compiled forward loops (docs/closed_loop.md): the RK4 and
Lawson step loops (`forward_rk4.py`, `forward_lawson.py`) take precomputed input rows, so
before each sample interval the held voltages overwrite the voltage columns of the rows of
its steps (`forward_kernel.voltage_columns`) and the compiled loop restarts from the carried
state. The controllers are updated at each sample instant from the elastic coordinates z of
that state by `gauss_sampled.SampledLoop` (the compiled update and the Python callables, as
on every other path). Sample instants are nodes of the forward grid, never stepped over.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable

import numpy as np

from .gauss_sampled import SampledLoop
from .solution import Progress

STEPS_PER_CALL = 4096  # progress is reported between calls of the compiled loop


def inner_nodes(loop: SampledLoop | None, t_out: np.ndarray, breaks: np.ndarray) -> np.ndarray:
    """The inner nodes no step may straddle (s): the breakpoints ``breaks`` and the sample
    instants strictly inside the run, those within round-off of an output time or a
    breakpoint left out (the node there stands for both)."""
    inner = breaks[(breaks > t_out[0]) & (breaks < t_out[-1])]
    if loop is None:
        return inner
    samples = loop.grid[:-1]
    samples = samples[(samples > t_out[0]) & (samples < t_out[-1])]
    taken = np.union1d(t_out, inner)
    i = np.clip(np.searchsorted(taken, samples), 1, taken.size - 1)
    gap = np.minimum(np.abs(taken[i] - samples), np.abs(taken[i - 1] - samples))
    return np.union1d(inner, samples[gap > 1e-9 * max(1.0, float(t_out[-1]))])


def run_steps(advance: Callable[[int, int], int], y: np.ndarray, starts: np.ndarray,
              h: np.ndarray, u: np.ndarray, on_progress: Progress | None,
              loop: SampledLoop | None = None, columns: slice | None = None,
              z: slice | None = None) -> int:
    """Drive ``advance(first, last)`` (the compiled loop over steps first … last−1, y in
    place; it returns −1 or the step that blew up) over every step, in calls of at most
    STEPS_PER_CALL steps; with a ``loop``, the controllers are updated at each of its
    sample instants from y[z] and the held voltages written into u[…, columns] of the
    steps up to the next sample. Returns −1 or the step that blew up."""
    stops = np.arange(0, h.size, STEPS_PER_CALL)
    at = np.zeros(0, dtype=np.int64)
    if loop is not None:
        loop.start()
        scale = 1e-9 * max(1.0, float(starts[-1] + h[-1]))
        at = np.searchsorted(starts, loop.grid[:-1] - scale)
        assert np.allclose(starts[at], loop.grid[:-1], rtol=0, atol=scale), "off-grid sample"
        stops = np.union1d(stops, at)
    stops = np.append(stops, h.size).astype(np.int64)
    ends = np.append(at[1:], h.size)
    k = 0
    for a, b in itertools.pairwise(stops):
        if loop is not None and k < at.size and at[k] == a:
            u[a:ends[k], :, columns] = loop.update(k, y[z])
            k += 1
        bad = advance(int(a), int(b))
        if bad >= 0:
            return bad
        if on_progress is not None:
            on_progress(float(starts[b - 1] + h[b - 1]))
    if loop is not None:
        loop.update(loop.grid.size - 1, y[z])  # the records at t_end
    return -1


def held_rows(loop: SampledLoop, t: np.ndarray, u: np.ndarray, columns: slice) -> np.ndarray:
    """Input rows u at times t with the voltages held there by the last pass of ``loop``
    (at a sample instant: the new value, as the steps read it)."""
    u = u.copy()
    u[:, columns] = loop.held_voltages(t)
    return u
