"""The compiled forward-dynamics kernel (dynamics/_forward_numba.py) against the numpy
ForwardSystem, the reference: the same accelerations to round-off on random states."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics import forward_kernel
from flexlink.dynamics.forward import ForwardSystem
from flexlink.model import (
    BangBang,
    Base,
    BaseLoad,
    Body,
    Chain,
    Link,
    PiezoActuator,
    PositionServo,
    Step,
    Sum,
    Table,
    TorqueDrive,
    VelocityServo,
)
from flexlink.motion import Cycloidal, Hold
from tests.helpers import CubicMotion, paper_links


def _patch(name: str, link: int, x0: float, x1: float, voltage, limit: float = np.inf
           ) -> PiezoActuator:
    return PiezoActuator(name, link, x0, x1, 0.025, 30.33e9, 265e-12, 0.002, voltage, limit)


def _free_two_appendages(stiffening: bool, actuators: bool = False) -> ForwardSystem:
    links = (Link("a", 2.0, 1.0, 50.0, tip_mass=0.3, tip_inertia=0.01, modes=2),
             Link("b", 1.5, 1.0, 40.0, modes=3),
             Link("c", 0.8, 0.5, 20.0, modes=2))
    loads = (BaseLoad(force_x=Step(2.0), moment=BangBang(1.5, 0.0, 2.0), point=(0.1, 0.2)),
             BaseLoad(force_y=Sum((Step(1.0), Step(-0.5, 0.3))), point=(-0.2, 0.1),
                      frame="body"))
    base = Base("free", mass=20.0, inertia=5.0, attachments=((0, (0.5, 0.0)), (1, (-0.5, 0.1))),
                loads=loads, position=(0.3, 0.2), velocity=(0.1, -0.05), rate=0.2)
    chain = Chain(links, (TorqueDrive(BangBang(2.0, 0.0, 4.0), initial_angle=0.2,
                                      motor_inertia=0.02),
                          Hold(180.0), CubicMotion(0.3, 0.5, -0.2, 0.1)))
    patches = ((_patch("a1", 0, 0.1, 0.4, Step(150.0, 0.2)),
                _patch("b1", 1, 0.3, 0.9, BangBang(200.0, 0.1, 1.0), limit=120.0),
                _patch("c1", 2, 0.0, 0.8, Sum((Step(80.0), Step(-30.0, 0.5)))))
               if actuators else ())
    return ForwardSystem(chain, base, stiffening, patches)


def _pinned_hub(stiffening: bool) -> ForwardSystem:
    links = (Link("beam", 2.0, 1.0, 10.0, modes=4), Link("outer", 1.0, 0.5, 5.0, modes=2))
    loads = (BaseLoad(moment=Step(0.7), force_x=Step(3.0), point=(0.0, 0.4), frame="body"),)
    base = Base("pinned", inertia=0.8, attachments=((0, (0.2, 0.0)),), loads=loads, rate=0.4)
    chain = Chain(links, (CubicMotion(0.1, 0.3, 0.4, -0.1),
                          TorqueDrive(Table((0.0, 1.0, 2.0), (0.5, -0.2, 0.3)))))
    return ForwardSystem(chain, base, stiffening)


def _paper_servos(stiffening: bool, actuators: bool = False) -> ForwardSystem:
    servo1 = VelocityServo(Cycloidal(0.0, 90.0, 0.1, 1.0), P=5.0, I=2.0, D=0.005,
                           saturation=6.0, rate_per_volt=np.pi, loop_gain=50.0,
                           torque_limit=800.0, motor_inertia=0.05)
    servo2 = PositionServo(Cycloidal(1.5, 3.0, 0.1, 1.0), bandwidth=30.0, rate_limit=0.5,
                           loop_gain=0.5, torque_limit=0.4, motor_inertia=0.001)
    patches = ((_patch("p1", 0, 0.05, 0.2, Table((0.0, 0.5, 1.5), (0.0, 100.0, -50.0))),
                _patch("p2", 1, 0.1, 0.3, Step(300.0), limit=200.0)) if actuators else ())
    return ForwardSystem(Chain(paper_links(3), (servo1, servo2)), Base(), stiffening, patches)


def _in_gravity(system: ForwardSystem) -> ForwardSystem:
    """The same system in a uniform field with both components (m/s², global axes)."""
    return ForwardSystem(system.chain, system.base, system.geometric_stiffening,
                         system.actuators, gravity=(2.5, -9.81))


def _bodies(stiffening: bool) -> ForwardSystem:
    """A torque-driven link and a servo-driven one carrying rigid bodies (an offset tip body,
    bodies inside the span) on a pinned base, in gravity."""
    links = (Link("a", 1.2, 0.8, 30.0, modes=3, mode_shapes="tip_loaded",
                  bodies=(Body(1.2, 0.3, (0.1, 0.06), 0.01), Body(0.5, 0.2, (-0.05, -0.08), 0.003))),
             Link("b", 0.9, 0.5, 12.0, tip_mass=0.05, modes=2,
                  bodies=(Body(0.4, 0.1, (0.2, 0.0), 0.0), Body(0.9, 0.0, (0.0, 0.0), 0.002),
                          Body(0.2, 0.15, (0.0, 0.1), 0.001))))
    base = Base("pinned", inertia=0.8, attachments=((0, (0.2, 0.0)),), rate=0.4)
    servo = PositionServo(Cycloidal(1.5, 3.0, 0.1, 1.0), bandwidth=30.0, rate_limit=0.5,
                          loop_gain=0.5, torque_limit=0.4, motor_inertia=0.02)
    chain = Chain(links, (TorqueDrive(Table((0.0, 1.0, 2.0), (0.5, -0.2, 0.3)), motor_inertia=0.05),
                          servo))
    return ForwardSystem(chain, base, stiffening, gravity=(1.5, -9.81))


SYSTEMS = {"free": _free_two_appendages, "bodies_gravity": _bodies, "pinned": _pinned_hub, "servos": _paper_servos,
           "free_actuators": lambda s: _free_two_appendages(s, True),
           "servos_actuators": lambda s: _paper_servos(s, True),
           "free_gravity": lambda s: _in_gravity(_free_two_appendages(s)),
           "pinned_gravity": lambda s: _in_gravity(_pinned_hub(s)),
           "servos_gravity": lambda s: _in_gravity(_paper_servos(s))}


@pytest.mark.parametrize("stiffening", [False, True])
@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_kernel_matches_the_numpy_equations(name: str, stiffening: bool) -> None:
    """Random rigid states, deflections, rates and servo integrals (saturating and not):
    p̈_free, z̈ and the integral rates agree with ForwardSystem.accelerations to 1e-11 of
    their size."""
    system = SYSTEMS[name](stiffening)
    rng = np.random.default_rng(7)
    nt, nu, n, ns = 12, len(system.free), system.n, len(system.servos)
    t = rng.uniform(0.0, 1.5, nt)
    p_free = rng.uniform(-2.0, 2.0, (nt, nu))
    pd_free = rng.normal(size=(nt, nu))
    z, zd = 1e-2 * rng.normal(size=(nt, n)), 0.3 * rng.normal(size=(nt, n))
    integral = 0.2 * rng.normal(size=(nt, ns))
    expected = system.accelerations(t, p_free, pd_free, z, zd, integral)
    got = forward_kernel.accelerations(system, t, p_free, pd_free, z, zd, integral)
    for ours, theirs in zip(got, expected):
        scale = np.abs(theirs).max(initial=0.0)
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-11 * scale)


def test_servo_limits_are_exercised() -> None:
    """The random states of the comparison reach both sides of the servo limits (saturated
    PID command, rate limit, torque limit), so the comparison covers every branch."""
    system = _paper_servos(True)
    rng = np.random.default_rng(7)
    t = rng.uniform(0.0, 1.5, 12)
    p = rng.uniform(-2.0, 2.0, (12, 2))
    pd = rng.normal(size=(12, 2))
    rng.normal(size=(2, 12, system.n))  # z, ż: the same draws as the comparison
    integral = 0.2 * rng.normal(size=(12, 1))
    s1, s2 = system.chain.joints
    ref1, rate1, _ = s1.reference.evaluate(t)
    raw = s1.P * (ref1 - p[:, 0]) + s1.I * integral[:, 0] + s1.D * (rate1 - pd[:, 0])
    assert np.any(np.abs(raw) > s1.saturation) and np.any(np.abs(raw) < s1.saturation)
    command = s2.bandwidth * (s2.reference.evaluate(t)[0] - p[:, 1])
    assert np.any(np.abs(command) > s2.rate_limit) and np.any(np.abs(command) < s2.rate_limit)
    tau1 = s1.loop_gain * (s1.rate_per_volt * np.clip(raw, -s1.saturation, s1.saturation) - pd[:, 0])
    assert np.any(np.abs(tau1) > s1.torque_limit) and np.any(np.abs(tau1) < s1.torque_limit)


def test_breakpoints_of_inputs() -> None:
    """Jumps of torque and load histories and the ends of motion profiles are breakpoints."""
    system = _free_two_appendages(True)
    times = forward_kernel.breakpoints(system)
    for b in (0.0, 1.0, 2.0, 0.3, 4.0):
        assert np.any(np.isclose(times, b)), b
    assert np.all(np.isfinite(times))
    for b in (0.2, 0.1, 1.1, 0.5):  # the actuators' voltage histories
        assert np.any(np.isclose(forward_kernel.breakpoints(_free_two_appendages(True, True)),
                                 b)), b


def test_actuators_load_the_elastic_rows_only() -> None:
    """The actuators' forces are B V on z, B from dynamics/actuators.py, V clipped to the
    limit; the kernel's input row carries V (so the comparison above covers the forces)."""
    from flexlink.dynamics.actuators import actuator_matrix

    system = _free_two_appendages(True, True)
    t = np.array([0.0, 0.3, 0.7])
    V = system.voltages(t)
    np.testing.assert_array_equal(V[:, 1], [0.0, 120.0, -120.0])  # ±200 V clipped at 120 V
    p = np.zeros((3, system.n_rigid))
    Q, _ = system.applied(t, p, p, np.zeros((3, 0)))
    without = ForwardSystem(system.chain, system.base, True)
    Q0, _ = without.applied(t, p, p, np.zeros((3, 0)))
    np.testing.assert_allclose(Q[:, :system.n_rigid], Q0[:, :system.n_rigid])
    np.testing.assert_allclose(Q[:, system.n_rigid:] - Q0[:, system.n_rigid:],
                               V @ actuator_matrix(system.actuators, system.modal).T)
    u = forward_kernel.inputs(system, t)
    np.testing.assert_array_equal(u[:, forward_kernel.voltage_columns(system)], V)


@pytest.mark.parametrize("stiffening", [False, True])
@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_joint_torques_match_the_numpy_equations(name: str, stiffening: bool) -> None:
    """The compiled joint rows (the torque channels) equal ForwardSystem.joint_torques to
    1e-11 of their size on random rigid states, accelerations and deflections."""
    system = SYSTEMS[name](stiffening)
    rng = np.random.default_rng(11)
    nt, nr, n = 9, system.n_rigid, system.n
    p, pd, pdd = rng.uniform(-2.0, 2.0, (nt, nr)), rng.normal(size=(nt, nr)), rng.normal(size=(nt, nr))
    z, zd, zdd = 1e-2 * rng.normal(size=(nt, n)), 0.3 * rng.normal(size=(nt, n)), rng.normal(size=(nt, n))
    expected = system.joint_torques(p, pd, pdd, z, zd, zdd)
    got = forward_kernel.joint_torques(system, p, pd, pdd, z, zd, zdd)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-11 * np.abs(expected).max())


def test_the_rates_kernels_run_without_reference_counting() -> None:
    """Every compiled kernel a rate evaluation passes the records to is compiled with
    _nrt=False: with numba's runtime, each call increfs and decrefs every array of
    ForwardData and the workspace, which cost more than a servo's arithmetic (ARCHITECTURE.md)."""
    from flexlink.dynamics import _elastic_numba, _forward_numba, _momentum_numba, _prismatic_numba

    kernels = [getattr(_forward_numba, name) for name in (
        "base_acceleration", "map_columns", "frames", "residual", "applied", "_drive", "_solve",
        "rates", "rates_in", "state_rates", "joint_torques")]
    kernels += [_elastic_numba.prescribed_motors, _elastic_numba.spring_torques,
                _elastic_numba.rotor_inertia, _prismatic_numba.lever_stiffness,
                _momentum_numba.momentum, _momentum_numba.project]
    counted = [k.py_func.__name__ for k in kernels if k.targetoptions.get("_nrt", True)]
    assert not counted, f"compiled with reference counting: {counted}"
