"""A cart on a rail carrying a rigid or flexible link, both models, against independent
references: the cart-pendulum's exact small-oscillation frequency, the frequencies of a beam
clamped to a sliding cart (horizontal, hanging, standing: tests/validation/cart_beam.py),
momentum along the rail with no force along it, and the energy balance of a force-driven
cart in gravity (docs/validation.md, "Carts")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexlink import simulate
from flexlink.dynamics.forward import ForwardSystem
from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
from flexlink.errors import SimulationError
from flexlink.model import (
    ZERO,
    BangBang,
    Base,
    Cart,
    Chain,
    Link,
    Scenario,
    SimulationSettings,
    Step,
    TorqueDrive,
)
from flexlink.motion import Cycloidal, Hold

from .cart_beam import cart_beam_frequencies, cart_pendulum_frequency

G = 9.81


def _first_order_squared(system: ForwardSystem) -> np.ndarray:
    """ω² of the first-order model linearised at rest at t = 0 (rigid state as given): the
    eigenvalues of −∂(p̈_free, z̈)/∂(p_free, z) by central differences."""
    nu, n = len(system.free), system.n
    start = system.initial_state()
    x0 = np.concatenate([start[:nu], start[2 * nu:2 * nu + n]])
    h = 1e-6
    cols = []
    for j in range(nu + n):
        states = np.repeat(x0[None], 2, 0)
        states[0, j] += h
        states[1, j] -= h
        pdd, zdd, _ = system.accelerations(np.zeros(2), states[:, :nu], np.zeros((2, nu)),
                                           states[:, nu:], np.zeros((2, n)),
                                           np.zeros((2, len(system.servos))))
        acc = np.concatenate([pdd, zdd], 1)
        cols.append((acc[0] - acc[1]) / (2 * h))
    return np.sort(np.linalg.eigvals(-np.array(cols).T).real)


def _nonlinear_squared(system: NonlinearForwardSystem) -> np.ndarray:
    """ω² of the nonlinear model linearised about its initial state (at rest)."""
    y0, v0 = system.initial_state()
    m = system.n_y
    h = 1e-6
    Y = np.repeat(y0[None], 2 * m, 0)
    for j in range(m):
        Y[2 * j, j] += h
        Y[2 * j + 1, j] -= h
    acc = system.accelerations(np.zeros(2 * m), Y, np.repeat(v0[None], 2 * m, 0))
    J = (acc[0::2] - acc[1::2]).T / (2 * h)
    return np.sort(np.linalg.eigvals(-J).real)


# --- the cart-pendulum ---------------------------------------------------------------------

def _pendulum(angle: float, rail_angle: float = 0.0) -> tuple[Chain, Base, float]:
    """A rigid bar (0.5 kg, 0.6 m) with a 0.3 kg tip mass and tip inertia on a pin of a
    2 kg cart; its exact ω on a level rail."""
    M, mb, mt, Jt, L = 2.0, 0.5, 0.3, 0.002, 0.6
    link = Link("bar", L, mb / L, 1.0, tip_mass=mt, tip_inertia=Jt, modes=0)
    chain = Chain((link,), (TorqueDrive(ZERO, initial_angle=angle),))
    base = Base("cart", mass=M, cart=Cart(TorqueDrive(ZERO), rail_angle=rail_angle))
    omega = cart_pendulum_frequency(M, mb + mt, mb * L / 2 + mt * L,
                                    mb * L**2 / 3 + mt * L**2 + Jt, G)
    return chain, base, omega


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_cart_pendulum_frequency_is_exact(model: str) -> None:
    """Both models linearised at the hanging rest give the exact ω to 1e-8 (rigid links:
    the rigid equations are exact in both)."""
    chain, base, omega = _pendulum(-math.pi / 2)
    if model == "first_order":
        squared = _first_order_squared(ForwardSystem(chain, base, True, gravity=(0.0, -G)))
    else:
        squared = _nonlinear_squared(NonlinearForwardSystem(chain, base, gravity=(0.0, -G)))
    assert squared[0] == pytest.approx(0.0, abs=1e-6)  # the cart's free translation
    assert math.sqrt(squared[1]) == pytest.approx(omega, rel=1e-8)


def test_cart_pendulum_oscillates_at_the_exact_period() -> None:
    """A run released 1 mrad from the hanging rest: the period of the joint angle (mean
    of 3 zero crossings) is 2π/ω to 1e-5, and the cart's momentum along the rail stays
    zero (no force along it)."""
    chain, base, omega = _pendulum(-math.pi / 2 + 1e-3)
    scenario = Scenario(chain, settings=SimulationSettings(
        t_end=4.0, dt_out=1e-3, gravity=(0.0, -G), rtol=1e-8), base=base)
    r = simulate(scenario)
    a = r["joint1_angle"] + math.pi / 2
    t = r.time
    i = np.flatnonzero(np.diff(np.sign(a)) > 0)
    crossings = t[i] - a[i] * (t[i + 1] - t[i]) / (a[i + 1] - a[i])
    assert np.diff(crossings).mean() == pytest.approx(2 * math.pi / omega, rel=1e-5)
    assert np.abs(r["momentum_x"]).max() < 1e-10
    assert np.ptp(r["cart_position"]) > 1e-4  # the cart does move


# --- a flexible beam on a cart -------------------------------------------------------------

RHO, L, EI = 0.8, 1.2, 30.0


def _beam(cart_ratio: float, angle_deg: float, tip_ratio: float = 0.0,
          modes: int = 8) -> tuple[Chain, Base]:
    link = Link("beam", L, RHO, EI, tip_mass=tip_ratio * RHO * L, modes=modes)
    return (Chain((link,), (Hold(angle_deg),)),
            Base("cart", mass=cart_ratio * RHO * L, cart=Cart()))


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
@pytest.mark.parametrize("case", [
    # (cart ratio M/ρL, beam angle deg, gravity on, tip ratio, sign of the axial load)
    (2.0, 90.0, False, 0.0, 1.0),  # no gravity
    (0.5, 90.0, False, 0.4, 1.0),  # a light cart, a tip mass
    (2.0, -90.0, True, 0.5, 1.0),  # hanging
    (2.0, 90.0, True, 0.5, -1.0),  # standing (inverted)
])
def test_beam_on_a_free_cart_frequencies(case: tuple, model: str) -> None:
    """Linearised at rest (first order with geometric stiffening; the nonlinear model about
    its straight equilibrium): the first three flexible frequencies of the beam on its free
    cart within 0.5% of the Chebyshev solution, the first within 0.1%."""
    ratio, angle, gravity, tip, sign = case
    chain, base = _beam(ratio, angle, tip)
    g = (0.0, -G) if gravity else (0.0, 0.0)
    gamma = RHO * G * L**3 / EI if gravity else 0.0
    expected = cart_beam_frequencies(ratio, 3, gamma, sign, tip) * math.sqrt(EI / RHO) / L**2
    if model == "first_order":
        squared = _first_order_squared(ForwardSystem(chain, base, True, gravity=g))
    else:
        squared = _nonlinear_squared(NonlinearForwardSystem(chain, base, gravity=g))
    assert abs(squared[0]) < 1e-6 * squared[1]  # the free translation
    got = np.sqrt(squared[1:4])
    np.testing.assert_allclose(got, expected, rtol=5e-3)
    assert got[0] == pytest.approx(expected[0], rel=1e-4)


def test_reference_limits() -> None:
    """The reference solver: a cart of huge mass is the clamp (cantilever λ₁ = 1.87510²),
    a massless cart the sliding–free beam (tan μ + tanh μ = 0: μ₁ = 2.36502²), converged in
    the number of points. (The third-derivative rows grow as the points' number to the sixth power: 40 points
    are converged to 1e-7, more lose digits to round-off; the huge cart's row to 2e-5.)"""
    assert cart_beam_frequencies(1e6, 1)[0] == pytest.approx(1.8751040687**2, rel=2e-5)
    assert cart_beam_frequencies(0.0, 1)[0] == pytest.approx(2.3650203724**2, rel=1e-6)
    np.testing.assert_allclose(cart_beam_frequencies(2.0, 3, 2.0, 1.0, 0.5, points=30),
                               cart_beam_frequencies(2.0, 3, 2.0, 1.0, 0.5, points=40),
                               rtol=1e-6)


# --- balances ------------------------------------------------------------------------------

@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_momentum_along_the_rail_is_conserved(model: str) -> None:
    """A flexible beam on a free cart on a rail at 30°, the beam swinging on a torque-driven
    joint (torque between cart and beam: internal), gravity across the rail only: the
    momentum along the rail keeps its initial value to 1e-7 of the peak momentum."""
    rail = math.radians(30.0)
    link = Link("beam", 1.0, 0.6, 6.0, tip_mass=0.2, modes=4)
    chain = Chain((link,), (TorqueDrive(BangBang(0.8, 0.0, 1.0), initial_angle=1.0),))
    base = Base("cart", mass=1.5, cart=Cart(TorqueDrive(ZERO, 0.0, 0.3), rail_angle=rail))
    gravity = (G * math.sin(rail), -G * math.cos(rail))  # perpendicular to the rail
    r = simulate(Scenario(chain, settings=SimulationSettings(
        t_end=1.5, dt_out=1e-3, gravity=gravity, model=model,
        rtol=1e-8 if model == "first_order" else 1e-7), base=base))
    along = r["momentum_x"] * math.cos(rail) + r["momentum_y"] * math.sin(rail)
    peak = np.abs(np.stack([r["momentum_x"], r["momentum_y"]])).max()
    assert np.abs(along - along[0]).max() < 1e-7 * peak
    assert np.ptp(r["joint1_angle"]) > 0.3


def test_energy_balance_of_a_force_driven_cart_in_gravity() -> None:
    """Nonlinear model, no damping: a bang-bang force on the cart along a rail inclined at
    20° with gravity, a flexible beam swinging on a free pin: kinetic + elastic + potential
    energy changes by the work ∫F ds of the drive force, to 1e-9 of the energy moved."""
    rail = math.radians(20.0)
    link = Link("beam", 0.8, 0.5, 4.0, tip_mass=0.1, modes=3)
    chain = Chain((link,), (TorqueDrive(ZERO, initial_angle=-1.2),))
    force = BangBang(6.0, 0.1, 1.0)
    base = Base("cart", mass=1.0, cart=Cart(TorqueDrive(force), rail_angle=rail))
    t = np.linspace(0.0, 1.5, 3001)
    system = NonlinearForwardSystem(chain, base, gravity=(0.0, -G))
    from flexlink.solvers.gauss_forward import solve_nonlinear_forward

    solution = solve_nonlinear_forward(system, t, 1e-9, None)
    y, v, a = system.from_solution(solution)
    kinetic, elastic = system.energy(t, y, v)
    energy = kinetic + elastic + system.potential(t, y)
    # The force is constant between its jumps, which fall on the grid: its work is exactly
    # Σ F(mid-interval) Δs.
    travel = y[:, system.n]
    work = np.concatenate([[0.0], np.cumsum(force.value(0.5 * (t[1:] + t[:-1]))
                                             * np.diff(travel))])
    scale = np.ptp(energy)
    assert np.abs(energy - energy[0] - work).max() < 1e-9 * scale
    np.testing.assert_allclose(system.cart_force(t, y, v, a)[1:-1], force.value(t)[1:-1],
                               atol=1e-6 * 6.0)


# --- travel limits -------------------------------------------------------------------------

def _travel_scenario(drive, travel=(-0.2, 0.2)) -> Scenario:
    chain, base = _beam(2.0, 90.0, modes=2)
    base = Base("cart", mass=2.0, cart=Cart(drive, travel=travel))
    return Scenario(chain, settings=SimulationSettings(t_end=1.0, dt_out=1e-2), base=base)


def test_a_prescribed_travel_outside_the_limits_is_refused() -> None:
    """Refused when the scenario is made, naming the field, the time and the travel."""
    with pytest.raises(ValueError, match=r"base.motion.*base.travel.*reaches s = 0\.3 m"):
        _travel_scenario(Cycloidal(0.0, 0.3 * 180 / math.pi, 0.2, 0.5))
    _travel_scenario(Cycloidal(0.0, 0.1 * 180 / math.pi, 0.2, 0.5))  # inside: accepted


def test_a_driven_cart_that_leaves_its_travel_ends_the_run() -> None:
    with pytest.raises(SimulationError, match=r"left its travel \[-0\.2, 0\.2\] m"):
        simulate(_travel_scenario(TorqueDrive(Step(5.0))))
    with pytest.raises(ValueError, match="starts at s = 0.5 m"):
        _travel_scenario(TorqueDrive(ZERO, 0.5))


def test_linearised_plant_of_the_example() -> None:
    """`flexlink linearize` of examples/cart_beam.toml (hanging beam with a tip mass on a
    force-driven cart, gravity): the plant's input is the cart force, its states name the
    cart's travel and speed, and its frequencies are the Chebyshev reference's within 0.5%."""
    from pathlib import Path

    from flexlink.control.linearization import linearize
    from flexlink.scenario import load_scenario

    scenario = load_scenario(Path(__file__).resolve().parents[2] / "examples" / "cart_beam.toml")
    plant = linearize(scenario)
    assert plant.input_names == ("cart_force",)
    assert {"cart_position", "cart_velocity"} <= set(plant.state_names)
    omega = np.sort(np.abs(np.linalg.eigvals(plant.A).imag))
    omega = np.unique(omega[omega > 1e-6].round(9))[:2]
    link = scenario.chain.links[0]
    rho, length = link.mass_per_length, link.length
    expected = cart_beam_frequencies(
        scenario.base.mass / (rho * length), 2, rho * G * length**3 / link.EI, 1.0,
        link.tip_mass / (rho * length)) * math.sqrt(link.EI / rho) / length**2
    np.testing.assert_allclose(omega, expected, rtol=5e-3)


# --- against a geometrically exact model ---------------------------------------------------

@pytest.mark.slow
@pytest.mark.parametrize("model, tolerance", [("first_order", 0.03), ("nonlinear", 0.01)])
@pytest.mark.parametrize("angle_deg, EI", [(-90.0, 30.0), (90.0, 30.0), (0.0, 300.0)],
                         ids=["hanging", "inverted", "horizontal"])
def test_beam_on_a_force_driven_cart_against_exudyn(model: str, tolerance: float,
                                                     angle_deg: float, EI: float) -> None:
    """examples/cart_beam.toml's system (a beam with a tip mass clamped to a 2 kg cart, ±4 N
    bang-bang force for 1 s on a level rail, gravity; undamped here), the beam hanging,
    standing or level (then ten times stiffer: it sags under its weight from rest), against
    Exudyn's geometrically exact beams (32 elements) on a cart held to the rail by
    constraints: cart travel within 10⁻³ of its peak, tip deflection within 3% (first order,
    stiffened) and 1% (nonlinear) of its peak, 6 modes."""
    import dataclasses

    from flexlink.model import PointSensor

    from .exudyn_forward_reference import Appendage, simulate_hub_exudyn

    pytest.importorskip("exudyn")
    beam = Link("beam", 1.2, 0.8, EI, tip_mass=0.3, thickness=0.01)
    force = BangBang(4.0, 0.0, 1.0)
    t_end, dt_out, cart_mass = 2.0, 0.002, 2.0
    exact = simulate_hub_exudyn([Appendage(beam, angle=math.radians(angle_deg))], 0.0,
                                lambda t: float(force.value(np.array([t]))[0]), t_end, dt_out,
                                32, hub_mass=cart_mass, gravity=(0.0, -G), rail=True)
    link = dataclasses.replace(beam, modes=6)
    scenario = Scenario(
        Chain((link,), (Hold(angle_deg),)), (PointSensor("tip", "deflection", 0, link.length),),
        SimulationSettings(t_end, dt_out, gravity=(0.0, -G), model=model,
                           rtol=1e-6 if model == "first_order" else 1e-4),
        base=Base("cart", mass=cart_mass, cart=Cart(TorqueDrive(force))))
    r = simulate(scenario, shapes=False)
    travel, ref_travel = np.asarray(r["cart_position"]), exact["hub_position"][:, 0]
    tip, ref_tip = np.asarray(r["tip"]), np.asarray(exact["tip_deflection"][0])
    assert np.abs(travel - ref_travel).max() < 1e-3 * np.abs(ref_travel).max()
    assert np.abs(tip - ref_tip).max() < tolerance * np.abs(ref_tip).max()


# --- prescribed and servo-driven carts, end to end ----------------------------------------

@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_a_prescribed_travel_takes_the_rate_of_change_of_momentum(model: str) -> None:
    """A flexible beam held at −60° on a cart moved by a cycloidal travel along a level rail,
    gravity across it: the cart's channels follow the profile, and the force the travel
    takes is the rate of change of the momentum along the rail (the momentum channel, from
    the kinematics; central differences, 10⁻³ of the peak force; measured 3.7·10⁻⁴ first
    order, 3.8·10⁻⁴ nonlinear: the difference quotient's own error)."""
    from flexlink.motion import Travel

    travel = Travel(Cycloidal(0.0, 0.4, 0.2, 1.0))  # metres, as written in a scenario
    link = Link("beam", 0.6, 0.5, 3.0, tip_mass=0.3, modes=3)
    scenario = Scenario(Chain((link,), (Hold(-60.0),)), settings=SimulationSettings(
        t_end=1.5, dt_out=1e-3, gravity=(0.0, -G), model=model,
        rtol=1e-8 if model == "first_order" else 1e-7),
        base=Base("cart", mass=2.0, cart=Cart(travel, travel=(-0.1, 0.5))))
    r = simulate(scenario)
    s, v, _ = travel.evaluate(r.time)
    np.testing.assert_allclose(r["cart_position"], s, atol=1e-12)
    np.testing.assert_allclose(r["cart_velocity"], v, atol=1e-12)
    rate = np.gradient(r["momentum_x"], r.time)
    force = r["cart_force"]
    # away from the ends and from the profile's kinks (where the difference quotient is not
    # the derivative)
    smooth = np.ones(r.time.size, dtype=bool)
    smooth[:2] = smooth[-2:] = False
    for kink in travel.breakpoints:
        smooth[np.abs(r.time - kink) < 2.5e-3] = False
    assert np.abs(force - rate)[smooth].max() < 1e-3 * np.abs(force).max()


def test_a_position_servo_brings_the_cart_to_its_reference() -> None:
    """A position servo on the travel (bandwidth 20/s, rate limit 0.5 m/s, force limit 30 N)
    carrying a flexible beam: the cart ends at the reference's 0.3 m within 1 mm, never
    faster than its rate limit by more than the velocity loop's lag, and its force (the
    servo law on the solved travel and speed) stays within the limit."""
    from flexlink.model import PositionServo
    from flexlink.motion import Travel

    reference = Travel(Cycloidal(0.0, 0.3, 0.0, 1.0))
    servo = PositionServo(reference, bandwidth=20.0, rate_limit=0.5, loop_gain=200.0,
                          torque_limit=30.0)
    chain, _ = _beam(2.0, -90.0, modes=3)
    scenario = Scenario(chain, settings=SimulationSettings(t_end=2.5, dt_out=1e-2,
                                                           gravity=(0.0, -G)),
                        base=Base("cart", mass=2.0, cart=Cart(servo, travel=(-0.1, 0.4))))
    r = simulate(scenario)
    assert r["cart_position"][-1] == pytest.approx(0.3, abs=1e-3)
    assert np.abs(r["cart_force"]).max() <= 30.0 + 1e-6
    assert np.abs(r["cart_velocity"]).max() < 0.5 * 1.1


def test_linearised_at_a_rest_configuration() -> None:
    """`linearize --at joint1=…` with a force-driven cart: the cart held at rest where it
    starts with no force (an equilibrium), the beam hanging: the reference's frequencies
    within 0.5%; a base pose key is refused for a cart."""
    from flexlink.control.linearization import linearize

    chain, base = _beam(2.0, -90.0, 0.5)
    base = Base("cart", mass=base.mass, cart=Cart(TorqueDrive(Step(3.0), 0.2)))
    scenario = Scenario(chain, settings=SimulationSettings(t_end=1.0, dt_out=1e-2,
                                                           gravity=(0.0, -G)), base=base)
    plant = linearize(scenario, {"joint1": -90.0})
    assert plant.equilibrium
    omega = np.sort(np.abs(np.linalg.eigvals(plant.A).imag))
    omega = np.unique(omega[omega > 1e-6].round(9))[:3]
    expected = cart_beam_frequencies(2.0, 3, RHO * G * L**3 / EI, 1.0, 0.5) \
        * math.sqrt(EI / RHO) / L**2
    np.testing.assert_allclose(omega, expected, rtol=5e-3)
    with pytest.raises(ValueError, match="not a coordinate of a cart base"):
        linearize(scenario, {"base_x": 0.1})
