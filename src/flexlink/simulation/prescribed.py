"""Prescribed joints, first-order model: FirstOrderSystem → a linear integrator → channels."""

from __future__ import annotations

from collections.abc import Callable, Collection, Sequence
from functools import partial
from typing import Any

import numpy as np

from ..channels.catalogue import joint_name, tip_name, voltage_name
from ..channels.first_order import sensor_values, shape_values, tip_deflections, tip_values
from ..channels.shapes import LazyShapes, LinkShape
from ..dynamics.first_order import FirstOrderSystem
from ..dynamics.prescribed_kernel import CompiledFirstOrderSystem, joint_torques, solved_frames
from ..model import Scenario, Sensor
from ..solvers import PRESCRIBED_METHODS, LinearIntegrator, Solution, rigid_solution
from .accuracy import axial_load_parameter, hangs_on_elastic
from .common import PathRun, Progress, check_tip_deflection


def run_prescribed(scenario: Scenario, t: np.ndarray, on_progress: Progress,
                  with_shapes: bool = True, integrate: LinearIntegrator | None = None,
                  channels: bool = True, kept: Collection[str] | None = None,
                  system: CompiledFirstOrderSystem | None = None) -> PathRun:
    """``integrate``: the integrator instead of the one ``simulation.method`` names (the
    optimiser's runs on a fixed discretisation); ``channels``: False for the solution alone
    (no channels; the tip-deflection check that a diverged run fails still made); ``kept``:
    the only channels to compute (None: all), as `prescribed_readings`; ``system``: the
    scenario's `prescribed_system` if already built."""
    settings = scenario.settings
    system = system or prescribed_system(scenario, t)
    if system.n:
        integrate = integrate or PRESCRIBED_METHODS[settings.method]
        solution = system.shift_solution(
            integrate(system, t, settings.rtol, settings.atol, on_progress))
    else:  # every link rigid: the motion is prescribed, nothing to integrate
        solution = rigid_solution(t, settings.method)
    if not channels:
        check_tip_deflection(scenario.chain.links, solution.t,
                             tip_deflections(system, solution.q), settings.geometric_stiffening,
                             steps=solution.reach)
        return PathRun(solution, {}, metadata={"path": "prescribed"})
    values, shapes, validity, read_sensors = prescribed_readings(scenario, system, solution,
                                                                 with_shapes, kept=kept)
    if scenario.actuators:  # open loop: the commanded voltages, clipped
        volts = system.voltages(t)
        values.update({voltage_name(a.name): volts[:, j]
                       for j, a in enumerate(scenario.actuators)
                       if kept is None or voltage_name(a.name) in kept})
    return PathRun(solution, values, shapes=shapes, metadata={
        "path": "prescribed", "geometric_stiffening": settings.geometric_stiffening,
        "elastic_coordinates": system.n, **validity}, read_sensors=read_sensors)


def prescribed_system(scenario: Scenario, t: np.ndarray) -> CompiledFirstOrderSystem:
    """The scenario's first-order system, started as its settings say, for output times t
    (s)."""
    settings = scenario.settings
    system = CompiledFirstOrderSystem(scenario.chain, settings.geometric_stiffening,
                                      scenario.actuators, settings.gravity)
    system.joint_history(t)  # fail early if a measured motion does not cover [0, t_end]
    if system.n and settings.initial == "equilibrium":
        system.start_from(system.equilibrium(float(t[0])))
    return system


def prescribed_values(scenario: Scenario, system: FirstOrderSystem, solution: Solution,
                      with_shapes: bool, checked: bool = True
                      ) -> tuple[dict[str, np.ndarray], Sequence[LinkShape], dict[str, Any]]:
    """The channels of a prescribed-joint run (sensors, joint angles and torques, tips), the
    link shapes and the validity metadata (a SimulationError if the tips ran away; with
    ``checked`` False neither: channels of a state next to a checked run's)."""
    return prescribed_readings(scenario, system, solution, with_shapes, checked)[:3]


def prescribed_readings(scenario: Scenario, system: FirstOrderSystem, solution: Solution,
                        with_shapes: bool, checked: bool = True,
                        kept: Collection[str] | None = None
                        ) -> tuple[dict[str, np.ndarray], Sequence[LinkShape], dict[str, Any],
                                   Callable[[tuple[Sensor, ...]], dict[str, np.ndarray]]]:
    """`prescribed_values`, and the readings of any sensors on the same motion. ``kept``:
    the only channels to read (None: all), and then the validity check without the accuracy
    estimate (a diverged run fails the same; the metadata is the estimate alone)."""
    t, z = solution.t, solution.q
    hist = system.joint_history(t)
    # The frames along the solution, with T z, … per output time from the compiled kernel.
    frames = solved_frames(system, t, z, solution.q_dot, solution.q_ddot)
    links = scenario.chain.links
    validity: dict[str, Any] = {}
    if checked and kept is not None:
        validity = check_tip_deflection(links, t, tip_deflections(system, z),
                                        system.geometric_stiffening, steps=solution.reach)
    elif checked:
        validity = check_tip_deflection(
            links, t, tip_deflections(system, z), system.geometric_stiffening,
            axial_load_parameter(links, system.modal, scenario.base, frames.theta,
                                 frames.omega, frames.alpha, frames.origin_accel),
            inboard=hangs_on_elastic(links, scenario.base), steps=solution.reach)
    torque = joint_torques(system, frames)
    sensors = scenario.sensors if kept is None else \
        tuple(s for s in scenario.sensors if s.name in kept)
    values = sensor_values(system, frames, solution, sensors)
    for k in range(len(scenario.chain.links)):
        values[joint_name(k, "angle")] = hist.angle[:, k]
        values[joint_name(k, "torque")] = torque[:, k]
    if kept is None or any(tip_name(link.name, axis) in kept for link in links
                           for axis in ("X", "Y")):
        values.update(tip_values(system, frames, z))
    if kept is not None:
        values = {name: v for name, v in values.items() if name in kept}
    shapes = LazyShapes(lambda: shape_values(system, frames, z)) if with_shapes else ()
    return values, shapes, validity, partial(sensor_values, system, frames, solution)
