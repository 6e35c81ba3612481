"""The first-order momentum (numpy `dynamics.forward.momentum`, compiled
`_momentum_numba.momentum`: the forward run's momentum channels and its projection) of a
chain with a slider on a moving base: the carried link's root sits at s along the line
through the parent's section at x_a and moves with ṡ u + s ω S u (frame of the parent)."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.forward import ForwardSystem
from flexlink.model import (
    BangBang,
    Base,
    Cart,
    Chain,
    Link,
    PrismaticJoint,
    TorqueDrive,
)
from flexlink.motion import Cycloidal, Travel
from tests.unit._momentum_checks import (
    compiled_components,
    first_moment_rate,
    numpy_momentum,
    packed,
)


def slider_system(kind: str, prescribed: bool = False) -> ForwardSystem:
    """A flexible boom (0.8 m) on a torque-driven hub of a ``kind`` base, a 0.4 kg block on a
    line at 20° through the boom's section at 0.55 m carrying a flexible arm at 30°; the
    travel force-driven or (``prescribed``) a cycloidal move."""
    links = (Link("boom", 0.8, 1.5, 60.0, modes=2),
             Link("arm", 0.6, 0.7, 20.0, tip_mass=0.15, modes=2))
    travel = (Travel(Cycloidal(0.2, 0.5, 0.0, 1.0)) if prescribed
              else TorqueDrive(BangBang(0.3, 0.0, 1.0), 0.2, 0.1))
    joints = (TorqueDrive(BangBang(0.5, 0.0, 1.0), initial_angle=0.3),
              PrismaticJoint(travel, np.radians(20.0), np.radians(30.0), mass=0.4, at=0.55))
    cart = Cart(TorqueDrive(BangBang(1.0, 0.0, 1.0)), rail_angle=0.3) if kind == "cart" else None
    base = Base(kind, mass=3.0 if kind in ("free", "cart") else 0.0, inertia=0.2,
                position=(0.3, 0.2) if kind == "free" else (0.0, 0.0), cart=cart)
    return ForwardSystem(Chain(links, joints), base, True)


CASES = [("free", False), ("pinned", False), ("cart", False), ("free", True)]


def _random_state(system: ForwardSystem, seed: int) -> np.ndarray:
    y = system.initial_state()
    y = y + 0.1 * np.random.default_rng(seed).normal(size=y.size)
    i = system.joint_index(1)
    if i in system.free:  # the travel moving at 0.3 m/s
        y[len(system.free) + system.free.index(i)] = 0.3
    return y


@pytest.mark.parametrize("kind, prescribed", CASES)
def test_compiled_momentum_equals_the_numpy_one_with_a_slider(kind: str, prescribed: bool
                                                              ) -> None:
    system = slider_system(kind, prescribed)
    d, w, pj = packed(system)
    pj = pj._replace(about_cm=False)
    for seed in range(3):
        y = _random_state(system, seed)
        out = compiled_components(system, d, w, pj, 0.4, y)
        lin, ang, _ = numpy_momentum(system, 0.4, y)
        if kind == "cart":  # the compiled component 0 is the momentum along the rail
            lin[0, 0] = lin[0] @ np.array(system.base.cart.direction)
        np.testing.assert_allclose(out[:3], [lin[0, 0], lin[0, 1], ang[0]], rtol=1e-13,
                                   atol=1e-13)


@pytest.mark.parametrize("kind, prescribed", CASES)
def test_the_first_moment_changes_at_the_linear_momentum_with_a_slider(
        kind: str, prescribed: bool) -> None:
    """S = ∫r dm of the compiled kernel (positions only, the block at s along its line)
    differenced along the motion equals the numpy linear momentum, which a slider's ṡ and
    s ω enter: without them it misses by the block's and the arm's mass times that speed."""
    system = slider_system(kind, prescribed)
    d, w, pj = packed(system)
    y = _random_state(system, 7)
    rate = first_moment_rate(system, d, w, pj, 0.4, y)
    lin, _, pd = numpy_momentum(system, 0.4, y)
    linear = lin[0]
    i = system.joint_index(1)
    assert abs(pd[0, i]) > 0.01  # the travel moves
    np.testing.assert_allclose(rate, linear, rtol=1e-6,
                               atol=1e-6 * np.abs(linear).max())
