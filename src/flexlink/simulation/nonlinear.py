"""Prescribed joints, nonlinear model: NonlinearSystem → Gauss collocation → channels."""

from __future__ import annotations

import numpy as np

from ..channels.catalogue import joint_name, voltage_name
from ..channels.nonlinear import sensor_values, shape_values, tip_values
from ..dynamics.nonlinear import NonlinearSystem
from ..model import Scenario
from ..solvers import rigid_solution
from ..solvers.gauss import solve_nonlinear
from .common import PathRun, Progress


def run_nonlinear(scenario: Scenario, t: np.ndarray, on_progress: Progress,
                  with_shapes: bool = True) -> PathRun:
    settings = scenario.settings
    system = NonlinearSystem(scenario.chain, actuators=scenario.actuators)
    hist = system.joint_history(t)  # fails early if a measured motion does not cover t
    solution = (solve_nonlinear(system, t, settings.rtol, settings.step, on_progress=on_progress)
                if system.n else rigid_solution(t, "gauss"))
    torque = system.joint_torques(t, solution.q, solution.q_dot, solution.q_ddot, hist)
    values = sensor_values(system, solution, scenario.sensors, hist)
    for k in range(len(scenario.chain.links)):
        values[joint_name(k, "angle")] = hist.angle[:, k]
        values[joint_name(k, "torque")] = torque[:, k]
    values.update(tip_values(system, solution, hist))
    volts = system.voltages(t)  # open loop: the commanded voltages, clipped
    values.update({voltage_name(a.name): volts[:, j] for j, a in enumerate(system.actuators)})
    shapes = shape_values(system, solution, hist) if with_shapes else ()
    return PathRun(solution, values, shapes=shapes,
                   metadata={"path": "prescribed", "elastic_coordinates": system.n})
