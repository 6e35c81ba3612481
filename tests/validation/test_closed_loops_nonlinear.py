"""Closed loops (four-bar, slider-crank) on the geometrically nonlinear model: rigid
kinematics against the first-order path (both exact for rigid links), the exact closure on
the deformed arcs through the run, the energy of a free flexible four-bar without damping
(exact for this model), the work of a prescribed crank against the energy it puts in, and
the constraint forces' balance on the rigid rocker."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from flexlink import simulate
from flexlink.scenario import scenario_from_dict
from flexlink.scenario.errors import ScenarioError
from tests.validation.test_closed_loops import FOUR_BAR, L2, L3, MASS, SLIDER_CRANK, _rate


def _nonlinear(d: dict) -> dict:
    d = copy.deepcopy(d)
    d["simulation"]["model"] = "nonlinear"
    return d


def _flexible_four_bar(**simulation) -> dict:
    d = _nonlinear(FOUR_BAR)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": MASS[1], "EI": 2.0,
                     "modes": 4}
    d["simulation"].update(simulation)
    return d


def test_rigid_mechanisms_follow_the_first_order_kinematics() -> None:
    """Rigid links: both models are exact, so joint angles, the crank torque and the pin
    force agree to round-off (measured 6e-15 four-bar, 8e-13 slider-crank)."""
    for base, channels in ((FOUR_BAR, ("joint2_angle", "joint3_angle", "joint1_torque",
                                       "pin_force_x", "pin_force_y")),
                           (SLIDER_CRANK, ("joint2_angle", "joint1_torque",
                                           "piston_normal_force"))):
        d = copy.deepcopy(base)
        d["simulation"]["t_end"] = 0.3
        first = simulate(scenario_from_dict(d))
        exact = simulate(scenario_from_dict(_nonlinear(d)))
        assert exact.metadata["method"] == "radau5"
        for name in channels:
            scale = np.abs(first[name]).max()
            assert np.abs(exact[name] - first[name]).max() < 1e-9 * scale, name


def test_flexible_slider_crank_stays_on_its_line_exactly() -> None:
    """The rod's deformed tip (the piston), read by the tip channel's own arc integral,
    stays on the line y = 0 to round-off of the loop's size, though the rod bends and its
    chord shortens (the closure is on the exact arc, not on a first-order expansion)."""
    d = _nonlinear(SLIDER_CRANK)
    d["links"][1] = {"name": "rod", "length": 0.304, "mass_per_length": 0.2225, "EI": 12.72,
                     "modes": 4, "tip_mass": 0.05}
    d["joints"][0] = {"motion": [{"profile": "spinup", "to_rate_deg_s": 8594.37,
                                  "start": 0.0, "duration": 0.1, "from_deg": 0.0}]}
    d["joints"][1]["initial_angle_deg"] = 0.0
    d["sensors"] = [{"name": "mid", "kind": "deflection", "link": "rod", "x": 0.152}]
    d["simulation"].update(t_end=0.15, dt_out=2e-4, rtol=1e-6)
    r = simulate(scenario_from_dict(d))
    size = 0.152 + 0.304
    assert np.abs(r["mid"]).max() > 1e-3  # the rod bends
    assert r.metadata["closure_residual_relative"] < 1e-8
    assert np.abs(r["rod_tip_Y"]).max() < 1e-9 * size
    assert np.abs(r["joint2_torque"]).max() < 1e-8 * np.abs(r["joint1_torque"]).max()


def test_free_flexible_four_bar_keeps_its_energy() -> None:
    """A four-bar turning freely, its coupler flexible, no damping, no loads: the nonlinear
    model's energy (kinetic of every point + bending) is constant to the integration
    tolerance, while the coupler bends and exchanges energy with the motion."""
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
    from flexlink.simulation.nonlinear_forward import run_nonlinear_forward

    d = _flexible_four_bar(t_end=0.3, rtol=1e-8)
    d["links"][1]["damping_ratio"] = 0.0
    d["joints"][0] = {"drive": "free", "initial_angle_deg": 90.0, "initial_rate_deg_s": 720.0}
    scenario = scenario_from_dict(d)
    t = np.linspace(0.0, 0.3, 301)
    run = run_nonlinear_forward(scenario, t, lambda _: None, with_shapes=False)
    system = NonlinearForwardSystem(scenario.chain, scenario.base)
    y, v, _ = system.from_solution(run.solution)
    kinetic, strain = system.energy(t, y, v)
    energy = kinetic + strain
    assert strain.max() > 1e-4 * energy[0]
    assert np.abs(energy - energy[0]).max() < 1e-6 * strain.max()


def test_prescribed_crank_work_is_the_energy_put_in() -> None:
    """A prescribed crank drives the flexible four-bar without damping: the work of its
    motor torque (the channel, the constraint forces left out) equals the change of the
    mechanism's energy, the coupler's bending included."""
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
    from flexlink.simulation.nonlinear_forward import run_nonlinear_forward

    d = _flexible_four_bar(t_end=0.4, rtol=1e-8)
    d["links"][1]["damping_ratio"] = 0.0
    d["joints"][0] = {"motion": [{"profile": "spinup", "to_rate_deg_s": 1200.0, "start": 0.0,
                                  "duration": 0.2, "from_deg": 90.0}]}
    scenario = scenario_from_dict(d)
    t = np.linspace(0.0, 0.4, 4001)
    run = run_nonlinear_forward(scenario, t, lambda _: None, with_shapes=False)
    system = NonlinearForwardSystem(scenario.chain, scenario.base)
    y, v, _ = system.from_solution(run.solution)
    kinetic, strain = system.energy(t, y, v)
    energy = kinetic + strain - (kinetic + strain)[0]
    power = run.values["joint1_torque"] * run.values["joint1_rate"]
    # the trapezoidal rule on the fine output grid (the power is smooth)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    assert strain.max() > 1e-4 * energy.max()
    assert np.abs(work - energy).max() < 1e-5 * energy.max()


def test_pin_force_turns_the_rigid_rocker() -> None:
    """The rigid rocker turns about its pivot under the pin's force only, with the coupler
    flexible: (B − D) × (−λ) = (m L²/3) α."""
    r = simulate(scenario_from_dict(_flexible_four_bar(t_end=0.4, rtol=1e-8)))
    t = r.time
    rocker = r["joint3_angle"]
    arm = L3 * np.stack([np.cos(rocker), np.sin(rocker)], -1)
    force = -np.stack([r["pin_force_x"], r["pin_force_y"]], -1)
    moment = arm[:, 0] * force[:, 1] - arm[:, 1] * force[:, 0]
    alpha = _rate(r["joint3_rate"], t)
    inertia = MASS[2] * L3**3 / 3
    ok = np.isfinite(alpha) & (np.abs(t - 0.5) > 2.5e-3)
    assert np.abs(moment[ok] - inertia * alpha[ok]).max() < 1e-7 * np.abs(moment).max()


def test_a_fixed_step_with_closures_is_refused() -> None:
    d = _nonlinear(FOUR_BAR)
    d["simulation"]["step"] = 1e-3
    with pytest.raises(ScenarioError, match="closures.*simulation.step"):
        scenario_from_dict(d)


@pytest.mark.parametrize("drive", ["torque", "servo"])
def test_driven_crank_under_gravity_does_the_work_of_its_torque(drive: str) -> None:
    """A driven crank (a torque step; a velocity servo with an integrator) turns the flexible
    four-bar under gravity, no damping: the crank stays independent, and the work of its
    torque equals the change of kinetic + bending + potential energy (measured 1.6e-7 and
    3.6e-7 of the largest change)."""
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
    from flexlink.simulation.nonlinear_forward import run_nonlinear_forward

    d = _flexible_four_bar(t_end=0.3, rtol=1e-8, gravity=[0.0, -9.81])
    d["links"][1]["damping_ratio"] = 0.0
    if drive == "torque":
        d["joints"][0] = {"drive": "torque", "initial_angle_deg": 90.0,
                          "torque": [{"profile": "step", "amplitude": 0.05, "start": 0.0}]}
    else:
        d["joints"][0] = {"drive": "servo", "servo": "velocity_pid", "P": 5.0, "I": 20.0,
                          "D": 0.1, "rate_per_volt_deg_s": 60.0, "loop_gain": 1.0,
                          "reference": [{"profile": "spinup", "to_rate_deg_s": 360.0,
                                         "start": 0.0, "duration": 0.2, "from_deg": 90.0}]}
    scenario = scenario_from_dict(d)
    t = np.linspace(0.0, 0.3, 3001)
    run = run_nonlinear_forward(scenario, t, lambda _: None, with_shapes=False)
    assert run.metadata["dependent_joints"] == "joint2 joint3"
    system = NonlinearForwardSystem(scenario.chain, scenario.base,
                                    gravity=scenario.settings.gravity)
    y, v, _ = system.from_solution(run.solution)
    kinetic, strain = system.energy(t, y, v)
    energy = kinetic + strain + system.potential(t, y)
    energy -= energy[0]
    power = run.values["joint1_torque"] * run.values["joint1_rate"]
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    assert run.values["joint1_rate"][-1] > 1.0  # the crank turns
    assert strain.max() > 1e-4 * np.abs(energy).max()
    assert np.abs(work - energy).max() < 1e-5 * np.abs(energy).max()


def test_a_loop_that_cannot_close_is_refused_with_its_residual() -> None:
    """The closed start is the first-order loops' (the links start undeformed): a pivot
    beyond reach is refused, naming the closure and the least gap (√(1 + L1²) − L2 − L3 =
    0.455 m), before anything runs."""
    d = _nonlinear(FOUR_BAR)
    d["joints"][2]["base_point"] = [1.0, 0.0]
    with pytest.raises(Exception, match=r"closures\[0\] \('pin', residual 0\.455 m\)"):
        simulate(scenario_from_dict(d))
