"""Pieces of a linearised plant shared by every kind of plant (`linearization.py`: open
chains; `loop_plant.py`: closed loops): the forward system of a scenario, the checks before a
linearisation (memory of the run up to the operating point, saturated servos), and the
plant's names, units and operating-point description."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..channels.catalogue import cart_name, catalogue
from ..dynamics.forward import ForwardSystem
from ..dynamics.servos import command_volts, servo_torque
from ..model import PositionServo, Scenario, VelocityServo
from .linear import LinearPlant
from .operating_point import Configuration, NotLinearizable

STEP = 1e-6  # central-difference step in the rigid coordinates (rad, m, and their rates)


def forward_system(scenario: Scenario) -> ForwardSystem:
    """The plant's system: its start may have unheld joints that the loads turn (a plant
    about it is frozen-time, ``equilibrium`` False), which a run refuses."""
    from ..simulation.forward import forward_system as run_system

    system = run_system(scenario)
    system.unheld_may_move = True
    return system


def _check_run_size(scenario: Scenario, t_end: float) -> None:
    """RunTooLarge, before the run to ``t_end`` (s), if its arrays would not fit in memory
    (the check `flexlink run` makes, for this shorter or equal run)."""
    from ..errors import RunTooLarge
    from ..simulation.common import (
        ALWAYS_FITS,
        MemoryEstimate,
        memory_problem,
        run_memory,
        sample_count,
    )

    estimate = MemoryEstimate(sample_count(t_end, scenario.settings.dt_out),
                              run_memory(scenario).per_sample)
    if estimate.total > ALWAYS_FITS:
        problem = memory_problem(estimate, t_end, f"the run up to t = {t_end:g} s")
        if problem:
            raise RunTooLarge(problem)


def _check_servos(scenario: Scenario, system: ForwardSystem, t0: float, p: np.ndarray,
                  pd: np.ndarray, integral: np.ndarray) -> None:
    """Refuse an operating point where a servo saturates: the plant is the unsaturated law."""
    t = np.array([t0])
    for s, k in enumerate(system.servos):
        joint, i = system.servo_of(k)
        args = (t, p[i:i + 1], pd[i:i + 1], integral[s:s + 1])
        torque, _ = servo_torque(joint, *args)  # type: ignore[arg-type]
        saturated = abs(float(torque[0])) >= joint.torque_limit  # type: ignore[union-attr]
        if isinstance(joint, VelocityServo):
            saturated |= abs(float(command_volts(joint, *args)[0])) >= joint.saturation
        elif isinstance(joint, PositionServo):
            error = float(joint.reference.evaluate(t)[0][0]) - p[i]
            saturated |= abs(joint.bandwidth * error) >= joint.rate_limit
        if saturated:
            raise NotLinearizable(f"joint {k + 1}'s servo is saturated at the operating point: the "
                                  "linearisation is of the unsaturated servo law; choose "
                                  "another time or a rest configuration")


def _elastic_names(scenario: Scenario) -> list[str]:
    return [f"{link.name}_q{i + 1}" for link in scenario.chain.links for i in range(link.modes)]


INPUT_UNITS = {"torque": "N m", "reference": "rad", "reference_rate": "rad s-1",
               "base_force_x": "N", "base_force_y": "N", "base_moment": "N m", "voltage": "V",
               "cart_force": "N", "force": "N"}


def _input_unit(name: str) -> str:
    if name in INPUT_UNITS:
        return INPUT_UNITS[name]
    for suffix in ("reference_rate", "reference", "torque", "voltage", "force"):
        if name.endswith("_" + suffix):
            return INPUT_UNITS[suffix]
    raise KeyError(name)


def _plant(scenario: Scenario, A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray,
           elastic: list[str], rigid: list[str], inputs: list[str], outputs: list[str],
           op: dict[str, Any], equilibrium: bool, ns_names: list[str] | None = None
           ) -> LinearPlant:
    units = {c.name: c.unit for c in catalogue(scenario)}
    rates = {_rate_name(name): "rad s-1" for name in rigid}
    rates.update({"base_x_rate": "m s-1", "base_y_rate": "m s-1",
                  "base_attitude_rate": "rad s-1", "base_x": "m", "base_y": "m",
                  "base_attitude": "rad"})
    rates.update({name: "rad" for name in rigid if name.startswith("joint")})
    out_units = tuple(units.get(name, rates.get(name, "")) for name in outputs)
    positions = rigid + elastic
    states = positions + [_rate_name(name) for name in positions] + (ns_names or [])
    return LinearPlant(A, B, C, D, tuple(states), tuple(inputs), tuple(outputs),
                       tuple(_input_unit(n) for n in inputs), out_units, op, equilibrium)


def _rate_name(name: str) -> str:
    """The rate's name of a coordinate's: ``joint1_angle`` → ``joint1_rate``, a slider's
    ``joint2_position`` → ``joint2_velocity``, ``cart_position`` → ``cart_velocity``,
    ``base_x`` or an elastic coordinate ``arm_q1`` → ``…_rate``."""
    if name.endswith("_angle"):
        return f"{name.removesuffix('_angle')}_rate"
    if name.endswith("_position") and (name == cart_name("position")
                                       or name.startswith("joint")):
        return f"{name.removesuffix('_position')}_velocity"
    return f"{name}_rate"


def _describe(scenario: Scenario, point: float | Configuration, equilibrium: bool
              ) -> dict[str, Any]:
    op: dict[str, Any] = {"scenario": scenario.name,
                          "geometric_stiffening": scenario.settings.geometric_stiffening,
                          "model": "first_order"}
    if isinstance(point, Configuration):
        op.update(point.describe())
    else:
        op.update(kind="time of the run" + ("" if equilibrium else " (frozen, not at rest)"),
                  time_s=point)
    return op
