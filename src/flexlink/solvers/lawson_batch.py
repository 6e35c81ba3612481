"""Adaptive Lawson runs of several systems advanced together: one compiled call for the first
pass of every system with the same output times and steps per interval (``lawson.py``).

Each run is its own up to its first pass (`lawson.prepare`: its own table, refinement and
first steps) and after it (`lawson.finish`: its own Richardson check, and shorter steps alone
if it needs them). Between them, the runs with the same output times, steps per interval and
state size — variants of one scenario that differ in its numbers, its motion's amplitude or
its timing — cross them in one call of the batched loop (_lawson_batch_numba.py), each on
its own table, with its own matrices and states and the same operations as its single run:
each result equals its single run's bit for bit. The loop's products then vectorise across a
call's 32 variants instead of across a 2n+1 row; a group of `MIN_GROUP` or more is filled up
to 32 with copies of its last variant, a smaller one runs alone (it would not pay).
"""

from __future__ import annotations

from collections.abc import Hashable, Sequence
from dataclasses import replace

import numpy as np

from .batched_expm import expm_balanced_many
from .lawson import Start, assemble_propagators, propagator_stacks, static_accelerations
from .solution import StepReach

MIN_GROUP = 24  # fewer variants on one discretisation run faster one by one
MAX_GROUP = 32  # one call of the loop (its `LANES`; a smaller group is filled up to it)

# states, z̈, peak, spread, the reach of the run's bounds (`lawson.first_pass`)
FirstPass = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, StepReach | None]


def shared_key(start: Start) -> Hashable:
    """What runs advanced together must share: the state size, the output times, the steps
    per interval and the polynomials' degree. Equal keys mean the same step h in every output
    interval; each run keeps its own table (blocks, pieces, polynomials)."""
    return (start.n, start.substeps, start.table.poly.shape[1], start.t_out.tobytes())


def groups(starts: Sequence[Start | None]) -> list[list[int]]:
    """Indices of ``starts`` in groups of `MIN_GROUP` … `MAX_GROUP` sharing their key, in
    order of first appearance; the others (and None) are left out."""
    by_key: dict[Hashable, list[int]] = {}
    for i, start in enumerate(starts):
        if start is not None:
            by_key.setdefault(shared_key(start), []).append(i)
    return [members[lo: lo + MAX_GROUP] for members in by_key.values()
            for lo in range(0, len(members), MAX_GROUP)
            if len(members[lo: lo + MAX_GROUP]) >= MIN_GROUP]


def with_propagators(starts: Sequence[Start]) -> list[Start]:
    """`lawson.with_propagators` of each run, the exponentials of every run that need the
    same Padé degree in one call (`batched_expm.expm_balanced_many`): each equal to its
    single run's bit for bit."""
    stacks = [propagator_stacks(s.table, s.n, s.t_out, s.substeps) for s in starts]
    flat = [stack for run in stacks for where, stack in run if where.any()]
    exponentials = iter(expm_balanced_many(flat))
    return [replace(start, ET=assemble_propagators(run, [
        next(exponentials) if where.any() else None for where, _ in run]))
        for start, run in zip(starts, stacks)]


def first_passes(starts: Sequence[Start]) -> list[FirstPass | None]:
    """The first pass (fine and coarse steps, running maxima) of each run in one call; the
    runs share `shared_key`. None for a run whose state became non-finite (its single run
    then reports where)."""
    from ._lawson_batch_numba import LANES, lawson_blocks_batch  # numba's import: when used

    first = starts[0]
    if any(shared_key(s) != shared_key(first) for s in starts[1:]):
        raise ValueError("runs advanced together must share their output times, steps per "
                         "interval and polynomial degree")
    n, t_out, nv = first.n, first.t_out, len(starts)
    tiles = -(-nv // LANES)
    padded = [*starts, *[starts[-1]] * (tiles * LANES - nv)]  # a last tile filled up
    m = 2 * n + 1
    blocks = max(len(s.table) for s in padded)
    polys = max(s.table.poly.shape[0] for s in padded)

    def stacked(values: list[np.ndarray], size: int, fill: float = 0
                ) -> np.ndarray:
        """(V, size, …): each run's array padded along its first axis to ``size``."""
        out = np.full((len(values), size, *values[0].shape[1:]), fill,
                      dtype=values[0].dtype)
        for v, a in enumerate(values):
            out[v, :a.shape[0]] = a
        return out

    def per_lane(a: np.ndarray) -> np.ndarray:
        """(V, …) → (tiles, LANES, …)."""
        return np.ascontiguousarray(a.reshape(tiles, LANES, *a.shape[1:]))

    tables = [s.table for s in padded]
    # Padded rows are never reached: each lane's blocks cover every output interval.
    first_ = per_lane(stacked([t.first for t in tables], blocks))
    last_ = per_lane(stacked([t.last for t in tables], blocks))
    static = per_lane(stacked([t.static for t in tables], blocks, False))
    pieces = per_lane(stacked([t.pieces for t in tables], blocks + 1))
    lower = per_lane(stacked([t.lower for t in tables], polys))
    upper = per_lane(stacked([t.upper for t in tables], polys, 1.0))
    # The single run's E², E⁴ (lawson.loop_matrices) of each run: numpy multiplies each
    # matrix of a stack on its own, so each is the single run's.
    ET = stacked([s.ET for s in padded], blocks)  # (V, blocks, m, m)
    moving = ~stacked([t.static for t in tables], blocks, True)
    E2T = ET.copy()
    E2T[moving] = ET[moving] @ ET[moving]
    E4T = E2T.copy()
    E4T[moving] = E2T[moving] @ E2T[moving]
    # The loop copies each lane's block lanes-last (transposing the table's) as it enters it.
    poly = per_lane(stacked([t.poly for t in tables], polys))
    reference = per_lane(stacked([t.reference for t in tables], blocks))
    ET, E2T, E4T = (per_lane(a) for a in (ET, E2T, E4T))
    states = np.empty((tiles, LANES, t_out.size, m))
    acc = np.empty((tiles, LANES, t_out.size, n))
    peak = np.empty((tiles, m, LANES))
    spread = np.zeros((tiles, m, LANES))
    rows = max((s.bounds.shape[0] for s in padded if s.bounds is not None), default=0)
    bounds = np.zeros((tiles * LANES, rows, m))
    for v, s in enumerate(padded):
        if s.bounds is not None:
            bounds[v, :s.bounds.shape[0]] = s.bounds
    bounds = np.ascontiguousarray(np.moveaxis(per_lane(bounds), 1, -1))  # (tiles, r, m, V)
    reach = np.zeros((tiles, rows, LANES))
    beyond = np.full((tiles, rows, LANES), np.inf)
    for k in range(tiles):
        y = np.zeros((m, LANES))
        y[-1] = 1.0
        yc = y.copy()
        states[k, :, 0] = y.T
        peak[k] = np.abs(y)
        lawson_blocks_batch(y, yc, t_out, first_[k], last_[k], static[k], pieces[k],
                            lower[k], upper[k], poly[k], reference[k], ET[k], E2T[k],
                            E4T[k], first.substeps, states[k], acc[k], peak[k], spread[k],
                            bounds[k], reach[k], beyond[k])
    out: list[FirstPass | None] = []
    for v, start in enumerate(starts):
        k, lane = divmod(v, LANES)
        top, gap = peak[k, :, lane], spread[k, :, lane]
        # |y| and |y − yc| keep a NaN or an infinity once met (the loop's maxima): finite
        # maxima mean every state was finite.
        if not (np.all(np.isfinite(top)) and np.all(np.isfinite(gap))):
            out.append(None)
            continue
        s, a = states[k, lane], acc[k, lane]
        a[0] = start.table.poly[0, 0] @ s[0]  # A at τ = 0 of the first block
        static_accelerations(start.table, s, a)
        r = None if start.bounds is None else StepReach(
            reach[k, :start.bounds.shape[0], lane].copy(),
            beyond[k, :start.bounds.shape[0], lane].copy())
        out.append((s, a, top.copy(), gap.copy(), r))
    return out


def load() -> None:
    """Load (or compile) the batched loop."""
    from ._lawson_batch_numba import load as load_loop

    load_loop()
