"""Sensitivities of a nonlinear run (Gauss collocation; prescribed joints, or driven joints
and a moving base) to numeric scenario fields: the derivative of what the run computed, on
its own accepted steps (`solvers.gauss_sensitivity`).

Pieces from differences, each at a fixed state or time, never of a run (fields moved by
±δ as in `sensitivities.prepare_fields`):

* ∂R/∂p at every stage: the compiled residual of the system built at the moved field,
  with its own stage inputs (a motion's angle moves the prescribed node angles, a drive's
  amplitude the input rows), at the replayed stage states;
* ∂y0/∂p: the moved systems' initial states (a static equilibrium start, a base's initial
  rate);
* ∂channel/∂p: the outputs (the quintic Hermite interpolant of the step ends with the
  moved system's accelerations there: `gauss.node_solution`, `gauss_forward.node_solution`)
  and the channels (`nonlinear.nonlinear_values`,
  `nonlinear_forward.nonlinear_forward_values`) of the moved scenario at the step ends
  moved along their sensitivities; the field's own part (at the run's states) over a
  fourth-order stencil 100 times wider (`WIDE_STEP`), since the solved
  accelerations' round-off over δ would show in a held joint's torque.
"""

from __future__ import annotations

from functools import partial
from typing import Any

import numpy as np

from ..model import Scenario
from ..solvers import Solution
from .common import PathRun, Progress

STATE_STEP = 1e-3  # of the states' size: the step of the channel map's state derivative
# The channels read accelerations solved from the moved equations, whose round-off (~1e-11
# of a held joint's torque on a free base) a difference over the field's step amplifies to
# 1e-5 of the torque's derivative: the field's own part of its channels takes a fourth-order
# central stencil (offset, weight) over WIDE_STEP times that step (its truncation ~1e-12),
# on scenarios `sensitivities.prepare_fields` builds for the nonlinear model.
WIDE_STEP = 100.0
WIDE_OFFSETS = ((1, 8.0 / 12.0), (-1, -8.0 / 12.0), (2, -1.0 / 12.0), (-2, 1.0 / 12.0))


class Refused(ValueError):
    """A run or field the nonlinear sensitivities cannot take (reported as a
    `sensitivities.SensitivityError`)."""


class _Prescribed:
    """The nonlinear model with every joint prescribed (`NonlinearSystem`, unknowns q)."""

    @staticmethod
    def system(scenario: Scenario) -> Any:
        from .nonlinear import nonlinear_system

        return nonlinear_system(scenario)

    @staticmethod
    def run(scenario: Scenario, t: np.ndarray, on_progress: Progress, shapes: bool,
            step_ends: list) -> PathRun:
        from .nonlinear import run_nonlinear

        return run_nonlinear(scenario, t, on_progress, shapes, step_ends=step_ends)

    @staticmethod
    def newton(system: Any) -> Any:
        from ..solvers.gauss import NEWTON_MAX, NEWTON_TOL, ROUND_OFF
        from ..solvers.gauss_steps import newton_settings

        return newton_settings(NEWTON_TOL, NEWTON_MAX, ROUND_OFF * system.max_frequency**2,
                               False)

    @staticmethod
    def size(system: Any) -> int:
        return int(system.n)

    @staticmethod
    def stage_inputs(system: Any, times: np.ndarray) -> Any:
        return system.node_inputs(times).stage_inputs()

    @staticmethod
    def initial(system: Any) -> tuple[np.ndarray, np.ndarray]:
        return system.initial_coordinates(), np.zeros(system.n)

    @staticmethod
    def inputs_jump(system: Any) -> np.ndarray:
        from ..dynamics.histories import input_breakpoints

        return np.asarray(input_breakpoints(system.chain.joints, system.actuators),
                          dtype=float)

    @staticmethod
    def jacobians(data: Any, rows: Any) -> Any:
        from ..solvers.gauss_sensitivity import prescribed_jacobians

        return prescribed_jacobians(data, rows)

    @staticmethod
    def values(scenario: Scenario, system: Any, t_nodes: np.ndarray, y: np.ndarray,
               v: np.ndarray, t: np.ndarray) -> dict[str, np.ndarray]:
        from ..solvers.gauss import node_solution
        from .nonlinear import nonlinear_values

        solution = Solution(t, *node_solution(system, t_nodes, y, v, t), "gauss")
        return nonlinear_values(scenario, system, solution, system.joint_history(t))


class _Forward(_Prescribed):
    """The nonlinear model with rigid coordinates (`NonlinearForwardSystem`, unknowns
    [q, p_free, servo integrals])."""

    @staticmethod
    def system(scenario: Scenario) -> Any:
        from .nonlinear_forward import nonlinear_forward_system

        return nonlinear_forward_system(scenario)

    @staticmethod
    def run(scenario: Scenario, t: np.ndarray, on_progress: Progress, shapes: bool,
            step_ends: list) -> PathRun:
        from .nonlinear_forward import run_nonlinear_forward

        return run_nonlinear_forward(scenario, t, on_progress, shapes, step_ends=step_ends)

    @staticmethod
    def newton(system: Any) -> Any:
        from ..solvers.gauss import NEWTON_MAX, ROUND_OFF
        from ..solvers.gauss_forward import NEWTON_TOL_FORWARD
        from ..solvers.gauss_steps import newton_settings

        return newton_settings(NEWTON_TOL_FORWARD, NEWTON_MAX,
                               ROUND_OFF * system.max_frequency**2, True)

    @staticmethod
    def size(system: Any) -> int:
        return int(system.n_y)

    @staticmethod
    def stage_inputs(system: Any, times: np.ndarray) -> Any:
        from ..dynamics.nonlinear_kernel import stage_rows

        return stage_rows(*system.stage_inputs(times))

    @staticmethod
    def initial(system: Any) -> tuple[np.ndarray, np.ndarray]:
        return system.initial_state()

    @staticmethod
    def inputs_jump(system: Any) -> np.ndarray:
        from ..dynamics.forward_kernel import breakpoints

        return np.asarray(breakpoints(system.loads), dtype=float)

    @staticmethod
    def jacobians(data: Any, rows: Any) -> Any:
        return None  # differences of the residual (applied loads on the rigid state)

    @staticmethod
    def values(scenario: Scenario, system: Any, t_nodes: np.ndarray, y: np.ndarray,
               v: np.ndarray, t: np.ndarray) -> dict[str, np.ndarray]:
        from ..solvers.gauss_forward import node_solution
        from .nonlinear_forward import nonlinear_forward_values

        return nonlinear_forward_values(scenario, system,
                                        node_solution(system, t_nodes, y, v, t))


def run_with_nonlinear_sensitivities(scenario: Scenario, fields: list, t: np.ndarray,
                                     on_progress: Progress, shapes: bool
                                     ) -> tuple[PathRun, dict[str, np.ndarray]]:
    """The nonlinear run of ``scenario`` (prescribed joints: `nonlinear.run_nonlinear`;
    rigid coordinates: `nonlinear_forward.run_nonlinear_forward`) and, per channel, its
    derivatives (nt, K) in the fields (`sensitivities._Field`)."""
    from ..solvers._gauss_numba import residual_model
    from ..solvers._gauss_sensitivity_numba import residuals
    from ..solvers.gauss_sensitivity import gauss_tangent, replay
    from ..solvers.gauss_steps import NODES
    path = _Forward if scenario.is_forward else _Prescribed
    nodes: list = []
    run = path.run(scenario, t, on_progress, shapes, nodes)
    if not nodes:
        raise Refused("sensitivities: every link is rigid: there is nothing to differentiate "
                      "through the integrator")
    t_nodes, y, v, parts = nodes[0]
    nominal = path.system(scenario)
    systems = [[nominal if j == 0 or _same_system(sc, scenario) else path.system(sc)
                for j, sc in zip(f.offsets, f.scenarios, strict=True)] for f in fields]
    jumps = path.inputs_jump(nominal)
    for f, group in zip(fields, systems, strict=True):
        if any(path.size(s) != path.size(nominal) for s in group):
            raise Refused(f"sensitivities: {f.target.text} changes the number of unknowns")
        if any(not np.array_equal(path.inputs_jump(s), jumps) for s in group):
            raise Refused(f"sensitivities: {f.target.text} moves a time where an input jumps; "
                          "the computed run is not differentiable in it on a fixed step "
                          "sequence")
    data = nominal.kernel_data()
    steps = replay(data, lambda times: path.stage_inputs(nominal, times), t_nodes, y, v,
                   parts, path.newton(nominal))
    stage_times = (steps.t[:, None] + NODES[None, :] * steps.h[:, None]).ravel()
    moved_rows = [[None if s is nominal else path.stage_inputs(s, stage_times)
                   for s in group] for group in systems]
    K, n = len(fields), path.size(nominal)

    def forcing(index: np.ndarray, Q: np.ndarray, V: np.ndarray, X: np.ndarray
                ) -> np.ndarray:
        out = np.zeros((Q.shape[0], n, K))
        r = np.empty((Q.shape[0], n))
        for k, f in enumerate(fields):
            if all(s is nominal for s in systems[k]):
                continue  # a field the equations do not read
            for w, s, rows in zip(f.weights, systems[k], moved_rows[k], strict=True):
                data_s = s.kernel_data()  # alive while its model (borrowed arrays) is used
                residuals(residual_model(data_s), steps.rows if rows is None else rows, index,
                          Q, V, X, r)
                out[:, :, k] += (w / f.step) * r
        return out

    start = path.initial(nominal)
    dy0, dv0 = np.zeros((n, K)), np.zeros((n, K))
    for k, f in enumerate(fields):
        if any(s is not nominal for s in systems[k]):
            for w, s in zip(f.weights, systems[k], strict=True):
                y0, v0 = start if s is nominal else path.initial(s)
                dy0[:, k] += w * y0 / f.step
                dv0[:, k] += w * v0 / f.step
    dy, dv = gauss_tangent(steps, data, forcing, dy0, dv0, path.jacobians(data, steps.rows))
    channels: dict[str, list[np.ndarray]] = {name: [] for name in run.values}
    nominal_values = None
    for k, f in enumerate(fields):
        total: dict[str, np.ndarray] = {}
        add = partial(_accumulate, total)
        # the field's own part, at the run's states (a link's shape functions, a sensor):
        # over the wide stencil where there is one (`WIDE_STEP`)
        if f.wide and not all(s is nominal for s in systems[k]):
            for (_, w), sc in zip(WIDE_OFFSETS, f.wide, strict=True):
                add(w / f.wide_step, path.values(sc, path.system(sc), t_nodes, y, v, t))
        else:
            for j, w, sc, s in zip(f.offsets, f.weights, f.scenarios, systems[k],
                                   strict=True):
                if j == 0:
                    if nominal_values is None:
                        nominal_values = path.values(scenario, nominal, t_nodes, y, v, t)
                    add(w / f.step, nominal_values)
                else:
                    add(w / f.step, path.values(sc, s, t_nodes, y, v, t))
        # the states' part: a fourth-order central stencil along the sensitivity, with a
        # step of STATE_STEP of the states' size (the channel maps lose about 1e-10 of a
        # joint torque to cancellation, which a step of the field's δ would amplify)
        size = float(max(np.abs(dy[:, :, k]).max(), np.abs(dv[:, :, k]).max()))
        if size > 0.0:
            h = STATE_STEP * max(float(np.abs(y).max()), float(np.abs(v).max())) / size
            for j, w in ((1, 8.0), (-1, -8.0), (2, -1.0), (-2, 1.0)):
                add(w / (12.0 * h), path.values(scenario, nominal, t_nodes,
                                                 y + j * h * dy[:, :, k],
                                                 v + j * h * dv[:, :, k], t))
        for name, column in channels.items():
            column.append(total.get(name, np.zeros(t.size)))
    return run, {name: np.stack(value, axis=-1) for name, value in channels.items()}


def _accumulate(total: dict[str, np.ndarray], weight: float,
                values: dict[str, np.ndarray]) -> None:
    """total += weight · values, channel by channel."""
    for name, value in values.items():
        total[name] = total.get(name, 0.0) + weight * np.asarray(value, dtype=float)


def _same_system(moved: Scenario, scenario: Scenario) -> bool:
    """Whether a moved scenario's nonlinear equations are the scenario's (a field of the
    sensors): the same chain, base, actuators, gravity and initial state."""
    a, b = moved.settings, scenario.settings
    try:
        return bool(moved.chain == scenario.chain and moved.base == scenario.base
                    and moved.actuators == scenario.actuators and a.gravity == b.gravity
                    and a.initial == b.initial)
    except ValueError:  # values holding arrays (a measured motion): compared as different
        return False


def refused(scenario: Scenario) -> str | None:
    """What keeps the nonlinear run of ``scenario`` from taking sensitivities, or None."""
    if scenario.controllers:
        return "controllers on the nonlinear model"
    if scenario.closures:
        return "closed kinematic loops on the nonlinear model"
    return None
