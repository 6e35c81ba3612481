"""Sensitivities of a forward run (driven joints, moving base; first-order model, compiled
Radau IIA) to numeric scenario fields: the derivative of what the run computed, on its
own accepted steps (`solvers.radau_sensitivity`).

Pieces from differences, each at a fixed state or time, never of a run (fields moved by
±δ as in `sensitivities.prepare_fields`):

* ∂f/∂p at every stage: the compiled rates of the forward system assembled at the moved
  field, with its own input table (a drive's torque or a servo's reference moves the
  inputs), at the run's stage states;
* ∂y0/∂p: the moved scenarios' initial states (an equilibrium start, a base's initial
  velocity);
* the projection onto the known momentum (free or pinned base, cart), after each step and
  at each output: the moved scenario's projection of the state moved along its
  sensitivity;
* ∂channel/∂p: the forward path's channels (`forward.forward_run`) of the moved scenario
  at the states moved along their sensitivities.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import Scenario
from .common import PathRun, Progress


@dataclass
class _Model:
    """One scenario's forward system as the compiled kernels see it."""

    scenario: Scenario
    system: Any
    data: Any
    work: Any
    projection: Any
    y0: np.ndarray
    table: tuple
    integrals: tuple | None


def _model(scenario: Scenario, t: np.ndarray, nodes: np.ndarray | None) -> _Model:
    from ..dynamics._forward_numba import workspace
    from ..dynamics.forward_kernel import breakpoints, inputs, pack
    from ..dynamics.momentum_projection import projection, start_values
    from ..solvers.input_table import integrals, tabulate
    from ..solvers.radau import segment_nodes
    from .forward import forward_system

    system = forward_system(scenario)
    data = pack(system)
    work = workspace(data, len(system.servos))
    y0 = system.initial_state()
    u0 = inputs(system, t[:1])[0]
    known = projection(system, data, float(t[0]), u0.size)
    if known.active.size:
        start_values(known, data, work, u0, y0, float(t[-1]))
    own = segment_nodes(t, breakpoints(system))
    if nodes is not None and not (own.shape == nodes.shape and np.all(own == nodes)):
        raise ValueError("moves a time where an input jumps")
    table = tabulate(lambda times: inputs(system, times), own)
    return _Model(scenario, system, data, work, known, y0, table,
                  integrals(table) if known.active.size else None)


def _rates(model: _Model) -> Any:
    from ..solvers._radau_numba import rates_at

    def rates(u: np.ndarray, Y: np.ndarray) -> np.ndarray:
        out = np.empty_like(Y)
        rates_at(model.data, model.work, np.ascontiguousarray(u), np.ascontiguousarray(Y), out)
        return out
    return rates


def _project(model: _Model, segment: int, t: float, y: np.ndarray) -> np.ndarray:
    """y projected onto the model's known momentum at time t (s) (`model_project`)."""
    from ..dynamics._momentum_numba import project
    from ..solvers.radau_sensitivity import table_rows

    seg = np.array([segment])
    times = np.array([t])
    u = table_rows(model.table, seg, times)[0]
    U = _integral_rows(model, seg, times)[0]
    out = np.array(y, dtype=float)
    project(model.data, model.work, model.projection, u, U, float(t), out)
    return out


def _integral_rows(model: _Model, segment: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The inputs' integrals from the start (`_radau_numba.input_integral`) at times."""
    a, b, _, first = model.table
    anti, offset = model.integrals  # type: ignore[misc]
    piece = np.clip(np.searchsorted(b, times, side="left"), first[segment],
                    first[segment + 1] - 1)
    x = (2.0 * times - (a[piece] + b[piece])) / (b[piece] - a[piece])
    T = np.polynomial.chebyshev.chebvander(x, anti.shape[1] - 1)
    return offset[piece] + np.einsum("nk,nkc->nc", T, anti[piece])


def run_with_forward_sensitivities(scenario: Scenario, fields: list, t: np.ndarray,
                                   on_progress: Progress, shapes: bool
                                   ) -> tuple[PathRun, dict[str, np.ndarray]]:
    """The forward run of ``scenario`` (`forward.run_forward`, compiled Radau IIA) and,
    per channel, its derivatives (nt, K) in the fields (`sensitivities._Field`)."""
    from ..solvers.forward import forward_solution
    from ..solvers.radau_sensitivity import (
        NODES,
        dense,
        output_steps,
        radau_tangent,
        step_sequence,
        table_rows,
    )
    from .forward import forward_run, run_forward
    from .sensitivities import SensitivityError

    records: list = []
    run = run_forward(scenario, t, on_progress, shapes, steps=records)
    nominal = _model(scenario, t, None)
    nodes = np.array([nominal.table[0][nominal.table[3][k]]
                      for k in range(nominal.table[3].size - 1)] + [t[-1]])
    moved: list[list[_Model]] = []
    for f in fields:
        try:
            moved.append([nominal if j == 0 else _model(sc, t, nodes)
                          for j, sc in zip(f.offsets, f.scenarios, strict=True)])
        except ValueError as error:
            raise SensitivityError(f"sensitivities: {f.target.text} {error}; the computed "
                                   "run is not differentiable in it on a fixed step "
                                   "sequence") from None
    if nominal.y0.size == 0:
        raise SensitivityError("sensitivities: this run has no state to differentiate")
    steps = step_sequence(records)
    K = len(fields)
    m = nominal.y0.size
    rates_of = [[_rates(md) for md in group] for group in moved]

    def forcing(times: np.ndarray, segment: np.ndarray, Y: np.ndarray) -> np.ndarray:
        out = np.zeros((Y.shape[0], m, K))
        for k, f in enumerate(fields):
            for w, md, rates in zip(f.weights, moved[k], rates_of[k], strict=True):
                out[:, :, k] += (w / f.step) * rates(table_rows(md.table, segment, times), Y)
        return out

    dy0 = np.zeros((m, K))
    for k, f in enumerate(fields):
        dy0[:, k] = sum(w * md.y0 for w, md in zip(f.weights, moved[k], strict=True)) / f.step
    projected = nominal.projection.active.size > 0

    def project_derivative(segment: int, time: float, y: np.ndarray, dy: np.ndarray
                           ) -> np.ndarray:
        out = np.empty_like(dy)
        for k, f in enumerate(fields):
            out[:, k] = sum(w * _project(md, segment, time, y + j * f.step * dy[:, k])
                            for j, w, md in zip(f.offsets, f.weights, moved[k], strict=True)
                            ) / f.step
        return out

    def project_step(s: int, y1: np.ndarray, dy1: np.ndarray) -> np.ndarray:
        raw = steps.y0[s] + steps.z[s, 2]
        return project_derivative(int(steps.segment[s]), float(steps.t[s] + steps.h[s]),
                                  raw, dy1)

    stage_u = table_rows(nominal.table, np.repeat(steps.segment, 3),
                         (steps.t[:, None] + steps.h[:, None] * NODES).ravel()
                         ).reshape(steps.h.size, 3, -1)
    starts, dz, ends = radau_tangent(steps, _rates(nominal), stage_u, forcing, dy0,
                                     project_step if projected else None)
    which, s = output_steps(steps, t)
    dstates = np.empty((t.size, m, K))
    dstates[0] = dy0
    dstates[1:] = dense(starts[which], dz[which], ends[which], s)
    if projected:  # the outputs are projected too
        raw = dense(steps.y0[which], steps.z[which], steps.y1[which], s)
        for i in range(1, t.size):
            dstates[i] = project_derivative(int(steps.segment[which[i - 1]]), float(t[i]),
                                            raw[i - 1], dstates[i])
    channels: dict[str, list[np.ndarray]] = {name: [] for name in run.values}
    states_out = _states(run, nominal)
    for k, f in enumerate(fields):
        total: dict[str, np.ndarray] = {}
        for j, w, md in zip(f.offsets, f.weights, moved[k], strict=True):
            y = states_out + j * f.step * dstates[:, :, k]
            solution, outputs = forward_solution(md.data, md.work, md.system, t, y,
                                                 dict(run.solution.stats),
                                                 None, run.solution.accuracy, md.projection)
            values = forward_run(md.scenario, md.system, t, solution, outputs, None, {}, {},
                                 False).values
            for name, v in values.items():
                total[name] = total.get(name, 0.0) + w * np.asarray(v, dtype=float)
        for name, column in channels.items():
            column.append(total[name] / f.step)
    return run, {name: np.stack(v, axis=-1) for name, v in channels.items()}


def _states(run: PathRun, model: _Model) -> np.ndarray:
    """The run's states y = [p_free, ṗ_free, z, ż, integrals] at the outputs."""
    sol = run.solution
    nu = len(model.system.free)
    return np.hstack([sol.q[:, :nu], sol.q_dot[:, :nu], sol.q[:, nu:], sol.q_dot[:, nu:],
                      sol.extra if sol.extra is not None else np.zeros((sol.t.size, 0))])


def check_forward(scenario: Scenario) -> None:
    """SensitivityError unless the forward run of ``scenario`` takes sensitivities: the
    compiled Radau IIA run without sampled controllers or closed loops."""
    from ..solvers.forward import FAST_METHOD
    from .sensitivities import SUPPORTED, SensitivityError

    what = None
    if scenario.controllers:
        what = "controllers on a forward run"
    elif scenario.closures:
        what = "closed kinematic loops"
    elif scenario.settings.method not in (FAST_METHOD, "lawson", "magnus"):
        what = f"a forward run with method = {scenario.settings.method!r}"
    if what is not None:
        raise SensitivityError(f"sensitivities: {what} do not compute sensitivities yet; "
                               f"they are computed on {SUPPORTED}")
