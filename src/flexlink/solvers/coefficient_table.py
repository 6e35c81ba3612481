"""The state matrix of a prescribed-motion run, tabulated once as piecewise polynomials in time.

With prescribed joints the equations ż = A(t)[z; ż; 1] (A = M⁻¹[−K, −C, f], shape (n, 2n+1))
change only as fast as the manoeuvre, far slower than the vibration they describe. Assembling
A at one instant in numpy costs more than a whole step of a compiled integrator, so the
integrator reads A from this table instead: per block of output intervals a polynomial of
degree 5 in τ ∈ [0, 1] through six Chebyshev–Lobatto samples.

The table checks itself: A is also assembled midway between the samples, and a block whose
polynomial misses one of those values by more than ``tolerance`` × (that entry's range over the
run) is split in two, down to one output interval, whose time range is then split in pieces
(down to 1/64 of it) around a kink of A between output times. Intervals where the joints rest
(equal joint states at both ends and in the middle, ``coefficient_keys``) form static blocks
with A exactly constant. Where the joint motions say their acceleration jumps (``breaks``, a
motion's start and end), blocks end, or a block of one interval is cut into pieces, exactly
there, so that no refinement is spent on those kinks.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

RowsFunction = Callable[[np.ndarray], np.ndarray]  # times (nt,) → A (nt, n, 2n+1)
KeyFunction = Callable[[np.ndarray], np.ndarray]
# output times (nt,) → per output interval (nt − 1,), whether A is equal at its ends and
# middle; or None: ask the keys
RestFunction = Callable[[np.ndarray], "np.ndarray | None"]

DEGREE = 5
_NODES = 0.5 - 0.5 * np.cos(np.pi * np.arange(DEGREE + 1) / DEGREE)  # Chebyshev–Lobatto, [0, 1]
_CHECKS = 0.5 * (_NODES[1:] + _NODES[:-1])
_FIT = np.linalg.inv(np.vander(_NODES, increasing=True))  # samples → monomial coefficients
_AT_CHECKS = np.vander(_CHECKS, DEGREE + 1, increasing=True)  # coefficients → values there
# Output intervals per moving block before refinement. Longer blocks mean fewer block
# exponentials ((2n+1)³ each) against more refinement samples: 128 was fastest from 2 to
# 10 links (measured against 64 and 256 with benchmarks/compare.py).
_MAX_INTERVALS = 128
_MAX_BLOCK = 0.128  # s, the same bound in time
_MIN_PIECE = 1.0 / 64  # smallest piece of one output interval (around a kink of A)
_BREAK_TOL = 1e-12  # s: a break this close to an output time is on it (arange rounding)


@dataclass(frozen=True)
class CoefficientTable:
    """Blocks of output intervals, each with A as piecewise polynomials in its local time τ ∈ [0, 1].

    first, last: output indices where block b starts and ends (last > first).
    static: whether A is constant on the block (joints at rest).
    pieces: block b's polynomials are pieces[b] … pieces[b+1]−1 (one, unless a block of one
        output interval had to be split further, around a kink of A).
    lower, upper: the τ range of each piece; poly: (pieces, DEGREE+1, n, 2n+1) monomial
        coefficients in the piece's own τ' = (τ − lower) / (upper − lower).
    reference: (blocks, n, 2n+1) A at the block's middle (τ = 1/2).
    """

    first: np.ndarray
    last: np.ndarray
    static: np.ndarray
    pieces: np.ndarray
    lower: np.ndarray
    upper: np.ndarray
    poly: np.ndarray
    reference: np.ndarray
    assemblies: int  # how many instants were assembled to build the table

    def __len__(self) -> int:
        return int(self.first.size)

    def evaluate(self, block: np.ndarray, tau: np.ndarray) -> np.ndarray:
        """A at local times τ of the given blocks (arrays of equal shape), (…, n, 2n+1)."""
        p = self.pieces[block]  # a new array (an index array picks)
        split = np.flatnonzero(self.pieces[block + 1] - p > 1)  # blocks of several pieces
        for i, a, b in zip(split, p[split], self.pieces[block + 1][split]):
            p[i] = min(a + np.searchsorted(self.upper[a:b], tau[i]), b - 1)
        local = (tau - self.lower[p]) / (self.upper[p] - self.lower[p])
        powers = local[:, None, None] ** np.arange(DEGREE + 1)
        values = np.matmul(powers, self.poly[p].reshape(p.size, DEGREE + 1, -1))
        return values.reshape(p.size, *self.poly.shape[2:])


@dataclass(frozen=True)
class TableLayout:
    """Where a table's polynomials lie, without their values: the moving pieces (first,
    last, τ lower, τ upper) and the static blocks (first, last) of `CoefficientTable`.
    `tabulate_on` samples another system's A on it: with the same layout and steps, runs
    that differ in a parameter differ smoothly in it (no refinement decision flips)."""

    moving: tuple[tuple[int, int, float, float], ...]
    static: tuple[tuple[int, int], ...]
    size: int  # output times of the table


def layout(table: CoefficientTable, size: int) -> TableLayout:
    """The layout of ``table`` (built on ``size`` output times)."""
    moving, static = [], []
    for b in range(len(table)):
        a, e = int(table.first[b]), int(table.last[b])
        if table.static[b]:
            static.append((a, e))
            continue
        for p in range(int(table.pieces[b]), int(table.pieces[b + 1])):
            moving.append((a, e, float(table.lower[p]), float(table.upper[p])))
    return TableLayout(tuple(moving), tuple(static), size)


def tabulate_on(rows: RowsFunction, t_out: np.ndarray, where: TableLayout,
                moving_references: bool = True) -> CoefficientTable:
    """The table of A(t) on a given layout (`TableLayout`), from one call of ``rows`` at its
    nodes, without checking it against A between them: the layout of a table `tabulate`
    built for a system close to this one. ``moving_references=False``: the moving blocks'
    ``reference`` left zero (a table of ∂A/∂p, whose steps read the static blocks' only;
    evaluating them costs as much as the rest of the table there)."""
    if t_out.size != where.size:
        raise ValueError(f"the layout is for {where.size} output times, got {t_out.size}")
    span = np.array([[t_out[a], t_out[b], lo, hi] for a, b, lo, hi in where.moving],
                    dtype=float).reshape(-1, 4)
    starts = span[:, :1] + (span[:, 1:2] - span[:, :1]) * span[:, 2:3]
    lengths = (span[:, 1:2] - span[:, :1]) * (span[:, 3:4] - span[:, 2:3])
    nodes = (starts + lengths * _NODES).ravel()
    static_times = np.array([t_out[a] for a, _ in where.static], dtype=float)
    sampler = _Sampler(rows)
    values = sampler.at(np.concatenate([nodes, static_times]))
    samples = values[:nodes.size].reshape(len(where.moving), DEGREE + 1, *values.shape[1:])
    # the entries' count spelled out: -1 cannot be inferred on a layout with no moving block
    poly = np.matmul(_FIT, samples.reshape(len(where.moving), DEGREE + 1,
                                           int(np.prod(values.shape[1:])))).reshape(samples.shape)
    return _assemble_table(list(where.moving), [poly], list(where.static), values[nodes.size:],
                           sampler.count, moving_references)


def sample_weights(table: CoefficientTable, t_out: np.ndarray, weights: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The transpose of `tabulate_on` on ``table``'s layout: the instants it samples, each
    once (sorted), and per instant the weight W_i (…) such that, for the table T that
    `tabulate_on` builds from any samples S_i there, Σ_{p,d} ⟨T.poly[p, d], weights[p, d]⟩ =
    Σ_i ⟨S_i, W_i⟩. ``weights``: (pieces, DEGREE+1, …), like ``table.poly``; a static
    piece's polynomial is its sample (its d = 0 coefficient)."""
    block = np.repeat(np.arange(len(table)), np.diff(table.pieces))
    static = table.static[block]
    moving = np.flatnonzero(~static)
    b = block[moving]
    # the nodes as tabulate_on places them, to the bit
    a, e = t_out[table.first[b]], t_out[table.last[b]]
    starts = a + (e - a) * table.lower[moving]
    lengths = (e - a) * (table.upper[moving] - table.lower[moving])
    nodes = (starts[:, None] + lengths[:, None] * _NODES).ravel()
    # poly[p, d] = Σ_j FIT[d, j] S_pj, so S_pj's weight is Σ_d FIT[d, j] weights[p, d]
    moved = np.tensordot(_FIT, weights[moving], axes=([0], [1]))  # (j, p, …)
    moved = np.swapaxes(moved, 0, 1).reshape(nodes.size, *weights.shape[2:])
    fixed = np.flatnonzero(static)
    times = np.concatenate([nodes, t_out[table.first[block[fixed]]]])
    order = np.argsort(times, kind="stable")
    times = times[order]
    new = np.ones(times.size, dtype=bool)
    new[1:] = times[1:] != times[:-1]
    starts = np.flatnonzero(new)  # each instant once: the weights of its copies summed
    out = np.add.reduceat(np.concatenate([moved, weights[fixed, 0]])[order], starts, axis=0)
    return times[starts], out


class RoughCoefficients(Exception):
    """A(t) is not smooth between output times (say a measured motion's spline with a knot at
    every sample): tabulating it would cost more assemblies than integrating with them."""


def tabulate(
    rows: RowsFunction, t_out: np.ndarray, keys: KeyFunction | None, tolerance: float,
    budget: float | None = None, breaks: np.ndarray | None = None,
    resting: RestFunction | None = None,
) -> CoefficientTable:
    """Build the table of A(t) over the output times t_out (s). ``breaks``: times (s) where A
    is known not to be smooth (a motion starts or stops); blocks and pieces end there instead
    of being refined down to them. ``resting``, if given, tells the output intervals at rest
    instead of ``keys`` (`resting_from_keys`, what it must equal) unless it returns None.
    Raises RoughCoefficients when it would need more than ``budget`` assemblies per moving
    output interval (+ 200)."""
    breaks = np.asarray([] if breaks is None else breaks, dtype=float)
    breaks = breaks[(breaks > t_out[0]) & (breaks < t_out[-1])]
    blocks = _initial_blocks(t_out, keys, breaks, resting)
    sampler = _Sampler(rows)
    limit = (np.inf if budget is None
             else budget * sum(b - a for a, b, static in blocks if not static) + 200)
    # Candidate pieces (first, last, τ lower, τ upper) of the moving blocks.
    moving = [piece for a, b, static in blocks if not static
              for piece in _pieces_between_breaks(a, b, t_out, breaks)]
    static = [(a, b) for a, b, static in blocks if static]
    static_times = np.array([t_out[a] for a, _ in static], dtype=float)
    static_values = None
    scale = None
    done: list[tuple[int, int, float, float]] = []  # the table's moving pieces, by level
    done_poly: list[np.ndarray] = []  # their polynomials, one array per level
    while moving or static_values is None:
        span = np.array([[t_out[a], t_out[b], lo, hi] for a, b, lo, hi in moving]).reshape(-1, 4)
        starts = span[:, :1] + (span[:, 1:2] - span[:, :1]) * span[:, 2:3]
        lengths = (span[:, 1:2] - span[:, :1]) * (span[:, 3:4] - span[:, 2:3])
        # One call of the (compiled) rows per level, the static blocks' values with the first:
        # each call costs its Python (joint states of the times, their runs) on top.
        times = [(starts + lengths * _NODES).ravel(), (starts + lengths * _CHECKS).ravel()]
        if static_values is None:
            times.append(static_times)
        values = sampler.at(np.concatenate(times))
        if static_values is None:
            static_values = values[values.shape[0] - static_times.size:]
        if not moving:
            break
        nodes = values[:times[0].size].reshape(len(moving), DEGREE + 1, *values.shape[1:])
        checks = values[times[0].size: times[0].size + times[1].size].reshape(
            len(moving), DEGREE, *values.shape[1:])
        # Stacked matrix products over the flattened entries (einsum does not call BLAS).
        flat = nodes.reshape(len(moving), DEGREE + 1, -1)
        poly = np.matmul(_FIT, flat).reshape(nodes.shape)
        if scale is None:  # each entry's range over the run: what an error is measured against
            scale = _entry_scale(nodes.reshape(-1, *nodes.shape[2:]), static_values)
        miss = np.matmul(_AT_CHECKS, poly.reshape(flat.shape))
        miss -= checks.reshape(miss.shape)
        np.abs(miss, out=miss)
        miss /= scale.reshape(1, 1, -1)
        miss = miss.max(axis=(1, 2))
        refine = []
        kept = np.zeros(len(moving), dtype=bool)
        for i, ((a, b, lo, hi), m) in enumerate(zip(moving, miss)):
            if m <= tolerance or hi - lo <= _MIN_PIECE:
                done.append((a, b, lo, hi))
                kept[i] = True
            elif b - a > 1:
                mid = (a + b) // 2
                refine += [(a, mid, 0.0, 1.0), (mid, b, 0.0, 1.0)]
            else:  # one output interval: split its time range
                refine += [(a, b, lo, 0.5 * (lo + hi)), (a, b, 0.5 * (lo + hi), hi)]
        done_poly.append(poly[kept])
        moving = refine
        if sampler.count > limit:
            raise RoughCoefficients(f"{sampler.count} assemblies and still refining")
    assert static_values is not None
    return _assemble_table(done, done_poly, static, static_values, sampler.count)


def _entry_scale(*samples: np.ndarray) -> np.ndarray:
    """What a table error of each entry of A = [−M⁻¹K, −M⁻¹C, M⁻¹f] (n, 2n+1) is measured
    against: its range over all ``samples`` (arrays of A), at least 1e-9 of its row's largest
    entry of the same part — for the damping part (1/s) also of √ of the stiffness part's
    (1/s²), the row's frequency. The floor keeps entries that are round-off (couplings to a
    rigid link, zero in exact arithmetic) from being refined down to the smallest piece."""
    present = [a for a in samples if a.shape[0]]
    high = np.max([a.max(axis=0) for a in present], axis=0)
    low = np.min([a.min(axis=0) for a in present], axis=0)
    spread = high - low
    size = np.maximum(high, -low)  # the largest |entry|
    n = spread.shape[-2]
    stiffness = size[:, :n].max(axis=1, keepdims=True)
    damping = np.maximum(size[:, n:2 * n].max(axis=1, keepdims=True), np.sqrt(stiffness))
    floor = np.concatenate([np.broadcast_to(stiffness, (n, n)), np.broadcast_to(damping, (n, n)),
                            size[:, 2 * n:]], axis=1)
    return np.maximum(spread, 1e-9 * floor) + 1e-300


def _pieces_between_breaks(
    a: int, b: int, t_out: np.ndarray, breaks: np.ndarray
) -> list[tuple[int, int, float, float]]:
    """The block's initial pieces: one, or (a block of one interval) one per side of each
    break inside it."""
    if b - a > 1:
        return [(a, b, 0.0, 1.0)]
    inside = breaks[(breaks > t_out[a] + _BREAK_TOL) & (breaks < t_out[b] - _BREAK_TOL)]
    if inside.size == 0:
        return [(a, b, 0.0, 1.0)]
    tau = np.concatenate([[0.0], (inside - t_out[a]) / (t_out[b] - t_out[a]), [1.0]])
    return [(a, b, float(lo), float(hi)) for lo, hi in itertools.pairwise(tau) if hi > lo]


def resting_from_keys(t_out: np.ndarray, keys: KeyFunction) -> np.ndarray:
    """Per output interval of t_out (s), whether ``keys`` label its ends and its middle alike
    (A equal there: the joints rest)."""
    interleaved = np.empty(2 * t_out.size - 1)  # in time order: keys label runs
    interleaved[0::2] = t_out
    interleaved[1::2] = t_out[:-1] + 0.5 * np.diff(t_out)
    k = keys(interleaved)
    at, mid = k[0::2], k[1::2]
    return (at[:-1] == at[1:]) & (at[:-1] == mid)


def _initial_blocks(
    t_out: np.ndarray, keys: KeyFunction | None, breaks: np.ndarray,
    rests: RestFunction | None = None,
) -> list[tuple[int, int, bool]]:
    """(first, last, static) blocks: runs of resting intervals, and moving runs cut into pieces
    of ≤ _MAX_INTERVALS intervals of equal length and ≤ _MAX_BLOCK seconds, cut at breaks."""
    intervals = np.diff(t_out)
    told = None if rests is None else rests(t_out)
    if told is not None:
        resting = np.array(told, dtype=bool)  # a copy: cut at breaks below
    elif keys is None:
        resting = np.zeros(intervals.size, dtype=bool)
    else:
        resting = resting_from_keys(t_out, keys)
    # A break inside an interval means motion there, even if the joints are back where they
    # were at both ends and in the middle (a quick move there and back).
    where = np.searchsorted(t_out, breaks)  # t_out[where - 1] < break ≤ t_out[where]
    # np.isclose(…, rtol=0, atol=_BREAK_TOL) of finite times, without its generality
    on_time = np.abs(t_out[np.minimum(where, t_out.size - 1)] - breaks) <= _BREAK_TOL
    inner = where[~on_time] - 1
    resting[inner] = False
    # Equal step lengths within a block (the last output interval may be shorter).
    length_key = np.round(intervals / intervals.max(), 9)
    # Runs of intervals alike in rest/motion and length; moving runs then cut. Two resting
    # intervals in a row rest in one state (they share an end).
    change = np.ones(intervals.size, dtype=bool)
    change[1:] = (resting[1:] != resting[:-1]) | (length_key[1:] != length_key[:-1])
    # A break on an output time starts a block there; one inside an interval makes that
    # interval a block of its own.
    change[np.clip(where[on_time], 0, intervals.size - 1)] = True
    change[inner] = True
    change[np.minimum(inner + 1, intervals.size - 1)] = True
    starts = np.flatnonzero(change)
    ends = np.append(starts[1:], intervals.size)
    blocks: list[tuple[int, int, bool]] = []
    for a, b in zip(starts.tolist(), ends.tolist()):
        if resting[a]:
            blocks.append((a, b, True))
        else:
            cut = int(max(1, min(_MAX_INTERVALS, _MAX_BLOCK // intervals[a])))
            blocks += [(lo, min(lo + cut, b), False) for lo in range(a, b, cut)]
    return blocks


class _Sampler:
    """A(t) at any times, counting the instants asked for (one call per refinement level).

    A time asked for again in the next call, bit for bit, is not assembled again: a
    piece's halves share three of their six nodes with it (τ = 0, ½ and the first or
    last check, (x₁/2) of its nodes x), and equal times give equal A. ``count`` still
    counts them, so the budget of `tabulate` decides as if each were assembled."""

    def __init__(self, rows: RowsFunction) -> None:
        self._rows = rows
        self.count = 0
        self._last: tuple[np.ndarray, np.ndarray] | None = None  # the last call's (times, A)

    def at(self, times: np.ndarray) -> np.ndarray:
        unique, inverse = np.unique(times, return_inverse=True)
        self.count += unique.size
        values = None
        if self._last is not None and unique.size:
            before, known_values = self._last
            where = np.minimum(np.searchsorted(before, unique), max(before.size - 1, 0))
            known = (before[where] == unique) if before.size else np.zeros(unique.size, bool)
            if known.any():
                values = np.empty((unique.size, *known_values.shape[1:]))
                values[known] = known_values[where[known]]
                if not known.all():
                    values[~known] = self._assembled(unique[~known])
        if values is None:
            values = self._assembled(unique)
        self._last = unique, values
        return values[inverse.ravel()]

    def _assembled(self, times: np.ndarray) -> np.ndarray:
        values = self._rows(times)
        if not np.all(np.isfinite(values)):
            raise FloatingPointError("the equations of motion have non-finite coefficients")
        return values


def _assemble_table(
    moving: list[tuple[int, int, float, float]], moving_poly: list[np.ndarray],
    static: list[tuple[int, int]], static_values: np.ndarray, assemblies: int,
    moving_references: bool = True,
) -> CoefficientTable:
    """The table of the moving pieces (first, last, τ lower, τ upper), whose polynomials
    are ``moving_poly`` stacked in their order, and of the static blocks (first, last) with
    A = ``static_values`` there, in time order; without ``moving_references``, the moving
    blocks' references zero."""
    shape = static_values.shape[1:]
    size = len(moving) + len(static)
    first = np.array([e[0] for e in moving] + [a for a, _ in static], dtype=np.int64)
    last = np.array([e[1] for e in moving] + [b for _, b in static], dtype=np.int64)
    lower = np.array([e[2] for e in moving] + [0.0] * len(static), dtype=float)
    upper = np.array([e[3] for e in moving] + [1.0] * len(static), dtype=float)
    order = np.lexsort((lower, first))  # by first output, then τ
    rank = np.empty(size, dtype=np.int64)
    rank[order] = np.arange(size)
    poly = np.zeros((size, DEGREE + 1, *shape))
    if moving:  # each polynomial copied once, to its place
        stacked = moving_poly[0] if len(moving_poly) == 1 else np.concatenate(moving_poly)
        poly[rank[:len(moving)]] = stacked.reshape(len(moving), DEGREE + 1, *shape)
    poly[rank[len(moving):], 0] = static_values
    first, last, lower, upper = first[order], last[order], lower[order], upper[order]
    new_block = np.ones(size, dtype=bool)
    new_block[1:] = first[1:] != first[:-1]
    pieces = np.append(np.flatnonzero(new_block), size).astype(np.int64)
    is_static = np.zeros(size, dtype=np.bool_)
    is_static[rank[len(moving):]] = True
    table = CoefficientTable(
        first=first[new_block],
        last=last[new_block],
        static=is_static[new_block],
        pieces=pieces,
        lower=lower,
        upper=upper,
        poly=poly,
        reference=np.empty((0, *shape)),
        assemblies=assemblies,
    )
    if moving_references:
        blocks = np.arange(len(table))
        reference = table.evaluate(blocks, np.full(blocks.size, 0.5))
    else:  # a static block's polynomial is its constant: its value at τ = 1/2 to the bit
        reference = np.zeros((len(table), *shape))
        reference[table.static] = poly[pieces[:-1][table.static], 0]
    return replace(table, reference=np.ascontiguousarray(reference))
