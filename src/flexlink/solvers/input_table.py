"""Inputs of a compiled run as piecewise Chebyshev polynomials (read by
`_radau_numba.input_row`).

An adaptive integrator needs the inputs (prescribed motions, servo references, torque
tables, base loads, actuator voltages) at times it does not know in advance, inside a
compiled loop that cannot call the Python objects that define them. Between breakpoints the
inputs are smooth, so each segment between two nodes is cut into pieces on which a
polynomial of degree DEGREE interpolates every input column at Chebyshev points of the
first kind (interior points: a jump on a node is never sampled, each side belongs to its
own segment); a piece is halved until the interpolant agrees with the inputs at the
points between its nodes within TOL of each column's range (its largest value minus its
smallest: a small input on a large offset, say a reference a little around 45°, is resolved
as well as the offset; a floor of a few units of round-off of the column's largest
magnitude).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

DEGREE = 8
TOL = 1e-11  # interpolation error relative to each column's range
MAX_PIECE = 0.25  # s, the longest piece tried first
MAX_HALVINGS = 16

_J = np.arange(DEGREE + 1)
NODES = np.cos(np.pi * (_J + 0.5) / (DEGREE + 1))  # on [−1, 1]
CHECK = np.cos(np.pi * (np.arange(DEGREE) + 1.0) / (DEGREE + 1))  # between the nodes
# coefficients = values @ _TO_COEF.T (discrete Chebyshev transform)
_TO_COEF = (2.0 / (DEGREE + 1)) * np.cos(np.outer(_J, np.pi * (_J + 0.5) / (DEGREE + 1)))
_TO_COEF[0] *= 0.5


def _chebyshev(coef: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Σ_k coef[p, k, c] T_k(x[j]) → (pieces, len(x), columns)."""
    T = np.cos(np.outer(np.arccos(np.clip(x, -1.0, 1.0)), np.arange(DEGREE + 1)))
    return np.einsum("jk,pkc->pjc", T, coef)


def tabulate(evaluate: Callable[[np.ndarray], np.ndarray], nodes: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The input table of ``evaluate`` (times (k,) s → rows (k, columns)) over the segments
    between consecutive ``nodes`` (s, sorted): piece starts and ends (s), coefficients
    (pieces, DEGREE + 1, columns) and, per segment, the index of its first piece (and the
    number of pieces at the end)."""
    width = np.diff(nodes)
    count = np.maximum(1, np.ceil(width / MAX_PIECE).astype(np.int64))
    seg = np.repeat(np.arange(width.size), count)
    k = np.arange(seg.size) - np.repeat(np.cumsum(count) - count, count)
    a = nodes[seg] + width[seg] * k / count[seg]
    b = nodes[seg] + width[seg] * (k + 1) / count[seg]
    b[np.cumsum(count) - 1] = nodes[1:]  # the segment's end exactly
    done_a, done_b, done_coef, done_seg = [], [], [], []
    bound = None
    for halving in range(MAX_HALVINGS + 1):
        mid, half = 0.5 * (a + b), 0.5 * (b - a)
        x = np.concatenate([NODES, CHECK])
        times = mid[:, None] + half[:, None] * x[None, :]
        values = evaluate(times.ravel()).reshape(times.shape + (-1,))
        if bound is None:
            span = values.max(axis=(0, 1)) - values.min(axis=(0, 1))
            bound = TOL * span + 1e3 * np.finfo(float).eps * np.abs(values).max(axis=(0, 1))
        coef = np.einsum("kj,pjc->pkc", _TO_COEF, values[:, :NODES.size])
        error = np.abs(_chebyshev(coef, CHECK) - values[:, NODES.size:]).max(axis=1)
        good = np.all(error <= bound, axis=1) | (halving == MAX_HALVINGS)
        done_a.append(a[good])
        done_b.append(b[good])
        done_coef.append(coef[good])
        done_seg.append(seg[good])
        a, b, seg = a[~good], b[~good], seg[~good]
        if a.size == 0:
            break
        m = 0.5 * (a + b)
        a, b, seg = np.concatenate([a, m]), np.concatenate([m, b]), np.concatenate([seg, seg])
    a, b = np.concatenate(done_a), np.concatenate(done_b)
    coef, seg = np.concatenate(done_coef), np.concatenate(done_seg)
    order = np.lexsort((a, seg))
    a, b, coef, seg = a[order], b[order], np.ascontiguousarray(coef[order]), seg[order]
    first = np.searchsorted(seg, np.arange(width.size + 1)).astype(np.int64)
    return a, b, coef, first


def integrals(table: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
              ) -> tuple[np.ndarray, np.ndarray]:
    """The inputs' integrals from the table's start, ∫ u dt (s · unit of each column), as a
    table over the same pieces: coefficients (pieces, DEGREE + 2, columns) of each piece's
    antiderivative in its own variable x ∈ [−1, 1], zero at x = −1 and scaled by the half
    width, and the integral up to each piece's start (pieces, columns). Read by
    `_radau_numba.input_integral`; exact for the tabulated polynomials."""
    a, b, coef, _first = table
    anti = np.polynomial.chebyshev.chebint(coef, lbnd=-1.0, axis=1)
    anti *= (0.5 * (b - a))[:, None, None]
    whole = anti.sum(axis=1)  # T_k(1) = 1: each piece's integral over itself
    offset = np.concatenate([np.zeros((1, coef.shape[2])), np.cumsum(whole, axis=0)[:-1]])
    return np.ascontiguousarray(anti), np.ascontiguousarray(offset)
