"""Prescribed joints, nonlinear model: NonlinearSystem → Gauss collocation → channels."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from ..channels.catalogue import joint_name, voltage_name
from ..channels.nonlinear import sensor_values, shape_values, tip_values
from ..dynamics.kinematics import JointHistory
from ..dynamics.nonlinear import NonlinearSystem
from ..errors import SimulationError
from ..model import Scenario
from ..solvers import Solution, rigid_solution
from ..solvers.gauss import solve_nonlinear
from ..solvers.gauss_sampled import SampledLoop, sample_grid
from .closed_loop import control_values, sensor_rows
from .common import PathRun, Progress


def nonlinear_system(scenario: Scenario) -> NonlinearSystem:
    """The nonlinear model of ``scenario`` with every joint prescribed."""
    settings = scenario.settings
    return NonlinearSystem(scenario.chain, actuators=scenario.actuators,
                           gravity=settings.gravity, initial=settings.initial)


def run_nonlinear(scenario: Scenario, t: np.ndarray, on_progress: Progress,
                  with_shapes: bool = True, step_ends: list | None = None) -> PathRun:
    """The nonlinear model's run with prescribed joints; ``step_ends`` as `solve_nonlinear`'s."""
    settings = scenario.settings
    system = nonlinear_system(scenario)
    hist = system.joint_history(t)  # fails early if a measured motion does not cover t
    loop = _sampled_loop(scenario, system, t) if scenario.controllers else None
    solution = (solve_nonlinear(system, t, settings.rtol, settings.step, on_progress=on_progress,
                                loop=loop, atol=settings.atol, step_ends=step_ends)
                if system.n else rigid_solution(t, "gauss"))
    values = nonlinear_values(scenario, system, solution, hist, loop)
    shapes = shape_values(system, solution, hist) if with_shapes else ()
    return PathRun(solution, values, shapes=shapes,
                   metadata={"path": "prescribed", "elastic_coordinates": system.n,
                             **({"controllers": len(scenario.controllers)} if loop else {})})


def nonlinear_values(scenario: Scenario, system: NonlinearSystem, solution: Solution,
                     hist: JointHistory, loop: SampledLoop | None = None
                     ) -> dict[str, np.ndarray]:
    """The channels of a prescribed nonlinear run from its solution at the output times."""
    t = solution.t
    torque = system.joint_torques(t, solution.q, solution.q_dot, solution.q_ddot, hist)
    values = sensor_values(system, solution, scenario.sensors, hist)
    for k in range(len(scenario.chain.links)):
        values[joint_name(k, "angle")] = hist.angle[:, k]
        values[joint_name(k, "torque")] = torque[:, k]
    values.update(tip_values(system, solution, hist))
    if loop is None:
        volts = system.voltages(t)  # open loop: the commanded voltages, clipped
        values.update({voltage_name(a.name): volts[:, j]
                       for j, a in enumerate(system.actuators)})
    else:  # the held voltages, commands and controller states at the outputs
        held = np.searchsorted(loop.grid, t + 1e-9 * max(1.0, t[-1]), side="right") - 1
        run = SimpleNamespace(work=loop.work, python_commands=loop.commands)
        values.update(control_values(scenario, run, np.clip(held, 0, loop.grid.size - 1),
                                      loop.python_index))
    return values


def _sampled_loop(scenario: Scenario, system: NonlinearSystem, t: np.ndarray) -> SampledLoop:
    """The scenario's controllers on their sample grid (solvers/gauss_sampled.py)."""
    if system.n == 0:
        raise SimulationError("controllers need an elastic link: every link is rigid")
    grid = sample_grid(scenario.controllers, float(t[-1]))
    return SampledLoop(scenario.controllers, scenario.actuators,
                       sensor_rows(scenario, system.modal, [a.coords for a in system.arcs],
                                   system.n, "nonlinear"),
                       grid, system.voltages(grid))


