"""The closed-loop integrator of prescribed-joint runs: Lawson on a tabulated state matrix
(``lawson.py``) whose state carries the held actuator voltages, with the sampled controllers
updated inside the compiled loop (docs/closed_loop.md).

With prescribed joints the plant is linear in z: over a sample interval with the voltages V
held, ż, z̈ = M⁻¹(−K z − C ż + f + B V) is the prescribed model with the constant input V, so
the state [z, ż, 1, V] with V̇ = 0 keeps the prescribed integrator as it is: the table holds
M⁻¹[−K, −C, f, B], the grid is the output times plus every sample instant, and at each grid
point the compiled loop runs the controllers that sample there and sets V. Python callables
are called between calls of the compiled loop, at their own samples. Error control as in
``lawson.py``: the run with half as many steps must agree (Richardson); the controllers see
the same pre-drawn noise in both runs.
"""

from __future__ import annotations

import copy
import itertools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..dynamics.controllers import ControlData, ControlWork, control_work, readings
from ..errors import SimulationError, UnstableLoop
from ..model import Controller, FunctionController
from .batched_expm import expm_balanced
from .coefficient_table import CoefficientTable, RoughCoefficients, tabulate
from .magnus import agree, initial_step, richardson_error
from .solution import Progress, StepReach, unreached

_MAX_HALVINGS = 10
_ASSEMBLIES_PER_STEP = 4
_INTERVALS_PER_CALL = 4096  # progress is reported between calls of the compiled loop


@dataclass(frozen=True)
class PythonLoop:
    """The Python callables of a run: per controller its grid points, sensor rows (inputs,
    n) over z, pre-drawn noise (samples, inputs) and actuator indices of its outputs."""

    controllers: Sequence[FunctionController]
    points: Sequence[np.ndarray]
    rows: Sequence[np.ndarray]
    noise: Sequence[np.ndarray]
    outputs: Sequence[np.ndarray]


@dataclass(frozen=True)
class ClosedLoopRun:
    """States [z, ż, 1, V] and z̈ on the grid, the controller records on the grid
    (ControlWork), the Python controllers' commands (grid, outputs) each, and stats."""

    states: np.ndarray
    acc: np.ndarray
    work: ControlWork
    python_commands: list[np.ndarray]
    stats: dict
    estimate: float = float("nan")  # the accepted run's Richardson error estimate
    reach: StepReach | None = None  # of the tips over every step (``bounds``)


def integrate_closed_loop(rows: Callable[[np.ndarray], np.ndarray], n: int, n_act: int,
                          keys: Callable[[np.ndarray], np.ndarray] | None, breaks: np.ndarray,
                          max_frequency: float, t_out: np.ndarray, grid: np.ndarray,
                          rtol: float, atol: float, control: ControlData,
                          python: PythonLoop, on_progress: Progress | None = None,
                          start: np.ndarray | None = None,
                          bounds: np.ndarray | None = None) -> ClosedLoopRun:
    """Integrate from rest over ``grid`` (output times ∪ sample instants) and check the
    error at the outputs ``t_out``. ``rows(times)``: M⁻¹[−K, −C, f, B] (nt, n, 2n+1+n_act).
    ``start``: z at t = 0 (n,), default undeformed; ``bounds`` (r, 2n+1): rows over
    [z, ż, 1] read at every step (`solution.tip_bounds`; the run's ``reach``)."""
    first_step = initial_step(max_frequency) * min(1.0, (rtol / 1e-4) ** 0.25)
    substeps = 2 * max(1, int(np.ceil(np.diff(grid).max() / (2 * first_step))))
    try:
        table = tabulate(rows, grid, keys, tolerance=rtol,
                         budget=_ASSEMBLIES_PER_STEP * substeps, breaks=breaks)
    except RoughCoefficients:
        raise SimulationError("closed loops need smooth joint motions (profiles): the "
                              "coefficients of this motion are too rough to tabulate "
                              "(measured angles?)") from None
    out = np.searchsorted(grid, t_out - 1e-12 * max(1.0, t_out[-1]))
    coarse = _solve(table, n, n_act, grid, substeps // 2, control, python, None, start, bounds)
    for _ in range(_MAX_HALVINGS):
        fine = _solve(table, n, n_act, grid, substeps, control, python, on_progress, start,
                      bounds)
        s_f, s_c = fine.states[out, :2 * n], coarse.states[out, :2 * n]
        if agree(s_f, s_f, s_c, n, rtol, atol):
            fine.stats.update(steps_per_grid_interval=substeps, table_blocks=len(table),
                              grid_points=int(grid.size))
            return replace(fine, estimate=richardson_error(s_f, s_c, n))
        coarse = fine
        substeps *= 2
    raise SimulationError(
        f"the closed-loop integration did not reach rtol = {rtol:g}, atol = {atol:g} with "
        f"{substeps} steps per grid interval; loosen the tolerances")


def _propagators(table: CoefficientTable, n: int, n_act: int, grid: np.ndarray,
                 substeps: int) -> np.ndarray:
    """exp(Δt Ã)ᵀ (static blocks) or exp(h/2 Ã_ref)ᵀ (moving), Ã the generator of
    [z, ż, 1, V]: [[0, I, 0, 0], [rows], [0 …]]."""
    m = 2 * n + 1 + n_act
    dt = (grid[table.last] - grid[table.first]) / (table.last - table.first)
    factor = np.where(table.static, dt, 0.5 * dt / substeps)
    A = np.zeros((len(table), m, m))
    A[:, :n, n:2 * n] = np.eye(n)
    A[:, n:2 * n, :] = table.reference
    scale = np.sqrt(max(np.abs(table.reference[:, :, :n]).max(), 1.0))
    E = expm_balanced(A * factor[:, None, None], n, scale)
    return np.ascontiguousarray(np.swapaxes(E, 1, 2))


def _solve(table: CoefficientTable, n: int, n_act: int, grid: np.ndarray, substeps: int,
           control: ControlData, python: PythonLoop, on_progress: Progress | None,
           start: np.ndarray | None = None, bounds: np.ndarray | None = None
           ) -> ClosedLoopRun:
    from ._closed_loop_numba import closed_loop_intervals

    ET = _propagators(table, n, n_act, grid, substeps)
    polyT = np.ascontiguousarray(np.swapaxes(table.poly, 2, 3))
    referenceT = np.ascontiguousarray(np.swapaxes(table.reference, 1, 2))
    block_of = np.repeat(np.arange(len(table)), table.last - table.first).astype(np.int64)
    m = 2 * n + 1 + n_act
    states = np.empty((grid.size, m))
    acc = np.zeros((grid.size, n))
    u = np.zeros(m)
    u[2 * n] = 1.0
    limits = np.zeros((0 if bounds is None else bounds.shape[0], m))
    if bounds is not None:
        limits[:, :2 * n + 1] = bounds  # the held voltages do not enter
    reach = unreached(limits)  # no rows without bounds
    if start is not None:
        u[:n] = start
    work = control_work(control)
    functions = [copy.deepcopy(c.function) for c in python.controllers]  # stateful callables
    held = [np.zeros(len(c.outputs)) for c in python.controllers]
    commands = [np.zeros((grid.size, len(c.outputs))) for c in python.controllers]
    counts = [0] * len(functions)
    stops = np.union1d(np.concatenate([np.asarray(p, dtype=np.int64) for p in python.points]
                                      + [np.array([], dtype=np.int64)]),
                       np.arange(0, grid.size - 1, _INTERVALS_PER_CALL))
    stops = np.append(stops[stops < grid.size - 1], grid.size - 1).astype(np.int64)
    for a, b in itertools.pairwise(stops):
        for j, c in enumerate(python.controllers):  # callables sampling at grid point a
            if counts[j] < python.points[j].size and python.points[j][counts[j]] == a:
                y = readings(c, python.rows[j], u[:n], counts[j], python.noise[j])
                held[j] = call_controller(c, functions[j], float(grid[a]), y)
                counts[j] += 1
        work.py_held[:] = 0.0
        for j in range(len(functions)):
            np.add.at(work.py_held, python.outputs[j], held[j])
            commands[j][a:] = held[j]
        bad = closed_loop_intervals(u, n, grid, int(a), int(b), block_of, table.first,
                                    table.last, table.static, table.pieces, table.lower,
                                    table.upper, polyT, referenceT, ET, substeps, states, acc,
                                    control, work, limits, reach.peak, reach.beyond)
        if bad >= 0:
            raise UnstableLoop(float(grid[bad]), "the response grows without bound", int(bad),
                               states[:bad + 1], work)
        if on_progress is not None:
            on_progress(float(grid[b]))
    acc[0] = table.poly[0, 0] @ states[0]
    for a, b, A in zip(table.first[table.static], table.last[table.static],
                       table.reference[table.static]):
        acc[a + 1: b + 1] = states[a + 1: b + 1] @ A.T  # resting: z̈ = A y, A constant
    return ClosedLoopRun(states, acc, work, commands, {},
                         reach=None if bounds is None else reach)


def call_controller(controller: Controller, function: Callable, t: float, y: np.ndarray) -> np.ndarray:
    """The callable's output at one sample, checked: one finite number per output."""
    name = controller.name
    try:
        out = np.asarray(function(t, y), dtype=float).reshape(-1)
    except Exception as exc:
        raise SimulationError(f"controller {name!r} raised at t = {t:.6g} s: "
                              f"{type(exc).__name__}: {exc}") from exc
    expected = len(controller.outputs)  # type: ignore[union-attr]
    if out.size != expected:
        raise SimulationError(f"controller {name!r} returned {out.size} values at t = {t:.6g} "
                              f"s; it has {expected} outputs")
    if not np.all(np.isfinite(out)):
        raise SimulationError(f"controller {name!r} returned a non-finite voltage at "
                              f"t = {t:.6g} s")
    return out
