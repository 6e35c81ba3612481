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


def test_more_drives_than_degrees_of_freedom_are_refused_naming_the_joints() -> None:
    """The four-bar's coupler prescribed as well as its crank: the pin's two equations leave
    one joint to move them; refused at load, naming the prescribed joints."""
    from flexlink.scenario.errors import ScenarioError

    d = copy.deepcopy(FOUR_BAR)
    d["joints"][1] = {"motion": [{"profile": "hold", "angle_deg": -60.0}]}
    with pytest.raises(ScenarioError, match=r"more drives than degrees of freedom.*"
                                            r"prescribed: joints\[0\] \(joint1\), "
                                            r"joints\[1\] \(joint2\)"):
        scenario_from_dict(d)
    d["joints"][1] = {"drive": "free", "initial_angle_deg": -60.0}
    d["closures"] = [{"name": "piston", "kind": "slider", "link": "rocker", "ground": [0, 0]}]
    scenario_from_dict(d)  # a slider's one equation: the two free joints suffice


def _gravity_four_bar(crank: dict, stiffening: bool = True) -> dict:
    d = _closed(90.0)
    d["joints"][0] = crank
    d["simulation"].update(gravity=[0.0, -9.81], initial="equilibrium", t_end=0.2, rtol=1e-9,
                           geometric_stiffening=stiffening)
    d["sensors"] = [{"name": "mid", "kind": "deflection", "link": "coupler", "x": L2 / 2}]
    return d


def test_equilibrium_start_of_a_closed_loop_under_gravity() -> None:
    """The crank held at 90°: the loop locks the mechanism, the coupler is a simply supported
    beam under its weight's transverse part q = m g cos θ₂: mid-span deflection 5 q L⁴ /
    384 EI (without stiffening; the rocker's weight loads the coupler axially). The run
    from that start stays still; from rest it vibrates."""
    d = _gravity_four_bar({"motion": [{"profile": "hold", "angle_deg": 90.0}]}, False)
    r = flexlink.simulate(scenario_from_dict(d))
    theta2 = r["joint1_angle"][0] + r["joint2_angle"][0]
    q = 0.3 * 9.81 * math.cos(theta2)
    exact = -5 * q * L2**4 / (384 * 20.0)
    # the basis's 8 sine modes hold the series' terms n ≤ 8 of w = Σ 4qL⁴ sin(nπx/L)/(EI n⁵π⁵)
    series = -sum(4 * q * L2**4 * math.sin(n * math.pi / 2) / (20.0 * (n * math.pi) ** 5)
                  for n in range(1, 9, 2))
    assert r["mid"][0] == pytest.approx(series, rel=1e-9)
    assert r["mid"][0] == pytest.approx(exact, rel=2e-5)  # the series' truncation: 1.3e-5
    assert np.ptp(r["mid"]) < 1e-9 * abs(exact)
    assert flexlink.linearize(scenario_from_dict(d), at=0.0).equilibrium
    d["simulation"]["initial"] = "rest"
    assert np.ptp(flexlink.simulate(scenario_from_dict(d))["mid"]) > 0.5 * abs(exact)
    assert not flexlink.linearize(scenario_from_dict(d), at=0.0).equilibrium


def test_equilibrium_start_with_a_servo_crank_balances_the_weights() -> None:
    """A position servo holds the crank: at equilibrium its torque is the weights' moment
    dV/dθ₁ of the closed mechanism (virtual work on the exact rigid four-bar kinematics;
    measured 5e-6 apart: the coupler's sag), and the run stays still."""
    servo = {"drive": "servo", "servo": "position", "bandwidth": 30.0,
             "rate_limit_deg_s": 500.0, "loop_gain": 5.0, "motor_inertia": 0.001,
             "reference": [{"profile": "hold", "angle_deg": 90.0}]}
    r = flexlink.simulate(scenario_from_dict(_gravity_four_bar(servo)))
    crank = r["joint1_angle"][0]
    assert crank != pytest.approx(math.pi / 2, abs=1e-5)  # the servo yields to the load

    def potential(c: float) -> float:
        b1, b2, b3 = _four_bar_angles(c)
        return 9.81 * (MASS[0] * L1 * 0.5 * L1 * math.sin(b1)
                       + 0.3 * L2 * (L1 * math.sin(b1) + 0.5 * L2 * math.sin(b2))
                       + MASS[2] * L3 * 0.5 * L3 * math.sin(b3))

    h = 1e-6
    moment = (potential(crank + h) - potential(crank - h)) / (2 * h)
    assert r["joint1_torque"][0] == pytest.approx(moment, rel=1e-4)
    for name in ("joint1_angle", "joint3_angle", "mid"):
        assert np.ptp(r[name]) < 1e-9 * max(1.0, abs(r[name][0]))


def test_pinned_loaded_modes_converge_where_the_sines_do_not() -> None:
    """A coupler carrying a body (0.05 kg, 4e-4 kg·m² about its tip) at the pinned end, the
    crank held: `auto` chooses `pinned_loaded`; with 2 modes its two lowest frequencies
    are within 3e-5 of frame elements (120 elements, the body lumped on the tip node); the
    sines miss them by 5.4% and 30% (0.8% and 3.3% with 16 modes)."""
    angles = _four_bar_angles(math.radians(90.0))
    fe = four_bar_frequencies((L1, MASS[0], math.inf), (L2, 0.3, 20.0), (L3, MASS[2], math.inf),
                              (D, 0.0), angles, EA=1e8, elements=120, count=2,
                              held_crank=True, coupler_tip=(0.05, 4e-4))
    errors = {}
    for shapes in ("auto", "pinned_pinned"):
        d = _closed(90.0)
        d["links"][1].update(modes=2, tip_mass=0.05, tip_inertia=4e-4, mode_shapes=shapes)
        scenario = scenario_from_dict(d)
        errors[scenario.chain.links[1].mode_shapes] = np.abs(
            flexlink.linearize(scenario, at=0.0).modes()[0][:2] / fe - 1).max()
    assert errors["pinned_loaded"] < 1e-4  # measured 2.2e-5
    assert errors["pinned_pinned"] > 0.2  # measured 0.30


def test_pinned_loaded_modes_meet_their_end_conditions() -> None:
    """y(0) = y''(0) = y(L) = 0 and EI y''(L) = J ω² y'(L) (ω² = EI β⁴/m); no inertia: the
    sines."""
    from flexlink.modes.shapes import pinned_loaded_modes, pinned_pinned_modes

    L, m, J = 0.3, 0.3, 4e-4
    shapes = pinned_loaded_modes(L, 4, m, J)
    ends = np.array([0.0, L])
    y, y1, y2 = (shapes.evaluate(ends, k) for k in (0, 1, 2))
    scale = np.abs(y1).max(0)
    assert np.abs(y[:, :]).max() < 1e-12 and np.abs(y2[0] / (shapes.beta * scale)).max() < 1e-10
    omega2_over_ei = shapes.beta**4 / m  # ω²/EI
    assert np.allclose(y2[1], J * omega2_over_ei * y1[1], rtol=1e-8, atol=0)
    assert np.all(y1[0] > 0)
    sines = pinned_pinned_modes(L, 4)
    x = np.linspace(0, L, 7)
    assert np.allclose(pinned_loaded_modes(L, 4, m, 0.0).evaluate(x), sines.evaluate(x))


@pytest.mark.slow
@pytest.mark.parametrize("free_crank", [False, True])
def test_plant_frequencies_match_exudyn_eigenvalues(free_crank: bool) -> None:
    """Exudyn's geometrically exact beams (32 and 64 elements, Richardson-extrapolated;
    tests/validation/exudyn_loop_modes.py) at rest: the coupler with its end body, crank
    held or free, the `auto` (pinned_loaded) plant with 4 modes within 5e-3 on three
    frequencies (measured ≤ 3.3e-4 held, ≤ 1.0e-4 free)."""
    pytest.importorskip("exudyn")
    from flexlink.model import Link
    from tests.validation.exudyn_loop_modes import four_bar_frequencies_exudyn

    angles = _four_bar_angles(math.radians(90.0))
    coupler = Link("coupler", L2, 0.3, 20.0, tip_mass=0.05, tip_inertia=4e-4)
    rocker = Link("rocker", L3, MASS[2], math.inf)
    coarse, fine = (four_bar_frequencies_exudyn(L1, coupler, rocker, (D, 0.0), angles, 1e8, n,
                                                3, held_crank=not free_crank)
                    for n in (32, 64))
    reference = fine + (fine - coarse) / 3
    d = _closed(90.0)
    d["links"][1].update(modes=4, tip_mass=0.05, tip_inertia=4e-4)
    if free_crank:
        d["joints"][0] = {"drive": "free", "initial_angle_deg": 90.0}
    model = flexlink.linearize(scenario_from_dict(d), at=0.0).modes()[0][:3]
    assert np.abs(model / reference - 1).max() < 5e-3


def test_servo_crank_static_gain_is_the_loop_kinematics() -> None:
    """A position servo on the crank, no loads: the plant's static gain from the crank's
    reference, −C A⁻¹ B + D, is 1 on the crank's angle and the loop's kinematic ratios
    dθ/dθ₁ (exact rigid four-bar, central differences) on the dependent joints."""
    d = _closed(90.0)
    d["joints"][0] = {"drive": "servo", "servo": "position", "bandwidth": 30.0,
                      "rate_limit_deg_s": 500.0, "loop_gain": 5.0, "motor_inertia": 0.001,
                      "reference": [{"profile": "hold", "angle_deg": 90.0}]}
    plant = flexlink.linearize(scenario_from_dict(d), at=0.0)
    assert plant.equilibrium and np.linalg.eigvals(plant.A).real.max() < 0
    column = plant.input_names.index("joint1_reference")
    gain = (-plant.C @ np.linalg.solve(plant.A, plant.B[:, column]) + plant.D[:, column])
    h = 1e-6
    up, down = (np.array(_four_bar_angles(math.pi / 2 + s)) for s in (h, -h))
    ratio = (up - down) / (2 * h)  # absolute angles of crank, coupler, rocker
    out = {name: gain[i] for i, name in enumerate(plant.output_names)}
    assert out["joint1_angle"] == pytest.approx(1.0, abs=1e-7)
    assert out["joint2_angle"] == pytest.approx(ratio[1] - ratio[0], abs=1e-6)
    assert out["joint3_angle"] == pytest.approx(ratio[2], abs=1e-6)


def test_servo_on_a_dependent_joint_static_gain() -> None:
    """The crank free, a position servo on the rocker (a joint the closures determine: its
    servo drives the loop through the constraint): static gain 1 on the rocker's angle and
    dθ₁/dθ₃ = 1/(dθ₃/dθ₁) of the rigid four-bar on the crank's."""
    d = _closed(90.0)
    d["joints"][0] = {"drive": "free", "initial_angle_deg": 90.0}
    rocker = math.degrees(_four_bar_angles(math.pi / 2)[2])
    d["joints"][2] = {"drive": "servo", "servo": "position", "bandwidth": 30.0,
                      "rate_limit_deg_s": 500.0, "loop_gain": 5.0, "motor_inertia": 0.001,
                      "base_point": [D, 0.0], "reference": [{"profile": "hold",
                                                             "angle_deg": rocker}]}
    plant = flexlink.linearize(scenario_from_dict(d), at=0.0)
    assert plant.operating_point["dependent_joints"] == "joint2 joint3"
    column = plant.input_names.index("joint3_reference")
    gain = (-plant.C @ np.linalg.solve(plant.A, plant.B[:, column]) + plant.D[:, column])
    out = {name: gain[i] for i, name in enumerate(plant.output_names)}
    h = 1e-6
    ratio = (_four_bar_angles(math.pi / 2 + h)[2] - _four_bar_angles(math.pi / 2 - h)[2]) / (2 * h)
    assert out["joint3_angle"] == pytest.approx(1.0, abs=1e-6)
    assert out["joint1_angle"] == pytest.approx(1 / ratio, rel=1e-6)
