"""The implicit integrator of the stiff paths: Radau IIA of order 5 (RADAU5), compiled, with
error-controlled adaptive steps, for M y' = f(t, y) (`_radau_numba.py`; ARCHITECTURE.md,
"Why the solver looks like this").

Model-independent: the model is its kernel data ``d`` and workspace ``w`` (the compiled
rates are chosen by the type of ``d``), its inputs a vectorised function of time tabulated
as piecewise polynomials between the breakpoints (`input_table.py`). Every breakpoint and
controller sample instant is a node no step straddles. Sampled controllers (``loop``, as
`gauss_sampled.SampledLoop`) are updated between calls of the compiled loop at each sample
instant from the state's elastic coordinates, their held voltages overwriting the input
columns ``held``. A model with known invariants (a forward system's momentum) passes its
``projection`` record: every accepted step's end and every output state is put back onto
them (`_radau_numba.model_project`), with the inputs' integrals from the table
(`input_table.integrals`) for the impulse of the loads.

Tolerances: component i's local error, times its weight w_i (1 unless the model passes
``weights``: `error_weights.py`), is kept below atol + rtol · its group's peak |y| (the
running maximum over the run so far of every component in the group: displacements,
velocities, …) by the step controller shared with the Gauss collocation
(`_step_control_numba.py`), with a conversion of the requested tolerance into the local one
(`local_tolerances`) so that the global error of the coordinates and rates is about rtol.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .gauss_sampled import SampledLoop
from .input_table import integrals, tabulate
from .solution import BLOW_UP, Progress

CHUNKS = 20  # calls of the compiled loop without controllers, progress reported between them


@dataclass
class RadauStop(Exception):
    """The run stopped at ``t`` (s): ``why`` is "blow-up" (|y| beyond BLOW_UP), "stalled"
    (the step collapsed) or "box" (a step ended with a component outside its ``box`` or a
    combination beyond its ``bounds``, at ``t``: `integrate_radau`); ``states``: the output rows reached before it (NaN after), ``y``:
    the last state (what a travel check reads to tell why it stopped)."""

    t: float
    why: str
    states: np.ndarray | None = None
    y: np.ndarray | None = None


def local_tolerances(rtol: float, atol: float) -> tuple[float, float]:
    """The local tolerances for a requested (global) rtol, atol. RADAU5 converts rtol into
    0.1 rtol^(2/3); measured, that lets the global error grow to ~10 rtol at rtol 1e-8
    (an oscillator over ten periods, tests/unit/test_radau.py; a servo arm's small response
    alike). rtol_local = 0.7 rtol^0.875 equals RADAU5's at rtol 1e-4 and keeps the global
    error near rtol from 1e-3 to 1e-10. atol stays an absolute floor, a tenth of the one
    asked for (RADAU5 scales it with rtol, which at rtol 1e-9 loosens it a hundredfold)."""
    return 0.7 * rtol ** 0.875, 0.1 * atol


def time_scale(t0: float, t1: float) -> float:
    """The time (s) below which two instants of a run from t0 to t1 count as one: 1e-9 of
    max(1 s, |t1|), but at most a millionth of the run (a run of a nanosecond keeps its
    two ends)."""
    return min(1e-9 * max(1.0, abs(t1)), 1e-6 * (t1 - t0))


def segment_nodes(t_out: np.ndarray, breaks: np.ndarray, loop: SampledLoop | None = None
                  ) -> np.ndarray:
    """The nodes (s) no step straddles: the run's ends, the inputs' breakpoints and the
    controllers' sample instants inside it."""
    t0, t1 = float(t_out[0]), float(t_out[-1])
    scale = time_scale(t0, t1)
    inner = breaks[(breaks > t0 + scale) & (breaks < t1 - scale)]
    samples = np.zeros(0)
    if loop is not None:
        samples = loop.grid[:-1]
        samples = samples[(samples > t0 + scale) & (samples < t1 - scale)]
    nodes = np.union1d(np.union1d([t0, t1], inner), samples)
    nodes = nodes[np.concatenate([[True], np.diff(nodes) > scale])]
    nodes[-1] = t1
    return nodes


def second_order_reduction(pairs: np.ndarray | None, size: int
                           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The iteration matrices' reduction (`_radau_numba._reduced_matrix`) for a state of
    ``size`` components whose rates at pairs[0] are the components pairs[1] exactly (a
    coordinate's rate is its velocity in the state): (rows, cols, vel), the rows (the
    velocities, then every component that is neither) and unknowns (the positions, then
    the same others) kept, and each unknown's velocity (−1: none). Solving the rate stages
    only, the factorisations are of half the size (RADAU5's second-order structure, Hairer
    and Wanner §IV.8). None: no reduction (empty arrays)."""
    none = np.zeros(0, dtype=np.int64)
    if pairs is None or np.size(pairs) == 0:
        return none, none, none
    pos, vel = (np.asarray(a, dtype=np.int64) for a in pairs)
    if pos.shape != vel.shape or np.unique(np.concatenate([pos, vel])).size != 2 * pos.size \
            or pos.min() < 0 or max(pos.max(), vel.max()) >= size:
        raise ValueError("second_order pairs must be distinct positions and velocities "
                         f"among the {size} state components")
    others = np.setdiff1d(np.arange(size), np.concatenate([pos, vel]))
    return (np.concatenate([vel, others]), np.concatenate([pos, others]),
            np.concatenate([vel, np.full(others.size, -1, dtype=np.int64)]))


def integrate_radau(d: object, w: object, y0: np.ndarray, t_out: np.ndarray,
                    inputs: Callable[[np.ndarray], np.ndarray], breaks: np.ndarray,
                    rtol: float, atol: float, groups: np.ndarray, hmax: float = np.inf,
                    mass: np.ndarray | None = None, on_progress: Progress | None = None,
                    loop: SampledLoop | None = None, held: slice = slice(0, 0),
                    z: slice = slice(0, 0), projection: object | None = None,
                    steps: list | None = None, weights: np.ndarray | None = None,
                    recent: bool = False, box: tuple | None = None,
                    bounds: np.ndarray | None = None, second_order: np.ndarray | None = None
                    ) -> tuple[np.ndarray, dict[str, int]]:
    """States (len(t_out), len(y0)) at t_out from y0 at t_out[0], and step statistics.

    inputs(t) → input rows (len(t), columns); breaks: times (s) where an input is not
    smooth; groups (len(y0),) the group index of each component (its error is relative to
    the group's peak), weights (len(y0),) its error weight (None: all 1;
    `error_weights.py`); mass: M (None: the identity); hmax: the longest step (s);
    projection: the model's record of known invariants (`_radau_numba.model_project`; its
    ``active`` components empty: none), onto which every accepted step and output state is
    put. ``recent``: each step sized from the largest error of the last three accepted
    steps (each scaled to its size), not of the last alone (`_radau_numba.MEMORY`: for runs
    where a mode the step does not resolve makes the estimate swing with its phase).
    ``steps``: a list to which every accepted step is appended as (t (s) at its start, h
    (s), segment index, y at its start, y at its end (projected), its stage increments z
    (3, len(y0)), Y_i = y + z_i): the step sequence that the sensitivities
    (`radau_sensitivity.py`) differentiate. ``box``: (columns, lo, hi), components
    y[columns[j]] that must stay in [lo[j], hi[j]] (a travel): the run stops at the first
    accepted step that ends outside (None: no such component). ``bounds`` (r, len(y0) + 1):
    linear combinations of the state, each row's coefficients then the bound of its
    magnitude, that stop the run alike where an accepted step ends beyond one (None: none).
    ``second_order`` (2, k): components whose rates are other components exactly
    (f[second_order[0]] = y[second_order[1]]: coordinates and their velocities; with the
    identity mass only): the linear systems are solved for the rest only
    (`second_order_reduction`). Raises RadauStop."""
    from ._radau_numba import (
        EXPONENT,
        F0_OK,
        FACCON,
        FIRST,
        GROW,
        H_OLD,
        N_ST,
        NEXT_OUT,
        RECENT,
        SEG,
        H,
        X,
        model_functions,
        radau_advance,
    )
    from ._step_control_numba import step_control

    if np.size(y0) == 0 and loop is None:  # every coordinate known: nothing to integrate
        return np.empty((t_out.size, 0)), dict.fromkeys(
            ("steps", "rejected_steps", "rhs_evaluations", "jacobians", "factorisations"), 0)
    t0, t1 = float(t_out[0]), float(t_out[-1])
    scale = time_scale(t0, t1)
    nodes = segment_nodes(t_out, breaks, loop)
    tab = tabulate(inputs, nodes)
    on = projection is not None and projection.active.size > 0  # type: ignore[attr-defined]
    itab = integrals(tab) if on else (np.zeros((1, 1, 1)), np.zeros((1, 1)))
    project = (on, itab, np.empty(tab[2].shape[2]))
    limits = np.empty((2, y0.size))  # each component's range: ±BLOW_UP, a travel's ends
    limits[0], limits[1] = -BLOW_UP, BLOW_UP
    if box is not None:
        columns = np.asarray(box[0], dtype=np.int64)
        limits[0, columns] = np.maximum(-BLOW_UP, box[1])
        limits[1, columns] = np.minimum(BLOW_UP, box[2])
    bounds = (np.zeros((0, y0.size + 1)) if bounds is None
              else np.ascontiguousarray(bounds, dtype=float))
    model = model_functions(d, w, projection if on else ())  # d, w, projection: kept alive
    m = y0.size
    groups = np.ascontiguousarray(groups, dtype=np.int64)
    rtol_local, atol_local = local_tolerances(rtol, atol)
    control = step_control(groups, weights, int(groups.max(initial=0)) + 1, rtol_local,
                           atol_local, EXPONENT, GROW)
    np.maximum.at(control.peak, groups, np.abs(y0))
    st = np.zeros(N_ST)
    st[X], st[H], st[FACCON], st[FIRST], st[NEXT_OUT] = t0, min(1e-5, hmax), 1.0, 1.0, 1.0
    st[F0_OK] = 0.0
    st[RECENT] = 1.0 if recent else 0.0
    if second_order is not None and mass is not None:
        raise ValueError("second_order needs the identity mass (mass = None)")
    reduced = second_order_reduction(second_order, m)
    r = reduced[0].size or m  # the iteration matrices' size
    ws = (np.empty((m, m)), np.empty((r, r)), np.empty((r, r), dtype=np.complex128),
          np.empty(r, dtype=np.int64), np.empty(r, dtype=np.int64),
          *(np.empty(m) for _ in range(11)), np.empty(m, dtype=np.complex128),
          np.empty(tab[2].shape[2]), np.empty(m), np.empty(m), np.empty(r),
          np.empty(r, dtype=np.complex128))
    cont = np.zeros((m, 4))
    identity = mass is None
    M = np.eye(1) if mass is None else np.ascontiguousarray(mass, dtype=float)
    states = np.full((t_out.size, m), np.nan)
    states[0] = y0
    y = np.array(y0, dtype=float)
    if loop is not None:
        loop.start()
        at = np.searchsorted(nodes, loop.grid[:-1] - scale)  # sample k starts at nodes[at[k]]
        stops = [(nodes[at[k + 1]] if k + 1 < at.size else t1) for k in range(at.size)]
    elif on_progress is not None:
        stops = list(np.linspace(t0, t1, CHUNKS + 1)[1:])
    else:  # one call: the steps do not depend on where a call stops
        stops = [t1]
    held_columns = np.array([held.start or 0, held.stop or 0] if loop is not None else [0, 0],
                            dtype=np.int64)
    held_values = np.zeros(max(1, held_columns[1] - held_columns[0]))
    for k, stop in enumerate(stops):
        if loop is not None:
            held_values[:] = loop.update(k, y[z])
            st[F0_OK] = 0.0  # the held voltages changed: f at the step's start too
        t_stop = float(stop) - (0.0 if stop == t1 else 0.5 * scale)
        if steps is None:
            status = radau_advance(model, M, identity, tab, nodes, held_values, held_columns,
                                   t_stop, hmax, control, t_out, states, y, st, ws, cont,
                                   project, limits, bounds, reduced)
        else:  # one accepted step per call (the loop resumes where it stopped: same steps)
            status = 0
            while status == 0 and st[X] < t_stop:
                start, seg, y_start = float(st[X]), int(st[SEG]), y.copy()
                status = radau_advance(model, M, identity, tab, nodes, held_values,
                                       held_columns, min(np.nextafter(start, np.inf), t_stop),
                                       hmax, control, t_out, states, y, st, ws, cont, project,
                                       limits, bounds, reduced)
                if status == 0:  # ws[6:9]: the accepted step's stage increments z1, z2, z3
                    steps.append((start, float(st[H_OLD]), seg, y_start, y.copy(),
                                  np.array(ws[6:9])))
        if status != 0:
            why = "stalled" if status != 1 else (
                "box" if np.all(np.abs(y) < BLOW_UP) else "blow-up")  # (NaN: a blow-up)
            raise RadauStop(float(st[X]), why, states, y.copy())
        if on_progress is not None:
            on_progress(float(st[X]))
    if loop is not None:
        loop.update(loop.grid.size - 1, y[z])  # the records at t_end
    from ._radau_numba import ACCEPTED, JACOBIANS, LUS, RATES, REJECTED

    stats = {"steps": int(st[ACCEPTED]), "rejected_steps": int(st[REJECTED]),
             "rhs_evaluations": int(st[RATES]), "jacobians": int(st[JACOBIANS]),
             "factorisations": int(st[LUS])}
    return states, stats
