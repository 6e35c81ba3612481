"""Edge cases of the nonlinear model's integrator: output samples next to an input's jump
(the interpolant of a step that ends on a breakpoint ends on the accelerations of the
inputs before it), and a chain of rigid links starting in exact equilibrium (Newton's
round-off floor counts the rigid coordinates)."""

from __future__ import annotations

import numpy as np

from flexlink import simulate
from flexlink.dynamics.nonlinear import NonlinearSystem
from flexlink.model import (
    BangBang,
    Base,
    Cart,
    Chain,
    Link,
    PiezoActuator,
    PositionServo,
    Scenario,
    SimulationSettings,
    Step,
    TorqueDrive,
)
from flexlink.motion import Hold
from flexlink.solvers.gauss import solve_nonlinear
from tests.helpers import chain_of, paper_links


def test_a_rigid_cart_under_a_bang_bang_force_moves_exactly() -> None:
    """A rigid link clamped to a free cart is one rigid body: ±F for half a second each
    gives the speed F t / m and back, every output (those just before the switch at 0.5 s
    and the end at 1 s included) exact to round-off."""
    link = Link("beam", 1.0, 0.6, 6.0, tip_mass=0.2, modes=0)
    base = Base("cart", mass=1.5, cart=Cart(TorqueDrive(BangBang(4.0, 0.0, 1.0))))
    r = simulate(Scenario(Chain((link,), (Hold(-90.0),)), base=base, settings=SimulationSettings(
        t_end=1.0, dt_out=2e-3, model="nonlinear")))
    mass = 1.5 + 0.6 + 0.2
    speed = np.where(r.time < 0.5, r.time, 1.0 - r.time) * 4.0 / mass
    travel = np.where(r.time < 0.5, 0.5 * r.time**2,
                      0.25 - 0.5 * (1.0 - r.time)**2) * 4.0 / mass
    np.testing.assert_allclose(r["cart_velocity"], speed, rtol=0, atol=1e-12)
    np.testing.assert_allclose(r["cart_position"], travel, rtol=0, atol=1e-12)


def test_outputs_before_a_voltage_step_follow_the_equations() -> None:
    """Prescribed joints held, a piezo patch stepped to 50 V at 0.1 s: at outputs 0.2 ms
    before the step, the interpolated q̈ is the equations' q̈ at the interpolated state
    (within 1e-3 of its peak), not pulled towards the accelerations after the step."""
    link1, link2 = paper_links(modes=3)
    patch = PiezoActuator("patch", 1, 0.01, 0.04, 0.025, 30.33e9, 265e-12, 0.001,
                          voltage=Step(50.0, 0.1))
    system = NonlinearSystem(chain_of([link1, link2], [Hold(0.0), Hold(0.0)]),
                             actuators=(patch,))
    t = np.linspace(0.0, 0.2, 1001)
    solution = solve_nonlinear(system, t, 1e-6)
    equations = system.accelerations(t, solution.q, solution.q_dot)
    peak = np.abs(equations).max()
    np.testing.assert_allclose(solution.q_ddot, equations, rtol=0, atol=1e-3 * peak)


def test_rigid_links_starting_in_exact_equilibrium_stay_there() -> None:
    """Two rigid links held by position servos against gravity, starting in static
    equilibrium: every acceleration is round-off, and the run stays at rest (it used to
    halve its step until it collapsed)."""
    link1 = Link("upper", 1.0, 0.6, 6.0, tip_mass=0.2, modes=0)
    link2 = Link("lower", 0.7, 0.3, 6.0, tip_mass=0.1, modes=0)
    chain = Chain((link1, link2), (PositionServo(Hold(20.0), 10.0, 3.0, 5.0),
                                   PositionServo(Hold(-30.0), 10.0, 3.0, 5.0)))
    r = simulate(Scenario(chain, settings=SimulationSettings(
        t_end=1.0, dt_out=1e-2, model="nonlinear", gravity=(0.0, -9.81),
        initial="equilibrium")))
    assert r.metadata["rejected_steps"] == 0
    for name in ("joint1_angle", "joint2_angle"):
        assert np.ptp(r[name]) < 1e-12
