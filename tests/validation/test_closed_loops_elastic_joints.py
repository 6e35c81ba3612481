"""Elastic joints in closed loops (first-order model): a four-bar whose crank is driven
through a compliant gearbox. Against the exact one-degree-of-freedom frequency of the rigid
mechanism on the spring (k / I_eff, I_eff from the loop's velocity ratios), the two-inertia
frequency with a driven rotor, a frame-element eigenanalysis with a flexible coupler, the
energy balance against the motor's work, and the linearised plant against the simulated
response."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

import flexlink
from flexlink.scenario import scenario_from_dict
from tests.validation.loop_fe import four_bar_frequencies
from tests.validation.test_closed_loops import (
    FOUR_BAR,
    L1,
    L2,
    L3,
    MASS,
    D,
    _bar_energy,
    _four_bar_angles,
)

K, GEAR, ROTOR = 50.0, 10.0, 2e-5  # N·m/rad (link side), motor turns per link turn, kg·m²
CRANK = 90.0  # deg


def _elastic(crank_deg: float = CRANK, motor: dict | None = None) -> dict:
    """FOUR_BAR closed at the crank angle, its crank joint elastic; ``motor``: the motor's
    drive keys (default: held by a prescribed motion at GEAR × the crank angle)."""
    d = copy.deepcopy(FOUR_BAR)
    angles = _four_bar_angles(math.radians(crank_deg))
    d["joints"][1]["initial_angle_deg"] = math.degrees(angles[1] - angles[0])
    d["joints"][2]["initial_angle_deg"] = math.degrees(angles[2])
    motor = motor if motor is not None else {
        "motion": [{"profile": "hold", "angle_deg": GEAR * crank_deg}]}
    d["joints"][0] = {"spring_stiffness": K, "gear_ratio": GEAR, **motor}
    return d


def _crank_inertia(crank: float) -> float:
    """I_eff (kg·m²): the rigid four-bar's kinetic energy is ½ I_eff β̇₁² (velocity ratios
    of the coupler and rocker from the loop's closure, L1 ė(a) + L2 ė(b) = L3 ė(c))."""
    a, b, c = _four_bar_angles(crank)
    e = [np.array([-np.sin(x), np.cos(x)]) for x in (a, b, c)]
    rate_b, rate_c = np.linalg.solve(np.column_stack([L2 * e[1], -L3 * e[2]]), -L1 * e[0])
    one = np.ones(1)
    tip = (L1 * e[0])[None]
    energy = (_bar_energy(MASS[0] * L1, L1, np.zeros((1, 2)), a * one, one)
              + _bar_energy(MASS[1] * L2, L2, tip, b * one, rate_b * one)
              + _bar_energy(MASS[2] * L3, L3, np.zeros((1, 2)), c * one, rate_c * one))
    return float(2 * energy[0])


@pytest.mark.parametrize("crank_deg", [90.0, 200.0])
def test_a_held_motor_sets_the_exact_one_dof_frequency(crank_deg: float) -> None:
    """Rigid links, the motor held: one degree of freedom, ω² = k / I_eff."""
    plant = flexlink.linearize(scenario_from_dict(_elastic(crank_deg)), at=0.0)
    assert plant.equilibrium and plant.state_names == ("joint1_angle", "joint1_rate")
    exact = math.sqrt(K / _crank_inertia(math.radians(crank_deg))) / (2 * math.pi)
    assert plant.modes()[0][0] == pytest.approx(exact, rel=1e-7)  # measured 6e-12


def test_a_driven_rotor_sets_the_two_inertia_frequency() -> None:
    """A torque-driven motor of rotor inertia J_m through gear N: a free motion (zero) and
    ω² = k (1/I_eff + 1/(N² J_m)); the motor's angle is a state of the plant."""
    d = _elastic(motor={"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.0}],
                        "motor_inertia": ROTOR, "initial_angle_deg": GEAR * CRANK})
    plant = flexlink.linearize(scenario_from_dict(d), at=0.0)
    assert set(plant.state_names) == {"joint1_angle", "joint1_motor_angle", "joint1_rate",
                                      "joint1_motor_rate"}
    assert "joint1_torque" in plant.input_names
    inertia = _crank_inertia(math.radians(CRANK))
    exact = math.sqrt(K * (1 / inertia + 1 / (GEAR**2 * ROTOR))) / (2 * math.pi)
    f = np.sort(np.abs(np.linalg.eigvals(plant.A).imag)) / (2 * math.pi)
    assert f[-1] == pytest.approx(exact, rel=1e-7)
    # the free motion: a double zero, split to ±1e-4 rad/s by the differences' round-off
    assert np.abs(plant.poles()).min() < 1e-5 * 2 * math.pi * exact


def test_a_held_elastic_crank_with_a_flexible_coupler_matches_frame_elements() -> None:
    """A flexible coupler and the elastic crank, motor held: the lowest frequencies against
    80 frame elements with a torsional spring at the crank's pivot."""
    d = _elastic()
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 20.0,
                     "modes": 8}
    plant = flexlink.linearize(scenario_from_dict(d), at=0.0)
    fe = four_bar_frequencies((L1, MASS[0], math.inf), (L2, 0.3, 20.0),
                              (L3, MASS[2], math.inf), (D, 0.0),
                              _four_bar_angles(math.radians(CRANK)), EA=1e8, elements=80,
                              count=3, crank_spring=K)
    f = plant.modes()[0][:3]
    assert np.abs(f / fe - 1).max() < 5e-3  # measured 2.2e-5


def _driven(amplitude: float, t_end: float = 0.3) -> dict:
    """The elastic crank's motor under a bang-bang torque (N·m, switching on output
    points), rigid links, no damping."""
    d = _elastic(motor={"drive": "torque", "motor_inertia": ROTOR,
                        "initial_angle_deg": GEAR * CRANK,
                        "torque": [{"profile": "bang_bang", "amplitude": amplitude,
                                    "start": 0.01, "duration": 0.1}]})
    d["simulation"].update(t_end=t_end, dt_out=1e-3, rtol=1e-9)
    return d


def test_energy_equals_the_motors_work_and_the_loop_stays_closed() -> None:
    """Kinetic energy of the three bars and the rotor plus the spring's energy against
    ∫ τ_m dθ_m (τ_m constant between output points), the spring torque's channel against
    k (θ_m/N − β), the joint's torque (on the link) equal to it, and the closure."""
    scenario = scenario_from_dict(_driven(0.02))
    r = flexlink.simulate(scenario)
    t = r.time
    b1, b2, b3 = (r[f"joint{k}_angle"] for k in (1, 2, 3))
    w1, w2, w3 = (r[f"joint{k}_rate"] for k in (1, 2, 3))
    motor, motor_rate = r["joint1_motor_angle"], r["joint1_motor_rate"]
    tip = L1 * w1[:, None] * np.stack([-np.sin(b1), np.cos(b1)], -1)
    zero = np.zeros((t.size, 2))
    stretch = motor / GEAR - b1
    energy = (_bar_energy(MASS[0] * L1, L1, zero, b1, w1)
              + _bar_energy(MASS[1] * L2, L2, tip, b1 + b2, w1 + w2)
              + _bar_energy(MASS[2] * L3, L3, zero, b3, w3)
              + 0.5 * ROTOR * motor_rate**2 + 0.5 * K * stretch**2)
    torque = scenario.chain.joints[0].motor.torque.value(0.5 * (t[1:] + t[:-1]))
    work = np.concatenate([[0.0], np.cumsum(torque * np.diff(motor))])
    assert energy.max() > 1e-3
    assert np.abs(energy - energy[0] - work).max() < 1e-6 * energy.max()
    assert np.abs(r["joint1_spring_torque"] - K * stretch).max() < 1e-12 * K
    assert np.abs(r["joint1_torque"] - r["joint1_spring_torque"]).max() < 1e-6 * K * np.abs(
        stretch).max()
    assert r.metadata["closure_residual_relative"] <= 1e-8
    assert r.metadata["dependent_joints"] == "joint2 joint3"


def test_plant_responds_as_the_simulated_mechanism() -> None:
    """A small motor torque from rest: the linearised plant's response (scipy's lsim on a
    fine grid) against the run's, the quadratic term removed (2 y(a)/a − y(2a)/(2a))."""
    from scipy.signal import lsim

    a = 1e-4
    one, two = (flexlink.simulate(scenario_from_dict(_driven(x, 0.2))) for x in (a, 2 * a))
    plant = flexlink.linearize(scenario_from_dict(_driven(0.0, 0.2)), at=0.0)
    t = one.time
    fine = np.linspace(0.0, t[-1], 20 * (t.size - 1) + 1)
    torque = scenario_from_dict(_driven(1.0, 0.2)).chain.joints[0].motor.torque.value(fine)
    u = np.zeros((fine.size, len(plant.input_names)))
    u[:, plant.input_names.index("joint1_torque")] = torque
    _, y, _ = lsim((plant.A, plant.B, plant.C, plant.D), u, fine, interp=False)
    y = y[::20]
    for name in ("joint1_angle", "joint3_angle", "joint1_motor_angle",
                 "joint1_spring_torque", "pin_force_y"):
        i = plant.output_names.index(name)
        simulated = 2 * (one[name] - one[name][0]) / a - (two[name] - two[name][0]) / (2 * a)
        peak = np.abs(y[:, i]).max()
        assert peak > 0 and np.abs(simulated - y[:, i]).max() < 1e-4 * peak, name


@pytest.mark.slow
@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_a_flexible_four_bar_driven_through_a_spring_matches_the_geometrically_exact_model(
        model: str) -> None:
    """The crank's motor spun up to 1200°/s in 0.2 s, the crank (2 kg/m) turned through the
    spring k = 50 N·m/rad, the coupler flexible (EI = 2 N·m², 4 modes; the stiffened first
    order and the nonlinear model: mid-span 2.0e-3 of its peak, windup 5.7e-4), 0.3 s:
    against Exudyn (Simo–Reissner beams, 32 elements on the coupler, the
    spring a coordinate spring on the crank root's rotation). Later the crank passes
    configurations where the spring-driven mechanism is so sensitive that both models'
    trajectories part (a stiff coupler too: the windups agree within 1% of their peak
    until 0.33 s, then differ by half of it)."""
    pytest.importorskip("exudyn")
    from flexlink.model import Link
    from tests.validation.exudyn_loops_reference import simulate_four_bar_exudyn

    d = _elastic(motor={"motion": [{"profile": "spinup", "to_rate_deg_s": 1200.0,
                                    "start": 0.0, "duration": 0.2, "from_deg": CRANK}]})
    d["joints"][0]["gear_ratio"] = 1.0
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 2.0,
                     "modes": 4}
    d["sensors"] = [{"name": "mid", "kind": "deflection", "link": "coupler", "x": L2 / 2}]
    d["simulation"] = {"name": "four-bar", "t_end": 0.3, "dt_out": 5e-4,
                       "geometric_stiffening": True, "model": model}
    scenario = scenario_from_dict(d)
    run = flexlink.simulate(scenario)
    ref = simulate_four_bar_exudyn(L1, Link("coupler", L2, 0.3, 2.0),
                                   Link("rocker", L3, MASS[2], math.inf), (D, 0.0),
                                   scenario.chain.joints[0].motor,
                                   _four_bar_angles(math.radians(CRANK)), 1e6, 0.3, 5e-4,
                                   elements=32, dt=2.5e-5, crank_spring=K,
                                   crank_mass_per_length=MASS[0])
    windup = np.asarray(run["joint1_spring_torque"]) / K
    ref_windup = np.asarray(scenario.chain.joints[0].motor.evaluate(ref["t"])[0]
                            ) - ref["crank_angle"]
    peak = np.abs(ref["mid_deflection"]).max()
    print(f"mid peak {peak:.4g} m, error {np.abs(run['mid'] - ref['mid_deflection']).max():.3g};"
          f" windup peak {np.abs(ref_windup).max():.4g} rad, error "
          f"{np.abs(windup - ref_windup).max():.3g}")
    assert np.abs(run["mid"] - ref["mid_deflection"]).max() < 0.01 * peak  # measured 1.7e-3
    assert np.abs(windup - ref_windup).max() < 0.01 * np.abs(ref_windup).max()  # 5.6e-4
    assert np.abs(np.unwrap(run["joint3_angle"]) - ref["rocker_angle"]).max() < 2e-4  # 3.5e-5
