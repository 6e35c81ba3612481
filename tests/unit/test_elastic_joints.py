"""Elastic joints (dynamics/elastic_joints.py, _elastic_numba.py): the compiled kernels
against the numpy equations, and the spring and rotor terms against their definitions."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics import forward_kernel
from flexlink.dynamics.forward import ForwardSystem
from flexlink.model import (
    BangBang,
    Base,
    BaseLoad,
    Chain,
    ElasticJoint,
    Link,
    PositionServo,
    Step,
    TorqueDrive,
    VelocityServo,
)
from flexlink.motion import Cycloidal


def _servo_and_prescribed_motors(stiffening: bool) -> ForwardSystem:
    """Fixed base: link 1 on an elastic joint with a PID servo on its motor (gear 3), link 2
    on an elastic joint with a prescribed motor angle; gravity."""
    links = (Link("a", 1.2, 1.0, 60.0, tip_mass=0.2, modes=3), Link("b", 0.7, 0.5, 20.0, modes=2))
    servo = VelocityServo(Cycloidal(0.0, 270.0, 0.1, 1.0), P=5.0, I=2.0, D=0.01,
                          saturation=6.0, rate_per_volt=np.pi, loop_gain=2.0,
                          torque_limit=3.0, motor_inertia=0.004)
    joints = (ElasticJoint(servo, stiffness=80.0, damping=0.3, gear_ratio=3.0),
              ElasticJoint(Cycloidal(10.0, 60.0, 0.2, 0.8), stiffness=15.0, damping=0.05))
    return ForwardSystem(Chain(links, joints), Base(), stiffening, gravity=(0.0, -9.81))


def _torque_motor_on_pinned_hub(stiffening: bool) -> ForwardSystem:
    """Pinned base with a moment: link 1 on an elastic joint whose motor is torque-driven
    (gear −2), link 2 on a position servo, link 3 on an elastic joint with a servo motor."""
    links = (Link("a", 1.5, 1.0, 30.0, modes=3), Link("b", 0.8, 0.6, 10.0, modes=2),
             Link("c", 0.5, 0.4, 5.0, modes=0))
    base = Base("pinned", inertia=0.9, attachments=((0, (0.2, 0.1)),),
                loads=(BaseLoad(moment=Step(0.4)),), rate=0.2)
    joints = (ElasticJoint(TorqueDrive(BangBang(0.5, 0.1, 0.6), initial_angle=0.4,
                                       initial_rate=-0.2, motor_inertia=0.02),
                           stiffness=40.0, damping=0.1, gear_ratio=-2.0),
              PositionServo(Cycloidal(0.0, 30.0, 0.0, 1.0), bandwidth=20.0, rate_limit=2.0,
                            loop_gain=0.8, motor_inertia=0.003),
              ElasticJoint(PositionServo(Cycloidal(0.0, -40.0, 0.0, 1.0), bandwidth=10.0,
                                         rate_limit=3.0, loop_gain=0.5, motor_inertia=0.001),
                           stiffness=5.0))
    return ForwardSystem(Chain(links, joints), base, stiffening)


SYSTEMS = {"servo_prescribed": _servo_and_prescribed_motors,
           "torque_pinned": _torque_motor_on_pinned_hub}


@pytest.mark.parametrize("stiffening", [False, True])
@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_kernel_matches_the_numpy_equations(name: str, stiffening: bool) -> None:
    """p̈_free (link and motor angles), z̈ and the integral rates agree with the numpy
    ForwardSystem.accelerations to 1e-10 of their size on random states (light rotors
    make the systems stiffer than the rigid-joint ones of test_forward_kernel.py)."""
    system = SYSTEMS[name](stiffening)
    rng = np.random.default_rng(3)
    nt, nu, n, ns = 10, len(system.free), system.n, len(system.servos)
    t = rng.uniform(0.0, 1.2, nt)
    p_free = rng.uniform(-2.0, 2.0, (nt, nu))
    pd_free = rng.normal(size=(nt, nu))
    z, zd = 1e-2 * rng.normal(size=(nt, n)), 0.3 * rng.normal(size=(nt, n))
    integral = 0.2 * rng.normal(size=(nt, ns))
    expected = system.accelerations(t, p_free, pd_free, z, zd, integral)
    got = forward_kernel.accelerations(system, t, p_free, pd_free, z, zd, integral)
    for ours, theirs in zip(got, expected):
        scale = np.abs(theirs).max(initial=0.0)
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10 * scale)


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_joint_torques_match_the_numpy_equations(name: str) -> None:
    system = SYSTEMS[name](False)
    rng = np.random.default_rng(5)
    nt, nr, n = 7, system.n_rigid, system.n
    p, pd, pdd = (rng.normal(size=(nt, nr)) for _ in range(3))
    z, zd, zdd = 1e-2 * rng.normal(size=(nt, n)), rng.normal(size=(nt, n)), rng.normal(size=(nt, n))
    expected = system.joint_torques(p, pd, pdd, z, zd, zdd)
    got = forward_kernel.joint_torques(system, p, pd, pdd, z, zd, zdd)
    assert expected.shape == (nt, len(system.chain.links))
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-11 * np.abs(expected).max())


def test_spring_and_rotor_on_a_rigid_link() -> None:
    """A rigid link of inertia m L²/3 on a spring to a rotor J_m through gear N: β̈ = τ_s/J,
    θ̈_m = −τ_s/(N J_m), τ_s = k (θ_m/N − β) + c (θ̇_m/N − β̇)."""
    k, c, N, Jm = 20.0, 0.4, 2.0, 0.1
    chain = Chain((Link("a", 1.0, 1.0, 50.0, modes=0),),
                  (ElasticJoint(TorqueDrive(Step(0.0), initial_angle=0.2, motor_inertia=Jm),
                                stiffness=k, damping=c, gear_ratio=N),))
    system = ForwardSystem(chain, Base())
    assert system.free == [0, 1] and system.n_rigid == 2
    np.testing.assert_allclose(system.initial_state(), [0.1, 0.2, 0.0, 0.0])
    beta, motor, rate, motor_rate = 0.05, 0.3, 0.2, -0.6
    tau = k * (motor / N - beta) + c * (motor_rate / N - rate)
    pdd, _, _ = system.accelerations(np.zeros(1), np.array([[beta, motor]]),
                                     np.array([[rate, motor_rate]]), np.zeros((1, 0)),
                                     np.zeros((1, 0)), np.zeros((1, 0)))
    np.testing.assert_allclose(pdd[0], [tau / (1.0 / 3.0), -tau / (N * Jm)], rtol=1e-13)


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_nonlinear_kernels_match_the_numpy_equations(name: str) -> None:
    """The nonlinear model with elastic joints: the compiled residual and accelerations
    agree with the numpy reference (as tests/unit/test_nonlinear_forward.py for the others)."""
    from flexlink.dynamics._nonlinear_forward_numba import residual
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem

    first_order = SYSTEMS[name](True)
    system = NonlinearForwardSystem(first_order.chain, first_order.base,
                                    gravity=first_order.gravity)
    assert system.nu == len(first_order.free)
    rng = np.random.default_rng(9)
    t = rng.uniform(0.0, 1.2, 8)
    y, v, a = (rng.normal(size=(8, system.n_y)) for _ in range(3))
    y[:, :system.n] *= 0.05
    expected = system.accelerations(t, y, v, compiled=False)
    got = system.accelerations(t, y, v, compiled=True)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    inp = system.stage_inputs(t)
    reference = system.residual(t, y, v, a, inp)
    data = system.kernel_data()
    out = np.empty(system.n_y)
    for i in range(t.size):
        residual(data, y[i], v[i], a[i], *(np.ascontiguousarray(x[i]) for x in inp), out)
        np.testing.assert_allclose(out, reference[i], rtol=0,
                                   atol=1e-11 * np.abs(reference[i]).max())


def test_both_models_share_the_spring_and_rotor() -> None:
    """At an undeformed state the nonlinear model's rigid accelerations are the first-order
    model's (both exact for rigid motion; the links' mass integrals by quadrature in one,
    closed form in the other): the spring torques and rotor inertias agree."""
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem

    first_order = _torque_motor_on_pinned_hub(False)
    system = NonlinearForwardSystem(first_order.chain, first_order.base)
    rng = np.random.default_rng(2)
    nu, n = len(first_order.free), first_order.n
    t = rng.uniform(0.0, 1.0, 4)
    p, pd = rng.normal(size=(4, nu)), rng.normal(size=(4, nu))
    integral = 0.1 * rng.normal(size=(4, len(first_order.servos)))
    pdd, _, rates = first_order.accelerations(t, p, pd, np.zeros((4, n)), np.zeros((4, n)),
                                              integral)
    y, v = np.zeros((4, system.n_y)), np.zeros((4, system.n_y))
    y[:, n:n + nu], v[:, n:n + nu], v[:, n + nu:] = p, pd, integral
    a = system.accelerations(t, y, v, compiled=False)
    np.testing.assert_allclose(a[:, n:n + nu], pdd, rtol=0, atol=1e-8 * np.abs(pdd).max())
    np.testing.assert_allclose(a[:, n + nu:], rates, rtol=0, atol=1e-12 * np.abs(rates).max())


def _scenario(**joint: object) -> dict:
    return {"simulation": {"t_end": 0.1, "dt_out": 0.01},
            "links": [{"name": "a", "length": 1.0, "mass_per_length": 0.5, "EI": 3.0}],
            "joints": [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 1.0}],
                        "motor_inertia": 1e-3, "spring_stiffness": 50.0, **joint}]}


@pytest.mark.parametrize(("joint", "field"), [
    ({"spring_stiffness": 0.0}, "joints[0].spring_stiffness"),
    ({"spring_stiffness": -3.0}, "joints[0].spring_stiffness"),
    ({"spring_damping": -0.1}, "joints[0].spring_damping"),
    ({"gear_ratio": 0.0}, "joints[0].gear_ratio"),
    ({"motor_inertia": -1e-3}, "joints[0].motor_inertia"),
    ({"motor_inertia": 0.0}, "joints[0].motor_inertia"),
    ({"spring_stiffness": "stiff"}, "joints[0].spring_stiffness"),
])
def test_bad_elastic_joints_are_refused_naming_the_field(joint: dict, field: str) -> None:
    from flexlink.scenario import ScenarioError, scenario_from_dict

    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(_scenario(**joint))
    assert any(m.startswith(field) for m in info.value.problems), info.value.problems


def test_an_elastic_joint_reads_its_motor_from_the_rest_of_the_table() -> None:
    """Torque and servo drives and a prescribed motion become the motor of the elastic joint;
    a prescribed motor needs no rotor inertia."""
    from flexlink.scenario import scenario_from_dict

    joint = scenario_from_dict(_scenario(spring_damping=0.2, gear_ratio=-4.0)).chain.joints[0]
    assert isinstance(joint, ElasticJoint) and isinstance(joint.motor, TorqueDrive)
    assert (joint.stiffness, joint.damping, joint.gear_ratio, joint.rotor_inertia) == (
        50.0, 0.2, -4.0, 1e-3)
    d = _scenario()
    d["joints"] = [{"motion": [{"profile": "hold", "angle_deg": 30.0}], "spring_stiffness": 9.0}]
    joint = scenario_from_dict(d).chain.joints[0]
    assert isinstance(joint, ElasticJoint) and joint.rotor_inertia == 0.0
    assert scenario_from_dict(d).is_forward


_HOLDING_MOTORS = (
    {"motion": [{"profile": "hold", "angle_deg": 0.0}]},
    {"drive": "servo", "servo": "velocity_pid", "P": 2.0, "I": 5.0, "rate_per_volt_deg_s": 60.0,
     "loop_gain": 5.0, "motor_inertia": 1e-3, "reference": [{"profile": "hold", "angle_deg": 0.0}]})


def _hanging_on_the_spring(motor: dict, model: str, link: dict) -> dict:
    return {"simulation": {"t_end": 0.5, "dt_out": 0.005, "gravity": [0.0, -9.81],
                           "initial": "equilibrium", "model": model},
            "links": [{"name": "a", "length": 1.0, "mass_per_length": 0.8, "tip_mass": 0.3,
                       **link}],
            "joints": [{"spring_stiffness": 40.0, **motor}]}


def test_equilibrium_start_holds_the_weight_on_the_spring() -> None:
    """A rigid horizontal arm under gravity on an elastic joint, its motor held at 0 (servo
    with an integrator, or prescribed): started in equilibrium the link sags to
    β = −M_g cos β / k (M_g = (m L/2 + m_t L) g) and stays there; the spring torque is the
    weight's moment, the motor stays at 0."""
    from scipy.optimize import brentq

    from flexlink.scenario import scenario_from_dict
    from flexlink.simulation import simulate

    moment = (0.8 / 2 + 0.3) * 9.81
    exact = brentq(lambda b: b + moment * np.cos(b) / 40.0, -1.5, 0.0, xtol=1e-14)
    for motor in _HOLDING_MOTORS:
        results = simulate(scenario_from_dict(_hanging_on_the_spring(motor, "first_order",
                                                                     {"rigid": True})))
        np.testing.assert_allclose(results["joint1_angle"], exact, rtol=0, atol=1e-9)
        np.testing.assert_allclose(results["joint1_spring_torque"], moment * np.cos(exact),
                                   rtol=1e-8)
        np.testing.assert_allclose(results["joint1_motor_angle"], 0.0, rtol=0, atol=1e-9)


def test_equilibrium_start_of_the_nonlinear_model() -> None:
    """The nonlinear model started in equilibrium with a flexible arm (static deflection
    0.4% of its length) on the spring stays at rest, at the first-order model's equilibrium
    (to the two models' difference at that deflection)."""
    from flexlink.scenario import scenario_from_dict
    from flexlink.simulation import simulate

    link = {"EI": 500.0, "modes": 2}
    for motor in _HOLDING_MOTORS:
        ours = simulate(scenario_from_dict(_hanging_on_the_spring(motor, "nonlinear", link)))
        first = simulate(scenario_from_dict(_hanging_on_the_spring(motor, "first_order", link)))
        angle = np.asarray(ours["joint1_angle"])
        assert np.ptp(angle) < 1e-9 and np.ptp(np.asarray(ours["a_tip_Y"])) < 1e-9
        assert abs(angle[0] - first["joint1_angle"][0]) < 1e-3 * abs(angle[0])


def test_the_animation_marks_elastic_joints() -> None:
    """A run's arm track lists the links on elastic joints (drawn with a ring at the root);
    a rigid joint is not listed."""
    from flexlink.results.arm_tracks import run_track
    from flexlink.scenario import scenario_from_dict
    from flexlink.simulation import simulate

    d = _scenario()
    d["links"].append({"name": "b", "length": 0.5, "mass_per_length": 0.5, "EI": 3.0})
    d["joints"].append({"motion": [{"profile": "hold", "angle_deg": 10.0}]})
    track = run_track(simulate(scenario_from_dict(d)))
    assert track.springs == (0,)


def test_frozen_time_plant_of_a_moving_arm_keeps_gravity() -> None:
    """The plant at a moving state (the Jacobian of the equations the run integrates) has the
    gravity stiffness: a rigid pendulum (m, L) released level, at t = 0.3 s its angle β gives
    ∂β̈/∂β = m g (L/2) sin β / (m L²/3); the motor angle of an elastic joint hanging the same
    pendulum on a spring has its row too."""
    from flexlink.control.linearization import linearize
    from flexlink.scenario import scenario_from_dict

    g = 9.81
    d = {"simulation": {"t_end": 1.0, "dt_out": 0.01, "gravity": [0.0, -g], "rtol": 1e-9},
         "links": [{"name": "a", "length": 1.0, "mass_per_length": 1.0, "rigid": True}],
         "joints": [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.0}]}]}
    plant = linearize(scenario_from_dict(d), at=0.3)
    beta = plant.operating_point["joint1_angle"]
    assert beta < -0.2  # falling
    np.testing.assert_allclose(plant.A[1, 0], g * 0.5 * np.sin(beta) / (1.0 / 3.0), rtol=1e-5)
    d["joints"][0].update(spring_stiffness=30.0, gear_ratio=2.0, motor_inertia=0.01)
    plant = linearize(scenario_from_dict(d), at=0.3)
    assert plant.state_names[:2] == ("joint1_angle", "joint1_motor_angle")
    beta = plant.operating_point["joint1_angle"]
    np.testing.assert_allclose(plant.A[2, :2], [(g * 0.5 * np.sin(beta) - 30.0) * 3.0,
                                                30.0 / 2.0 * 3.0], rtol=1e-5)
    np.testing.assert_allclose(plant.A[3, :2], [30.0 / 2.0 / 0.01, -30.0 / 4.0 / 0.01],
                               rtol=1e-5)
