"""The compiled momentum of a forward system (dynamics/_momentum_numba.py) against the numpy
`dynamics.forward.momentum`, and which components the projection of the Radau IIA loop
holds (dynamics/momentum_projection.py)."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.forward import ForwardSystem
from flexlink.dynamics.forward_kernel import inputs, pack
from flexlink.dynamics.momentum_projection import projection
from flexlink.model import BangBang, Base, BaseLoad, Chain, Link, Step, TorqueDrive
from flexlink.motion import Cycloidal, Hold
from tests.unit._momentum_checks import (
    compiled_components,
    first_moment_rate,
    numpy_momentum,
    packed,
)

LINKS = (Link("a", 2.0, 1.0, 50.0, tip_mass=0.3, tip_inertia=0.01, modes=2),
         Link("b", 1.5, 1.0, 40.0, modes=3), Link("c", 0.8, 0.5, 30.0, modes=2))


def _system(kind: str, loads: tuple = (), gravity: tuple = (0.0, 0.0)) -> ForwardSystem:
    attach = ((0, (0.5, 0.0)), (1, (-0.5, 0.1))) if kind != "fixed" else ((1, (0.0, 0.2)),)
    base = Base(kind, mass=20.0 if kind == "free" else 0.0, inertia=5.0, attachments=attach,
                loads=loads, position=(0.3, 0.2) if kind == "free" else (0.0, 0.0))
    joints = (TorqueDrive(BangBang(2.0, 0.0, 4.0), initial_angle=0.2),
              Cycloidal(180.0, 150.0, 0.0, 1.0), Hold(30.0))
    return ForwardSystem(Chain(LINKS, joints), base, True, gravity=gravity)


@pytest.mark.parametrize("kind", ["free", "pinned", "fixed"])
def test_compiled_momentum_equals_the_numpy_one(kind: str) -> None:
    """Random states (the prescribed joint moving: its rate enters), about the origin."""
    system = _system(kind)
    d, w, pj = packed(system)
    rng = np.random.default_rng(3)
    pj = pj._replace(about_cm=False)
    for _ in range(3):
        y = system.initial_state() + 0.1 * rng.normal(size=system.initial_state().size)
        out = compiled_components(system, d, w, pj, 0.4, y)
        lin, ang, _ = numpy_momentum(system, 0.4, y)
        np.testing.assert_allclose(out[:3], [*lin[0], ang[0]], rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("kind, loads, gravity, active", [
    ("fixed", (), (0.0, 0.0), []),
    ("pinned", (BaseLoad(moment=Step(1.0)),), (0.0, 0.0), [2]),
    ("pinned", (), (0.0, -9.81), []),
    ("free", (BaseLoad(moment=Step(1.0), force_x=Step(2.0), point=(0.1, 0.0)),), (0.0, 0.0),
     [0, 1]),
    ("free", (BaseLoad(force_y=Step(2.0), frame="body"),), (0.0, 0.0), []),
    ("free", (BaseLoad(moment=Step(1.0)),), (0.0, -9.81), [0, 1, 2]),
])
def test_only_components_with_a_known_change_are_projected(kind, loads, gravity, active):
    """Forces at points and in body axes, and gravity about a pin, change the momentum by
    amounts that follow the solved motion: those components are left alone."""
    system = _system(kind, loads, gravity)
    pj = projection(system, pack(system), 0.0, inputs(system, np.zeros(1)).shape[1])
    assert list(pj.active) == active
    assert pj.about_cm == (kind == "free" and any(gravity))


@pytest.mark.parametrize("kind", ["free", "pinned"])
def test_first_moment_changes_at_the_linear_momentum(kind: str) -> None:
    """S = ∫r dm (the centre of mass of the gravity projection) against the numpy linear
    momentum: dS/dt along the motion (central differences of the compiled S) equals L."""
    system = _system(kind)
    d, w, pj = packed(system)
    rng = np.random.default_rng(4)
    y = system.initial_state() + 0.1 * rng.normal(size=system.initial_state().size)
    rate = first_moment_rate(system, d, w, pj, 0.4, y)
    linear = numpy_momentum(system, 0.4, y)[0][0]
    np.testing.assert_allclose(rate, linear, rtol=1e-6,
                               atol=1e-6 * np.abs(linear).max())


def _cart_run(drive, loads: tuple = (), t_end: float = 10.0):
    """A flexible beam swinging on a torque-driven pin of a cart on a 30° rail, gravity
    along and across the rail, default tolerance: the run."""
    import math

    from flexlink import simulate
    from flexlink.model import Cart, Scenario, SimulationSettings

    rail = math.radians(30.0)
    link = Link("beam", 1.0, 0.6, 6.0, tip_mass=0.2, modes=4)
    chain = Chain((link,), (TorqueDrive(BangBang(0.8, 0.0, 1.0), initial_angle=1.0),))
    base = Base("cart", mass=1.5, loads=loads, attitude=0.4,
                cart=Cart(drive, rail_angle=rail))
    settings = SimulationSettings(t_end=t_end, dt_out=0.01, gravity=(0.0, -9.81))
    return simulate(Scenario(chain, settings=settings, base=base))


def test_momentum_along_a_free_carts_rail_is_held_over_10_s() -> None:
    """Default rtol 1e-4, 10 s: the momentum along the rail equals its start value plus
    M g·e t plus the impulses of the drive's force and of the loads' components along the
    rail (one in body axes: the cart's attitude is constant) to 1e-8 of its peak."""
    import math

    force = BangBang(3.0, 0.5, 2.0)
    loads = (BaseLoad(force_x=Step(1.0, 1.0), force_y=Step(-2.0, 3.0)),
             BaseLoad(force_x=Step(0.5, 2.0), frame="body", point=(0.1, 0.0)))
    r = _cart_run(TorqueDrive(force, 0.0, 0.3), loads)
    t = r.time
    e = np.array([math.cos(math.radians(30.0)), math.sin(math.radians(30.0))])
    along = r["momentum_x"] * e[0] + r["momentum_y"] * e[1]
    mass = 1.5 + 0.6 * 1.0 + 0.2
    body_e = np.array([math.cos(0.4) * e[0] + math.sin(0.4) * e[1]])
    # ∫ of a bang-bang (+a for half the duration, −a for the other half) and of steps
    bang = 3.0 * (np.clip(t - 0.5, 0.0, 1.0) - np.clip(t - 1.5, 0.0, 1.0))
    impulse = (bang + e[0] * 1.0 * np.clip(t - 1.0, 0.0, None)
               + e[1] * -2.0 * np.clip(t - 3.0, 0.0, None)
               + body_e[0] * 0.5 * np.clip(t - 2.0, 0.0, None))
    known = along[0] + mass * -9.81 * e[1] * t + impulse
    peak = np.abs(along).max()
    assert np.abs(along - known).max() < 1e-8 * peak
    assert np.ptp(r["joint1_angle"]) > 0.3 and np.ptp(r["cart_position"]) > 1.0


def test_a_servo_or_prescribed_cart_is_not_projected() -> None:
    """Their force follows the solved travel (servo) or the rail sets the travel."""
    from flexlink.model import Cart, PositionServo

    for drive, active in ((TorqueDrive(Step(1.0)), [0]),
                          (PositionServo(Cycloidal(0.0, 0.2, 0.0, 1.0), bandwidth=5.0,
                                         rate_limit=1.0, loop_gain=10.0), []),
                          (Cycloidal(0.0, 0.2, 0.0, 1.0), [])):
        base = Base("cart", mass=1.0, cart=Cart(drive))
        system = ForwardSystem(Chain(LINKS[:1], (TorqueDrive(Step(0.1)),)), base, True)
        d = pack(system)
        pj = projection(system, d, 0.0, inputs(system, np.zeros(1)).shape[1])
        assert pj.active.tolist() == active
