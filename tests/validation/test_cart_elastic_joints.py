"""Elastic joints on a cart (docs/elastic_joints.md, docs/validation.md "Carts"): the cart's
travel is the base coordinate and each motor angle one more rigid coordinate, so the two
compose without new terms. Checked against the exact small-oscillation frequencies of a
rigid bar on an elastic joint on a free cart (both models), the energy balance of a
force-driven cart with a torque-driven motor (nonlinear model, no damping), and the
momentum along the rail of a free cart (both models, from a scenario file's keys)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import eigh

from flexlink import simulate
from flexlink.dynamics.forward import ForwardSystem
from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
from flexlink.model import ZERO, BangBang, Base, Cart, Chain, ElasticJoint, Link, TorqueDrive
from flexlink.scenario import scenario_from_dict

from .test_cart import _first_order_squared, _nonlinear_squared

G = 9.81


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_rigid_bar_on_an_elastic_joint_on_a_free_cart_has_the_exact_frequencies(
        model: str) -> None:
    """Hanging bar (mass m, first moment s₁, inertia J about the pin) on a cart of mass M,
    its joint a spring k to a rotor J_m through a gear N: with s, φ, θ_m,
    M = [[M + m, s₁, 0], [s₁, J, 0], [0, 0, J_m]],
    K = [[0, 0, 0], [0, g s₁ + k, −k/N], [0, −k/N, k/N²]]; ω² are the eigenvalues, to 1e-8.
    A stiff spring locks the rotor to the bar: the rigid cart-pendulum
    (`cart_pendulum_frequency`) with the bar's inertia plus the reflected N² J_m."""
    from .cart_beam import cart_pendulum_frequency

    M, mb, mt, Jt, L = 2.0, 0.5, 0.3, 0.002, 0.6
    k, N, Jm = 30.0, 5.0, 4e-3
    m, s1, J = mb + mt, mb * L / 2 + mt * L, mb * L**2 / 3 + mt * L**2 + Jt
    exact = eigh(np.array([[0, 0, 0], [0, G * s1 + k, -k / N], [0, -k / N, k / N**2]]),
                 np.array([[M + m, s1, 0], [s1, J, 0], [0, 0, Jm]]), eigvals_only=True)

    def squared(stiffness: float) -> np.ndarray:
        link = Link("bar", L, mb / L, 1.0, tip_mass=mt, tip_inertia=Jt, modes=0)
        motor = TorqueDrive(ZERO, initial_angle=-math.pi / 2 * N, motor_inertia=Jm)
        chain = Chain((link,), (ElasticJoint(motor, stiffness, 0.0, N),))
        base = Base("cart", mass=M, cart=Cart(TorqueDrive(ZERO)))
        if model == "first_order":
            return _first_order_squared(ForwardSystem(chain, base, True, gravity=(0.0, -G)))
        return _nonlinear_squared(NonlinearForwardSystem(chain, base, gravity=(0.0, -G)))

    got = squared(k)
    assert got[0] == pytest.approx(0.0, abs=1e-6)  # the free translation
    np.testing.assert_allclose(got[1:], np.sort(exact)[1:], rtol=1e-8)
    pendulum = cart_pendulum_frequency(M, m, s1, J + N**2 * Jm, G)
    stiff = squared(1e6)
    assert math.sqrt(stiff[1]) == pytest.approx(pendulum, rel=1e-5)


def test_energy_is_the_work_of_the_cart_force_and_the_motor_torque() -> None:
    """Nonlinear model, no damping, gravity, a rail at 20°: a flexible beam on an elastic
    joint whose motor is torque-driven; bang-bang force on the cart, bang-bang torque on the
    motor. Kinetic (cart, beam, rotor) + strain + spring + potential energy changes by
    ∫F ds + ∫τ_m dθ_m (both constant between output times: exact sums) to 1e-8 of the
    energy moved."""
    from flexlink.solvers.gauss_forward import solve_nonlinear_forward

    rail = math.radians(20.0)
    link = Link("beam", 0.8, 0.5, 4.0, tip_mass=0.1, modes=3)
    torque, force = BangBang(0.05, 0.2, 0.8), BangBang(6.0, 0.1, 1.0)
    motor = TorqueDrive(torque, initial_angle=-1.2 * 8.0, motor_inertia=2e-4)
    chain = Chain((link,), (ElasticJoint(motor, 20.0, 0.0, 8.0),))
    base = Base("cart", mass=1.0, cart=Cart(TorqueDrive(force), rail_angle=rail))
    t = np.linspace(0.0, 1.5, 3001)
    system = NonlinearForwardSystem(chain, base, gravity=(0.0, -G))
    solution = solve_nonlinear_forward(system, t, 1e-9, None)
    y, v, _ = system.from_solution(solution)
    kinetic, elastic = system.energy(t, y, v)
    energy = kinetic + elastic + system.potential(t, y)
    travel = solution.q[:, system.free.index(0)]
    angle = solution.q[:, system.free.index(system.loads.motor_index(0))]
    mid = 0.5 * (t[1:] + t[:-1])
    work = np.concatenate([[0.0], np.cumsum(force.value(mid) * np.diff(travel)
                                            + torque.value(mid) * np.diff(angle))])
    scale = np.ptp(energy)
    assert np.abs(energy - energy[0] - work).max() < 1e-8 * scale
    assert np.ptp(travel) > 0.05 and np.ptp(angle) > 0.5


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_momentum_along_the_rail_of_a_free_cart_with_an_elastic_joint(model: str) -> None:
    """A scenario file's keys: a free cart on a 30° rail, gravity across it, a flexible beam
    on an elastic joint whose motor a servo turns (internal torques only): the momentum
    along the rail keeps its start value to 1e-7 of its peak."""
    rail = 30.0
    g = [G * math.sin(math.radians(rail)), -G * math.cos(math.radians(rail))]
    scenario = scenario_from_dict({
        "simulation": {"name": "cart-elastic", "t_end": 1.0, "dt_out": 0.002, "gravity": g,
                       "model": model, "rtol": 1e-8 if model == "first_order" else 1e-7},
        "base": {"type": "cart", "mass": 1.5,
                 "cart": {"rail_angle_deg": rail, "drive": "free"}},
        "links": [{"name": "beam", "length": 0.8, "mass_per_length": 0.6, "EI": 6.0,
                   "tip_mass": 0.2, "modes": 3}],
        "joints": [{"spring_stiffness": 40.0, "gear_ratio": 10.0, "drive": "servo",
                    "servo": "position", "bandwidth": 20.0, "rate_limit_deg_s": 2000.0,
                    "loop_gain": 0.05, "motor_inertia": 1e-4,
                    "reference": [{"profile": "cycloidal", "from_deg": -900.0,
                                   "to_deg": 0.0, "start": 0.1, "duration": 0.6}]}]})
    r = simulate(scenario)
    c, s = math.cos(math.radians(rail)), math.sin(math.radians(rail))
    along = r["momentum_x"] * c + r["momentum_y"] * s
    peak = np.abs(np.stack([r["momentum_x"], r["momentum_y"]])).max()
    assert np.abs(along - along[0]).max() < 1e-7 * peak
    assert np.ptp(r["cart_position"]) > 0.01 and np.ptp(r["joint1_spring_torque"]) > 0.1
