"""Sensitivities of a nonlinear run with prescribed joints (Gauss collocation) to numeric
scenario fields: the derivative of what the run computed, on its own accepted steps
(`solvers.gauss_sensitivity`).

Pieces from differences, each at a fixed state or time, never of a run (fields moved by
±δ as in `sensitivities.prepare_fields`):

* ∂R/∂p at every stage: the compiled residual of the system built at the moved field,
  with its own stage inputs (a motion's angle moves the prescribed node angles), at the
  replayed stage states;
* ∂q0/∂p: the moved systems' initial coordinates (a static equilibrium start);
* ∂channel/∂p: the outputs (the quintic Hermite interpolant of the step ends with the
  moved system's accelerations there, `gauss.node_solution`) and the channels
  (`nonlinear.nonlinear_values`) of the moved scenario at the step ends moved along their
  sensitivities.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..model import Scenario
from ..solvers import Solution
from .common import PathRun, Progress


class Refused(ValueError):
    """A run or field the nonlinear sensitivities cannot take (reported as a
    `sensitivities.SensitivityError`)."""


def _system(scenario: Scenario) -> Any:
    from ..dynamics.nonlinear import NonlinearSystem

    settings = scenario.settings
    return NonlinearSystem(scenario.chain, actuators=scenario.actuators,
                           gravity=settings.gravity, initial=settings.initial)


def run_with_nonlinear_sensitivities(scenario: Scenario, fields: list, t: np.ndarray,
                                     on_progress: Progress, shapes: bool
                                     ) -> tuple[PathRun, dict[str, np.ndarray]]:
    """The nonlinear prescribed run of ``scenario`` (`nonlinear.run_nonlinear`) and, per
    channel, its derivatives (nt, K) in the fields (`sensitivities._Field`)."""
    from ..solvers._gauss_sensitivity_numba import residuals
    from ..solvers.gauss import NEWTON_MAX, NEWTON_TOL, ROUND_OFF, node_solution
    from ..solvers.gauss_sensitivity import gauss_tangent, replay
    from ..solvers.gauss_steps import NODES, newton_settings
    from .nonlinear import nonlinear_values, run_nonlinear
    from .sensitivities import _same_model

    nodes: list = []
    run = run_nonlinear(scenario, t, on_progress, shapes, step_ends=nodes)
    if not nodes:
        raise Refused("sensitivities: every link is rigid: there is nothing to differentiate "
                      "through the integrator")
    t_nodes, q, v, parts = nodes[0]
    nominal = _system(scenario)
    systems = [[nominal if j == 0 or _same_model(sc, scenario) else _system(sc)
                for j, sc in zip(f.offsets, f.scenarios, strict=True)] for f in fields]
    for f, group in zip(fields, systems, strict=True):
        if any(s.n != nominal.n for s in group):
            raise Refused(f"sensitivities: {f.target.text} changes the number of elastic "
                          "coordinates")
    data = nominal.kernel_data()
    newton = newton_settings(NEWTON_TOL, NEWTON_MAX, ROUND_OFF * nominal.max_frequency**2,
                             False)
    steps = replay(data, lambda times: nominal.node_inputs(times).stage_inputs(), t_nodes, q,
                   v, parts, newton)
    stage_times = (steps.t[:, None] + NODES[None, :] * steps.h[:, None]).ravel()
    moved_rows = [[None if s is nominal else s.node_inputs(stage_times).stage_inputs()
                   for s in group] for group in systems]
    K, n = len(fields), nominal.n

    def forcing(index: np.ndarray, Q: np.ndarray, V: np.ndarray, X: np.ndarray
                ) -> np.ndarray:
        out = np.zeros((Q.shape[0], n, K))
        r = np.empty((Q.shape[0], n))
        for k, f in enumerate(fields):
            if all(s is nominal for s in systems[k]):
                continue  # a field the equations do not read
            for w, s, rows in zip(f.weights, systems[k], moved_rows[k], strict=True):
                residuals(s.kernel_data(), steps.rows if rows is None else rows, index, Q, V,
                          X, r)
                out[:, :, k] += (w / f.step) * r
        return out

    q0 = nominal.initial_coordinates()
    dy0 = np.zeros((n, K))
    for k, f in enumerate(fields):
        if any(s is not nominal for s in systems[k]):
            dy0[:, k] = sum(w * (s.initial_coordinates() if s is not nominal else q0)
                            for w, s in zip(f.weights, systems[k], strict=True)) / f.step
    dq, dv = gauss_tangent(steps, data, forcing, dy0, np.zeros((n, K)))
    channels: dict[str, list[np.ndarray]] = {name: [] for name in run.values}
    for k, f in enumerate(fields):
        total: dict[str, np.ndarray] = {}
        for j, w, sc, s in zip(f.offsets, f.weights, f.scenarios, systems[k], strict=True):
            moved = Solution(t, *node_solution(s, t_nodes, q + j * f.step * dq[:, :, k],
                                               v + j * f.step * dv[:, :, k], t), "gauss")
            values = nonlinear_values(sc, s, moved, s.joint_history(t))
            for name, value in values.items():
                total[name] = total.get(name, 0.0) + w * np.asarray(value, dtype=float)
        for name, column in channels.items():
            column.append(total[name] / f.step)
    return run, {name: np.stack(value, axis=-1) for name, value in channels.items()}


def refused(scenario: Scenario) -> str | None:
    """What keeps the nonlinear prescribed run of ``scenario`` from taking sensitivities,
    or None."""
    if scenario.controllers:
        return "controllers on the nonlinear model"
    return None
