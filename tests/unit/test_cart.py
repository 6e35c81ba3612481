"""A cart on a straight rail (model.Cart, a base with one coordinate along the rail): the
compiled kernel against the numpy ForwardSystem, the cart's inputs, momentum and force."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics import forward_kernel
from flexlink.dynamics.forward import ForwardSystem, momentum
from flexlink.model import (
    BangBang,
    Base,
    BaseLoad,
    Cart,
    Chain,
    ElasticJoint,
    Link,
    PositionServo,
    Step,
    TorqueDrive,
    VelocityServo,
)
from flexlink.motion import Hold
from tests.helpers import CubicMotion


def _links() -> tuple[Link, ...]:
    return (Link("beam", 1.2, 0.8, 30.0, tip_mass=0.2, tip_inertia=0.004, modes=3),
            Link("outer", 0.6, 0.4, 8.0, modes=2))


def _loads() -> tuple[BaseLoad, ...]:
    return (BaseLoad(force_x=Step(2.0), force_y=Step(-1.0, 0.2), moment=Step(0.5)),
            BaseLoad(force_x=BangBang(1.5, 0.0, 1.0), point=(0.1, 0.0), frame="body"))


def _cart(drive, joints, gravity=(0.0, 0.0), stiffening=True) -> ForwardSystem:
    base = Base("cart", mass=3.0, attachments=((0, (0.1, -0.05)),), loads=_loads(),
                position=(0.2, 0.1), attitude=0.3, cart=Cart(drive, rail_angle=0.4))
    return ForwardSystem(Chain(_links(), joints), base, stiffening, gravity=gravity)


SYSTEMS = {
    "force": lambda s: _cart(TorqueDrive(BangBang(5.0, 0.0, 1.0), 0.1, 0.2),
                             (TorqueDrive(Step(0.3), 0.2), Hold(30.0)), stiffening=s),
    "prescribed": lambda s: _cart(CubicMotion(0.1, 0.3, -0.4, 0.2),
                                  (TorqueDrive(Step(0.3), 0.2), CubicMotion(0.2, 0.1, 0.3)),
                                  (0.0, -9.81), s),
    "position_servo": lambda s: _cart(
        PositionServo(CubicMotion(0.0, 0.2, 0.5), bandwidth=20.0, rate_limit=0.4,
                      loop_gain=40.0, torque_limit=15.0),
        (VelocityServo(CubicMotion(0.1, 0.5), P=5.0, I=2.0, D=0.01, saturation=6.0,
                       rate_per_volt=3.0, loop_gain=20.0), Hold(-20.0)), (1.0, -9.81), s),
    "pid_servo": lambda s: _cart(
        VelocityServo(CubicMotion(0.0, 0.2, 0.5), P=20.0, I=0.0, D=0.5, saturation=6.0,
                      rate_per_volt=0.1, loop_gain=50.0, torque_limit=20.0),
        (Hold(90.0), TorqueDrive(Step(-0.1))), (0.0, -9.81), s),
    "pid_integral": lambda s: _cart(
        VelocityServo(CubicMotion(0.0, 0.2, 0.5), P=20.0, I=8.0, D=0.5, saturation=6.0,
                      rate_per_volt=0.1, loop_gain=50.0, torque_limit=20.0),
        (VelocityServo(CubicMotion(0.1, 0.5), P=5.0, I=2.0, D=0.01, saturation=6.0,
                       rate_per_volt=3.0, loop_gain=20.0), Hold(-20.0)), (0.0, -9.81), s),
    "elastic_joints": lambda s: _cart(
        TorqueDrive(BangBang(5.0, 0.0, 1.0), 0.1, 0.2),
        (ElasticJoint(TorqueDrive(Step(0.1), 1.0, motor_inertia=2e-2), 20.0, 0.1, 4.0),
         Hold(30.0)), (0.0, -9.81), s),
}


@pytest.mark.parametrize("stiffening", [False, True])
@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_kernel_matches_the_numpy_equations(name: str, stiffening: bool) -> None:
    """Random states: p̈_free, z̈ and the servo integral rates of the compiled kernel equal
    ForwardSystem.accelerations to 1e-10 of their size (random states make the
    system stiff: its condition number is ~1e5)."""
    system = SYSTEMS[name](stiffening)
    rng = np.random.default_rng(3)
    nt, nu, n, ns = 12, len(system.free), system.n, len(system.servos)
    t = rng.uniform(0.0, 1.5, nt)
    p_free, pd_free = rng.uniform(-2.0, 2.0, (nt, nu)), rng.normal(size=(nt, nu))
    z, zd = 1e-2 * rng.normal(size=(nt, n)), 0.3 * rng.normal(size=(nt, n))
    integral = 0.2 * rng.normal(size=(nt, ns))
    expected = system.accelerations(t, p_free, pd_free, z, zd, integral)
    got = forward_kernel.accelerations(system, t, p_free, pd_free, z, zd, integral)
    for ours, theirs in zip(got, expected):
        scale = np.abs(theirs).max(initial=0.0)
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10 * scale)


def test_a_prescribed_cart_is_not_a_free_coordinate() -> None:
    system = SYSTEMS["prescribed"](True)
    assert system.free == [system.n_base + 0]
    assert SYSTEMS["force"](True).free == [0, 1]


def test_the_rail_takes_every_load_across_it() -> None:
    """With the rail along X and no attitude, a force along Y and a moment do nothing to
    the cart's travel row; a force along X is its force."""
    base = Base("cart", mass=2.0, loads=(BaseLoad(force_x=Step(3.0), force_y=Step(7.0),
                                                  moment=Step(5.0)),), cart=Cart())
    system = ForwardSystem(Chain((Link("b", 1.0, 1.0, 10.0, modes=2),), (Hold(0.0),)), base)
    t = np.array([0.5])
    p = np.zeros((1, system.n_rigid))
    Q, _ = system.applied(t, p, p, np.zeros((1, 0)))
    assert Q[0, 0] == pytest.approx(3.0)


def test_cart_force_is_the_drive_force_of_a_force_driven_cart() -> None:
    """Along a solution of the equations the travel row less the loads along the rail is the
    drive's force: p̈, z̈ from accelerations, then cart_force returns the force history."""
    system = SYSTEMS["force"](True)
    rng = np.random.default_rng(5)
    nt, nu, n = 6, len(system.free), system.n
    t = rng.uniform(0.0, 1.5, nt)
    p_free, pd_free = rng.uniform(-1.0, 1.0, (nt, nu)), rng.normal(size=(nt, nu))
    z, zd = 1e-2 * rng.normal(size=(nt, n)), 0.3 * rng.normal(size=(nt, n))
    pdd_free, zdd, _ = system.accelerations(t, p_free, pd_free, z, zd, np.zeros((nt, 0)))
    p, pd, pdd = system.rigid_state(t, p_free, pd_free, pdd_free)
    force = system.cart_force(t, p, pd, pdd, z, zd, zdd)
    np.testing.assert_allclose(force, BangBang(5.0, 0.0, 1.0).value(t), atol=1e-9)


def test_momentum_of_a_rigid_cart_and_link() -> None:
    """Rigid link of mass m, length L at angle θ on a cart of mass M moving at ṡ along a
    rail at angle φ: linear momentum (M + m) ṡ e + m (L/2) θ̇ e⊥(θ)."""
    M, m, L, phi = 3.0, 1.5, 0.8, 0.4
    base = Base("cart", mass=M, cart=Cart(TorqueDrive(Step(0.0)), rail_angle=phi))
    chain = Chain((Link("bar", L, m / L, 1.0, modes=0),), (TorqueDrive(Step(0.0)),))
    system = ForwardSystem(chain, base)
    p = np.array([[0.3, 0.7]])
    pd = np.array([[0.5, -1.2]])
    lin, _ = momentum(system, p, pd, np.zeros((1, 0)), np.zeros((1, 0)))
    e = np.array([np.cos(phi), np.sin(phi)])
    expected = (M + m) * 0.5 * e + m * L / 2 * -1.2 * np.array([-np.sin(0.7), np.cos(0.7)])
    np.testing.assert_allclose(lin[0], expected, atol=1e-12)


def _nonlinear(name: str):
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem

    system = SYSTEMS[name](True)
    return NonlinearForwardSystem(system.chain, system.base, gravity=system.gravity)


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_nonlinear_kernel_matches_its_numpy_equations(name: str) -> None:
    """The compiled nonlinear forward accelerations with a cart equal the numpy residual's
    to 1e-9 of their size on random states."""
    system = _nonlinear(name)
    rng = np.random.default_rng(9)
    b, m, n = 5, system.n_y, system.n
    t = rng.uniform(0.0, 1.5, b)
    y, v = rng.normal(size=(b, m)), rng.normal(size=(b, m))
    y[:, :n] *= 0.05
    expected = system.accelerations(t, y, v, compiled=False)
    got = system.accelerations(t, y, v)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def test_nonlinear_cart_force_is_the_drive_force() -> None:
    """On a solution of the nonlinear equations a force-driven cart's force is its force
    history."""
    system = _nonlinear("force")
    rng = np.random.default_rng(2)
    b, m, n = 4, system.n_y, system.n
    t = rng.uniform(0.0, 1.5, b)
    y, v = rng.normal(size=(b, m)), rng.normal(size=(b, m))
    y[:, :n] *= 0.05
    a = system.accelerations(t, y, v, compiled=False)
    np.testing.assert_allclose(system.cart_force(t, y, v, a), BangBang(5.0, 0.0, 1.0).value(t),
                               atol=1e-8)


def test_both_models_need_the_same_force_for_a_prescribed_cart_with_rigid_links() -> None:
    """Rigid links: both models' rigid equations are exact, so the force a prescribed travel
    takes (gravity, loads, a torque-driven joint) is the same to round-off."""
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem

    flexible = SYSTEMS["prescribed"](True)
    links = tuple(Link(k.name, k.length, k.mass_per_length, 1.0, tip_mass=k.tip_mass,
                       tip_inertia=k.tip_inertia, modes=0) for k in flexible.chain.links)
    chain = Chain(links, flexible.chain.joints)
    first = ForwardSystem(chain, flexible.base, gravity=flexible.gravity)
    nonlinear = NonlinearForwardSystem(chain, flexible.base, gravity=flexible.gravity)
    rng = np.random.default_rng(4)
    t = rng.uniform(0.0, 1.5, 5)
    y, v = rng.normal(size=(5, 1)), rng.normal(size=(5, 1))
    a = nonlinear.accelerations(t, y, v, compiled=False)
    p, pd, pdd = first.rigid_state(t, y, v, a)
    empty = np.zeros((5, 0))
    expected = first.cart_force(t, p, pd, pdd, empty, empty, empty)
    np.testing.assert_allclose(nonlinear.cart_force(t, y, v, a), expected,
                               atol=1e-10 * np.abs(expected).max())


def test_the_animation_draws_the_cart_on_its_rail(tmp_path) -> None:
    """A cart driven along a rail at 30°: the block sits at the carried link's root, turned
    along the rail, and the rail's ends lie on the line the root moves on, in its direction;
    the animation is written."""
    import math

    from flexlink import simulate
    from flexlink.model import Scenario, SimulationSettings
    from flexlink.results.arm_tracks import run_track

    rail = math.radians(30.0)
    base = Base("cart", mass=1.0, position=(0.2, 0.1), attachments=((0, (0.05, 0.0)),),
                cart=Cart(TorqueDrive(Step(2.0)), rail_angle=rail))
    chain = Chain((Link("beam", 0.5, 0.5, 5.0, modes=2),), (Hold(-90.0),))
    results = simulate(Scenario(chain, settings=SimulationSettings(t_end=0.5, dt_out=0.01),
                                base=base))
    track = run_track(results)
    X, Y = track.links[0]
    np.testing.assert_allclose(track.base[:, :2], np.column_stack([X[:, 0], Y[:, 0]]))
    np.testing.assert_allclose(track.base[:, 2], rail, atol=1e-9)
    d = track.rail[1] - track.rail[0]
    assert math.atan2(d[1], d[0]) == pytest.approx(rail, abs=1e-9)
    offset = track.rail[0] - track.base[0, :2]  # on the root's line
    assert abs(offset[0] * d[1] - offset[1] * d[0]) < 1e-9
    assert results.animate(tmp_path / "cart.gif").is_file()


@pytest.mark.parametrize("case", ["force", "servo with an integral"])
def test_a_driven_carts_force_channel_is_the_travel_row_of_the_equations(case: str) -> None:
    """The run's cart_force of a driven cart (its drive's law at the solved state) equals the
    travel row of the numpy equations at the run's solved accelerations (`cart_force`) to
    1e-8 of its peak: examples/cart_beam.toml (bang-bang force) and the velocity-PID servo
    with an integral of tests/validation/test_cart_servo_integral.py."""
    from pathlib import Path

    from flexlink import load_scenario
    from flexlink.scenario import scenario_from_dict
    from flexlink.simulation import output_times
    from flexlink.simulation.forward import forward_system, run_forward

    if case == "force":
        scenario = load_scenario(Path(__file__).resolve().parents[2] / "examples"
                                 / "cart_beam.toml")
    else:
        from tests.validation.test_cart_servo_integral import _scenario

        scenario = scenario_from_dict(_scenario("first_order", 4.0))
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    run = run_forward(scenario, t, None, False)
    system = forward_system(scenario)
    sol, nu = run.solution, len(system.free)
    p, pd, pdd = system.rigid_state(t, sol.q[:, :nu], sol.q_dot[:, :nu], sol.q_ddot[:, :nu])
    row = system.cart_force(t, p, pd, pdd, sol.q[:, nu:], sol.q_dot[:, nu:],
                            sol.q_ddot[:, nu:])
    force = np.asarray(run.values["cart_force"])
    assert np.ptp(force) > 0
    np.testing.assert_allclose(force, row, rtol=0, atol=1e-8 * np.abs(row).max())
