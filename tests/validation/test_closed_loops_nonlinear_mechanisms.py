"""Closed loops on the nonlinear model with elastic joints, sampled controllers and a moving
base (the four-bar of tests/validation/test_closed_loops.py). Rigid links: the nonlinear
model's mechanism is the first-order model's, so both runs agree to the integration
tolerance. Independent checks: the exact one-degree-of-freedom frequency √(k / I_eff) of the
elastic crank, the energy balance against the motor's work, the equivalence principle on an
accelerating cart, the conservation of momentum and energy on a free base in space, and a
controller's loop reported stable or unstable."""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
import pytest

import flexlink
from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
from flexlink.dynamics.nonlinear_loops import NonlinearLoopSystem
from flexlink.errors import SimulationError
from flexlink.scenario import scenario_from_dict
from flexlink.solvers.nonlinear_loops import integrate_nonlinear_loops
from tests.validation.test_closed_loops import L1, L2, L3, MASS, _bar_energy
from tests.validation.test_closed_loops_controllers import _damped, _first_frequency, _ppf
from tests.validation.test_closed_loops_elastic_joints import (
    CRANK,
    GEAR,
    ROTOR,
    K,
    _crank_inertia,
    _driven,
    _elastic,
)
from tests.validation.test_closed_loops_moving_base import (
    ACCELERATION,
    RAIL,
    UniformAcceleration,
    _swinging,
)
from tests.validation.test_ppf import identified_poles


def _both(d: dict) -> tuple[flexlink.Results, flexlink.Results]:
    """The scenario's runs on the first-order and the nonlinear model."""
    out = []
    for model in ("first_order", "nonlinear"):
        d = copy.deepcopy(d)
        d["simulation"]["model"] = model
        out.append(flexlink.simulate(scenario_from_dict(d), shapes=False))
    return out[0], out[1]


def _agree(first, nonlinear, names: tuple[str, ...], bound: float) -> None:
    for name in names:
        ref = np.asarray(first[name])
        scale = np.abs(ref - ref[0]).max()
        assert scale > 0, name
        assert np.abs(np.asarray(nonlinear[name]) - ref).max() < bound * scale, name


# -- elastic joints -------------------------------------------------------------------------

def test_an_elastic_crank_on_rigid_links_is_the_first_order_mechanism() -> None:
    """A bang-bang motor torque through the spring (rigid links, no damping, rtol 1e-10):
    the two models' angles, spring torque and pin force agree to the integration tolerance
    (the two runs' own errors, each up to about rtol, add up); the nonlinear run's energy
    (bars, rotor, spring) equals the motor's work."""
    scenario_dict = _driven(0.02)
    scenario_dict["simulation"]["rtol"] = 1e-10
    first, run = _both(scenario_dict)
    _agree(first, run, ("joint1_angle", "joint3_angle", "joint1_motor_angle"), 1e-9)
    _agree(first, run, ("joint1_spring_torque", "joint1_torque", "pin_force_y"), 1e-6)
    t = np.asarray(run.time)
    b1, b2, b3 = (np.asarray(run[f"joint{k}_angle"]) for k in (1, 2, 3))
    w1, w2, w3 = (np.asarray(run[f"joint{k}_rate"]) for k in (1, 2, 3))
    motor, motor_rate = np.asarray(run["joint1_motor_angle"]), run["joint1_motor_rate"]
    tip = L1 * w1[:, None] * np.stack([-np.sin(b1), np.cos(b1)], -1)
    zero = np.zeros((t.size, 2))
    energy = (_bar_energy(MASS[0] * L1, L1, zero, b1, w1)
              + _bar_energy(MASS[1] * L2, L2, tip, b1 + b2, w1 + w2)
              + _bar_energy(MASS[2] * L3, L3, zero, b3, w3)
              + 0.5 * ROTOR * np.asarray(motor_rate)**2 + 0.5 * K * (motor / GEAR - b1)**2)
    scenario = scenario_from_dict(scenario_dict)
    torque = scenario.chain.joints[0].motor.torque.value(0.5 * (t[1:] + t[:-1]))
    work = np.concatenate([[0.0], np.cumsum(torque * np.diff(motor))])
    assert energy.max() > 1e-3
    assert np.abs(energy - energy[0] - work).max() < 1e-6 * energy.max()
    assert run.metadata["model"] == "nonlinear"
    assert run.metadata["closure_residual_relative"] <= 1e-8


def test_an_elastic_crank_on_a_servo_under_gravity_is_the_first_order_mechanism() -> None:
    """The motor on a position servo (its rotor 2·10⁻⁵ kg·m²) turns the crank by 20° through
    the spring under gravity, rigid links: both models agree to the integration tolerance
    (measured 7e-10 on the angles, 9e-9 on the spring torque)."""
    d = _elastic(motor={"drive": "servo", "servo": "position", "bandwidth": 30.0,
                        "loop_gain": 5.0, "rate_limit_deg_s": 5000.0, "motor_inertia": ROTOR,
                        "reference": [{"profile": "cycloidal", "from_deg": GEAR * CRANK,
                                       "to_deg": GEAR * (CRANK + 20.0), "start": 0.0,
                                       "duration": 0.1}]})
    d["simulation"].update(t_end=0.2, dt_out=1e-3, rtol=1e-9, gravity=[0.0, -9.81])
    first, run = _both(d)
    _agree(first, run, ("joint1_angle", "joint3_angle", "joint1_motor_angle"), 1e-8)
    _agree(first, run, ("joint1_spring_torque", "joint1_torque", "pin_force_y"), 1e-6)
    assert run.metadata["closure_residual_relative"] <= 1e-8


def test_a_held_elastic_crank_rings_at_the_exact_one_dof_frequency() -> None:
    """The motor moved by 0.05° of the crank in 2 ms and held (rigid links): the crank rings
    on the spring at ω² = k / I_eff of the final configuration (an amplitude of 10⁻³ rad
    shifts it by its square)."""
    step = 0.05  # deg of the crank
    d = _elastic(motor={"motion": [
        {"profile": "cycloidal", "from_deg": GEAR * CRANK, "to_deg": GEAR * (CRANK + step),
         "start": 0.0, "duration": 0.002}]})
    d["simulation"].update(model="nonlinear", t_end=0.3, dt_out=2e-4, rtol=1e-10)
    run = flexlink.simulate(scenario_from_dict(d), shapes=False)
    t, crank = np.asarray(run.time), np.asarray(run["joint1_angle"])
    ringing = t > 0.002
    crank = crank - math.radians(CRANK + step)
    assert 1e-5 < np.abs(crank[ringing]).max() < 2e-3
    poles = identified_poles(t[ringing], crank[ringing], 2, 1)
    exact = math.sqrt(K / _crank_inertia(math.radians(CRANK + step)))
    assert np.abs(poles).max() == pytest.approx(exact, rel=1e-5)
    assert np.abs(poles.real).max() < 1e-5 * exact  # no damping
    assert run.metadata["closure_residual_relative"] <= 1e-8


def test_a_kicked_rotor_rings_at_the_exact_two_inertia_frequency() -> None:
    """A ±10⁻³ N·m bang-bang torque on the rotor over 2 ms (no net impulse: the mechanism
    stays where it was, rigid links): the spring's windup then rings at ω² = k (1/I_eff +
    1/(N² J_m))."""
    d = _driven(1e-3, t_end=0.2)
    d["joints"][0]["torque"] = [{"profile": "bang_bang", "amplitude": 1e-3, "start": 0.0,
                                 "duration": 0.002}]
    d["simulation"].update(model="nonlinear", dt_out=2e-4, rtol=1e-10)
    run = flexlink.simulate(scenario_from_dict(d), shapes=False)
    t = np.asarray(run.time)
    windup = np.asarray(run["joint1_spring_torque"]) / K
    ringing = t > 0.002 + 1e-9
    assert np.abs(windup[ringing]).max() > 1e-6
    poles = identified_poles(t[ringing], windup[ringing], 2, 1)
    inertia = _crank_inertia(math.radians(CRANK))
    exact = math.sqrt(K * (1 / inertia + 1 / (GEAR**2 * ROTOR)))
    assert np.abs(poles).max() == pytest.approx(exact, rel=1e-6)  # measured 2.3e-7
    assert np.abs(np.asarray(run["joint1_angle"]) - math.radians(CRANK)).max() < 1e-4


def test_an_elastic_crank_with_a_stiff_flexible_coupler_follows_the_first_order_model(
        ) -> None:
    """The coupler flexible (EI = 20 N·m², 3 modes) under the bang-bang motor torque: the
    geometrically stiffened first-order model and the nonlinear one agree while the
    deflection is small."""
    d = _driven(0.02)
    d["simulation"].update(rtol=1e-8, geometric_stiffening=True)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": MASS[1], "EI": 20.0,
                     "modes": 3}
    d["sensors"] = [{"name": "bend", "kind": "deflection", "link": "coupler", "x": L2 / 2}]
    first, run = _both(d)
    _agree(first, run, ("joint1_angle", "joint3_angle", "joint1_spring_torque"), 1e-4)
    _agree(first, run, ("bend", "pin_force_y"), 1e-2)
    assert run.metadata["closure_residual_relative"] <= 1e-8


# -- a moving base --------------------------------------------------------------------------

def test_a_rigid_four_bar_on_a_free_base_is_the_first_order_mechanism() -> None:
    d = _swinging(flexible=False)
    d["joints"][0]["initial_rate_deg_s"] = 720.0
    d["base"] = {"type": "free", "mass": 2.0, "inertia": 0.01}
    d["simulation"]["t_end"] = 0.2
    first, run = _both(d)
    _agree(first, run, ("base_x", "base_y", "base_attitude", "joint1_angle", "joint3_angle",
                        "joint1_rate", "pin_force_x", "pin_force_y"), 1e-8)
    assert run.metadata["closure_residual_relative"] <= 1e-8


def _on_cart_and_in_gravity(d: dict) -> tuple:
    """The mechanism of ``d`` (a coupler sensor "bend" added) on a cart turned by 20°
    accelerating at ACCELERATION along the rail at RAIL, and fixed in the equivalent
    gravity: the cart's attitude turns the mechanism, so the fixed one is turned by it, in
    the field turned back. Both runs' results."""
    d["sensors"] = [{"name": "bend", "kind": "deflection", "link": "coupler", "x": 0.15}]
    d["base"] = {"type": "cart", "mass": 5.0, "attitude_deg": 20.0,
                 "cart": {"rail_angle_deg": math.degrees(RAIL), "drive": "prescribed",
                          "motion": [{"profile": "hold", "position": 0.0}]}}
    scenario = scenario_from_dict(d)
    cart = dataclasses.replace(scenario.base.cart, drive=UniformAcceleration(ACCELERATION))
    scenario = dataclasses.replace(scenario, base=dataclasses.replace(scenario.base, cart=cart))
    on_cart = flexlink.simulate(scenario, shapes=False)
    fixed = copy.deepcopy(d)
    del fixed["base"]
    turn = math.radians(20.0)
    fixed["simulation"]["gravity"] = [-ACCELERATION * math.cos(RAIL - turn),
                                      -ACCELERATION * math.sin(RAIL - turn)]
    return on_cart, flexlink.simulate(scenario_from_dict(fixed), shapes=False)


def test_a_uniformly_accelerated_cart_is_the_equivalent_gravity_field() -> None:
    """The four-bar with a flexible coupler on a cart accelerating at 3 m/s² along a 30°
    rail against the fixed four-bar in gravity −a along the rail, both on the nonlinear
    model (the equivalence principle holds exactly in it)."""
    d = _swinging()
    d["simulation"].update(model="nonlinear", t_end=0.3)
    on_cart, reference = _on_cart_and_in_gravity(d)
    for name in ("joint1_angle", "joint2_angle", "joint3_angle", "joint1_rate", "bend"):
        ref = np.asarray(reference[name])
        scale = np.abs(ref - ref[0]).max()
        assert scale > 0, name
        assert np.abs(np.asarray(on_cart[name]) - ref).max() < 1e-6 * scale, name
    force = np.hypot(on_cart["pin_force_x"], on_cart["pin_force_y"])
    ref = np.hypot(reference["pin_force_x"], reference["pin_force_y"])
    assert np.abs(force - ref).max() < 1e-6 * np.abs(ref).max()
    assert np.abs(np.asarray(on_cart["joint1_angle"]) - np.pi / 2).max() > 0.05  # it swung
    assert on_cart.metadata["closure_residual_relative"] <= 1e-8


def test_a_flexible_four_bar_on_a_free_base_keeps_its_momentum_and_energy() -> None:
    """A soft coupler (EI = 0.5 N·m², 3 modes, undamped) on a free base in space, the crank
    started at 2 rev/s: linear and angular momentum and the exact energy (the model's
    kinetic and strain energy from the states) constant; the loop closed."""
    d = _swinging()
    d["links"][1]["EI"] = 0.5
    d["joints"][0]["initial_rate_deg_s"] = 720.0
    d["base"] = {"type": "free", "mass": 2.0, "inertia": 0.01}
    d["simulation"].update(model="nonlinear", t_end=0.3, rtol=1e-9)
    scenario = scenario_from_dict(d)
    system = NonlinearForwardSystem(scenario.chain, scenario.base)
    loops = NonlinearLoopSystem(system, scenario.closures)
    t = np.linspace(0.0, 0.3, 301)
    run = integrate_nonlinear_loops(loops, t, 1e-9, 1e-12)
    y, v, _ = system.from_solution(run.solution)
    kinetic, strain = system.energy(t, y, v)
    energy = kinetic + strain
    assert strain.max() > 1e-4 * energy[0]  # the coupler bends
    assert np.abs(energy - energy[0]).max() < 1e-6 * energy[0]
    linear, angular = system.momentum(t, y, v)
    assert np.abs(linear - linear[0]).max() < 1e-7 * np.abs(linear).max()
    assert np.abs(angular - angular[0]).max() < 1e-7 * np.abs(angular).max()
    assert np.abs(y[:, system.n + 2] - y[0, system.n + 2]).max() > 0.05  # the base turned
    assert run.residual.max() < 1e-8 * loops.size


# -- controllers ----------------------------------------------------------------------------

def test_ppf_on_the_coupler_follows_the_first_order_model_at_small_deflection() -> None:
    """PPF at 2 kHz on the four-bar's coupler (0.2 V pulse: deflections of micrometres): the
    sensor, held voltage and pin force of both models agree; the loop reported closed."""
    d = _damped([], t_end=0.2)
    plant, f1 = _first_frequency(d)
    gain = 0.3 / abs(float(plant.C[0] @ np.linalg.solve(plant.A, plant.B)[:, 0]))
    d["controllers"] = [_ppf(f1, gain)]
    first, run = _both(d)
    assert run.metadata["controllers"] == 1 and run.metadata["model"] == "nonlinear"
    _agree(first, run, ("pzt", "patch_voltage", "ppf_command", "pin_force_y"), 1e-6)
    assert run.metadata["closure_residual_relative"] <= 1e-8


def test_an_over_gained_loop_on_the_nonlinear_model_is_reported_unstable() -> None:
    d = _damped([], t_end=0.5)
    plant, f1 = _first_frequency(d)
    gain = 50.0 / abs(float(plant.C[0] @ np.linalg.solve(plant.A, plant.B)[:, 0]))
    d["controllers"] = [_ppf(f1, gain)]
    d["simulation"]["model"] = "nonlinear"
    with pytest.raises(SimulationError, match="closed loop unstable"):
        flexlink.simulate(scenario_from_dict(d), shapes=False)


# -- the equilibrium start ------------------------------------------------------------------

@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_an_equilibrium_start_on_an_accelerating_cart_stays_at_rest_relative_to_it(
        model: str) -> None:
    """The four-bar (crank held, flexible coupler) on a cart accelerating at 3 m/s² from
    t = 0: started in equilibrium relative to the cart, the coupler's deflection stays
    constant and equals the fixed four-bar's in the equivalent gravity field (turned by
    the cart's 20° attitude), also started in equilibrium."""
    d = _swinging()
    d["joints"][0] = {"motion": [{"profile": "hold", "angle_deg": 90.0}]}
    d["links"][1]["EI"] = 2.0
    d["simulation"].update(model=model, t_end=0.2, initial="equilibrium")
    on_cart, reference = _on_cart_and_in_gravity(d)
    bend = np.asarray(on_cart["bend"])
    assert abs(bend[0]) > 1e-6
    assert np.ptp(bend) < 1e-9 * abs(bend[0])
    assert np.abs(bend - np.asarray(reference["bend"])).max() < 1e-9 * abs(bend[0])
    assert np.ptp(np.asarray(on_cart["joint3_angle"])) < 1e-12
    assert on_cart.metadata["closure_residual_relative"] <= 1e-8


def test_a_servo_held_crank_under_gravity_starts_in_equilibrium_on_the_nonlinear_model(
        ) -> None:
    """A position servo holds the crank of the four-bar (flexible coupler) under gravity:
    started in equilibrium, the nonlinear run stays still; the servo's torque is the
    weights' moment dV/dθ₁ on the rigid four-bar's kinematics (the coupler's sag apart),
    and the coupler's sag is the stiffened first-order model's (small deflection)."""
    from tests.validation.test_closed_loops import _four_bar_angles
    from tests.validation.test_loop_plant import _gravity_four_bar

    servo = {"drive": "servo", "servo": "position", "bandwidth": 30.0,
             "rate_limit_deg_s": 500.0, "loop_gain": 5.0, "motor_inertia": 0.001,
             "reference": [{"profile": "hold", "angle_deg": 90.0}]}
    first, run = _both(_gravity_four_bar(servo))
    crank = run["joint1_angle"][0]
    assert crank != pytest.approx(math.pi / 2, abs=1e-5)  # the servo yields to the load

    def potential(c: float) -> float:
        b1, b2, b3 = _four_bar_angles(c)
        return 9.81 * (MASS[0] * L1 * 0.5 * L1 * math.sin(b1)
                       + 0.3 * L2 * (L1 * math.sin(b1) + 0.5 * L2 * math.sin(b2))
                       + MASS[2] * L3 * 0.5 * L3 * math.sin(b3))

    h = 1e-6
    moment = (potential(crank + h) - potential(crank - h)) / (2 * h)
    assert run["joint1_torque"][0] == pytest.approx(moment, rel=1e-4)
    for name in ("joint1_angle", "joint3_angle", "mid"):
        assert np.ptp(run[name]) < 1e-9 * max(1.0, abs(run[name][0])), name
    assert run["mid"][0] == pytest.approx(first["mid"][0], rel=1e-6)  # measured 1.0e-8
    assert run["joint1_angle"][0] == pytest.approx(first["joint1_angle"][0], abs=1e-10)
