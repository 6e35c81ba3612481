"""The linearised plant of a closed-loop mechanism (`linearize`, `frozen_modes` with
[[closures]]): in independent coordinates, its frequencies against an independent
frame-element eigenanalysis (tests/validation/loop_fe.py), its time response against the
simulated closed mechanism under a small input, and frozen-time points of a run."""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
import pytest

import flexlink
from flexlink.scenario import scenario_from_dict
from tests.validation.loop_fe import four_bar_frequencies
from tests.validation.test_closed_loops import FOUR_BAR, L1, L2, L3, MASS, D, _four_bar_angles
from tests.validation.test_linear_plant import SineLoad, exact_response

COUPLER = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 20.0, "modes": 8}


def _closed(crank_deg: float) -> dict:
    """FOUR_BAR with a flexible coupler and its free joints' angles closing the loop at the
    crank angle (deg)."""
    d = copy.deepcopy(FOUR_BAR)
    d["links"][1] = dict(COUPLER)
    angles = _four_bar_angles(math.radians(crank_deg))
    d["joints"][1]["initial_angle_deg"] = math.degrees(angles[1] - angles[0])
    d["joints"][2]["initial_angle_deg"] = math.degrees(angles[2])
    return d


@pytest.mark.parametrize(("crank_deg", "flexible_rocker"), [(90.0, False), (200.0, True)])
def test_plant_frequencies_match_a_finite_element_eigenanalysis(crank_deg: float,
                                                                flexible_rocker: bool) -> None:
    """A free crank (a mechanism motion: left out of the modes), a flexible coupler (and
    rocker): the plant's oscillatory poles against 80 frame elements per flexible link."""
    d = _closed(crank_deg)
    d["joints"][0] = {"drive": "free", "initial_angle_deg": crank_deg}
    if flexible_rocker:
        d["links"][2] = {"name": "rocker", "length": L3, "mass_per_length": MASS[2], "EI": 60.0,
                         "modes": 8}
    plant = flexlink.linearize(scenario_from_dict(d), at=0.0)
    assert plant.equilibrium
    assert plant.operating_point["dependent_joints"] == "joint2 joint3"
    # independent coordinates: the crank's angle and the elastic ones; no dependent joint
    assert plant.state_names[0] == "joint1_angle"
    assert "joint2_angle" not in plant.state_names and "joint3_angle" not in plant.state_names
    assert {"joint2_angle", "joint3_angle", "pin_force_x"} <= set(plant.output_names)
    fe = four_bar_frequencies((L1, MASS[0], math.inf), (L2, 0.3, 20.0),
                              (L3, MASS[2], 60.0 if flexible_rocker else math.inf), (D, 0.0),
                              _four_bar_angles(math.radians(crank_deg)), EA=1e8, elements=80,
                              count=5)
    f = plant.modes()[0][:4]
    assert np.abs(f / fe[1:] - 1).max() < 5e-3  # measured 9.1e-5 and 3.4e-4


def test_frozen_modes_over_crank_angles_of_a_held_crank() -> None:
    """The crank prescribed (held at each angle by its motor): no mechanism motion, the
    modes of the flexible coupler and rocker, over a grid of crank angles (the free joints'
    guesses zipped with it), against frame elements with the crank's rotation fixed."""
    d = _closed(90.0)
    d["links"][2] = {"name": "rocker", "length": L3, "mass_per_length": MASS[2], "EI": 60.0,
                     "modes": 8}
    scenario = scenario_from_dict(d)
    cranks = np.array([60.0, 150.0, 250.0])
    closed = [_four_bar_angles(math.radians(c)) for c in cranks]
    modes = flexlink.frozen_modes(scenario, angles={
        "joint1": cranks, "joint2": [math.degrees(a[1] - a[0]) for a in closed],
        "joint3": [math.degrees(a[2]) for a in closed]}, count=3)
    for i, angles in enumerate(closed):
        fe = four_bar_frequencies((L1, MASS[0], math.inf), (L2, 0.3, 20.0),
                                  (L3, MASS[2], 60.0), (D, 0.0), angles, EA=1e8,
                                  elements=80, count=3, held_crank=True)
        assert np.abs(modes.frequency_hz[i] / fe - 1).max() < 5e-3  # measured ≤ 8.5e-4
        assert np.degrees(angles[2]) == pytest.approx(modes.configurations[i, 2], abs=1e-6)
    assert np.abs(modes.shapes[:, 0]).max() == pytest.approx(1.0)


def _forced(a: float) -> flexlink.Scenario:
    """The four-bar at rest, free crank, flexible damped coupler, a crank torque
    a sin(2π·3t) N·m."""
    d = _closed(90.0)
    d["joints"][0] = {"drive": "torque", "initial_angle_deg": 90.0,
                      "torque": [{"profile": "step", "amplitude": 0.0, "start": 0.0}]}
    d["links"][1]["damping_ratio"] = 0.02
    d["simulation"].update(t_end=0.4, dt_out=1e-3, rtol=1e-9)
    sc = scenario_from_dict(d)
    joints = (dataclasses.replace(sc.chain.joints[0], torque=SineLoad(a, 3.0)),
              *sc.chain.joints[1:])
    return dataclasses.replace(sc, chain=dataclasses.replace(sc.chain, joints=joints))


def test_plant_responds_as_the_simulated_closed_mechanism() -> None:
    """A small crank torque from rest: the plant's exact response against the closed-loop
    run, per unit amplitude with the quadratic term removed (2 y(a)/a − y(2a)/(2a)): every
    output (dependent joints, pin forces, motor torques, tips) within 1e-5 of its peak."""
    a = 1e-4
    one, two = flexlink.simulate(_forced(a)), flexlink.simulate(_forced(2 * a))
    plant = flexlink.linearize(_forced(0.0), at=0.0)
    t = one.time
    inputs = [(3.0, 0.0, 0.0, 1.0) if name == "joint1_torque" else (3.0, 0.0, 0.0, 0.0)
              for name in plant.input_names]
    linear = exact_response(plant, inputs, t)
    worst = {}
    for i, name in enumerate(plant.output_names):
        simulated = 2 * (one[name] - one[name][0]) / a - (two[name] - two[name][0]) / (2 * a)
        peak = np.abs(linear[:, i]).max()
        if peak > 1e-9:  # the free joints' motor torques are zero (round-off in both)
            worst[name] = np.abs(simulated - linear[:, i]).max() / peak
    assert {"joint3_angle", "pin_force_y", "coupler_tip_Y", "joint1_torque"} <= set(worst)
    assert max(worst.values()) < 1e-5, worst  # measured 5.1e-7
    for name in ("joint2_torque", "joint3_torque"):
        row = plant.output_names.index(name)
        own = (np.array(plant.input_names) == name).astype(float)  # its own torque input
        assert np.abs(plant.C[row]).max() < 1e-7 and np.abs(plant.D[row] - own).max() < 1e-9


def test_frozen_time_plant_along_the_run() -> None:
    """Times of a run of the four-bar whose crank spins up: the plant is about the run's
    state at that time (the joint angles of the simulated run), frozen-time while it moves."""
    d = _closed(90.0)
    d["simulation"].update(t_end=0.3)
    scenario = scenario_from_dict(d)
    run = flexlink.simulate(scenario)
    modes = flexlink.frozen_modes(scenario, times=[0.0, 0.3], count=2)
    i = int(np.argmin(np.abs(run.time - 0.3)))
    assert modes.configurations[1, 2] == pytest.approx(np.degrees(run["joint3_angle"][i]),
                                                       abs=1e-5)
    plant = flexlink.linearize(scenario, at=0.3)
    assert not plant.equilibrium
    assert np.all(np.isfinite(plant.A)) and modes.frequency_hz.shape == (2, 2)
