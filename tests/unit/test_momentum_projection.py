"""The compiled momentum of a forward system (dynamics/_momentum_numba.py) against the numpy
`dynamics.forward.momentum`, and which components the projection of the Radau IIA loop
holds (dynamics/momentum_projection.py)."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics._forward_numba import workspace
from flexlink.dynamics._momentum_numba import _state, components
from flexlink.dynamics.forward import ForwardSystem, momentum
from flexlink.dynamics.forward_kernel import inputs, pack
from flexlink.dynamics.momentum_projection import projection
from flexlink.model import BangBang, Base, BaseLoad, Chain, Link, Step, TorqueDrive
from flexlink.motion import Cycloidal, Hold

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
    d = pack(system)
    w = workspace(d, 0)
    rng = np.random.default_rng(3)
    nu, n = len(system.free), system.n
    t = np.array([0.4])
    u = inputs(system, t)[0]
    pj = projection(system, d, 0.0, u.size)._replace(about_cm=False)
    out = np.zeros(5)
    for _ in range(3):
        y = system.initial_state() + 0.1 * rng.normal(size=system.initial_state().size)
        _state(d, w, u, y)
        components(d, w, pj, w.pd, out)
        p, pd, _ = system.rigid_state(t, y[None, :nu], y[None, nu:2 * nu], np.zeros((1, nu)))
        lin, ang = momentum(system, p, pd, y[None, 2 * nu:2 * nu + n],
                            y[None, 2 * nu + n:2 * nu + 2 * n])
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
    d = pack(system)
    w = workspace(d, 0)
    rng = np.random.default_rng(4)
    nu, n = len(system.free), system.n
    y = system.initial_state() + 0.1 * rng.normal(size=system.initial_state().size)
    rates = np.empty_like(y)
    from flexlink.dynamics._forward_numba import rates as kernel

    t, eps = 0.4, 1e-6
    kernel(d, w, inputs(system, np.array([t]))[0], y, rates)
    pj = projection(system, d, 0.0, inputs(system, np.zeros(1)).shape[1])
    out = np.zeros(5)
    moments = []
    for sign in (1.0, -1.0):
        ys = y.copy()
        ys[:nu] += sign * eps * rates[:nu]  # positions move with their rates
        ys[2 * nu:2 * nu + n] += sign * eps * rates[2 * nu:2 * nu + n]
        u = inputs(system, np.array([t + sign * eps]))[0]
        _state(d, w, u, ys)
        components(d, w, pj, w.pd, out)
        moments.append(out[3:5].copy())
    p, pd, _ = system.rigid_state(np.array([t]), y[None, :nu], y[None, nu:2 * nu],
                                  np.zeros((1, nu)))
    linear = momentum(system, p, pd, y[None, 2 * nu:2 * nu + n],
                      y[None, 2 * nu + n:2 * nu + 2 * n])[0][0]
    np.testing.assert_allclose((moments[0] - moments[1]) / (2 * eps), linear, rtol=1e-6,
                               atol=1e-6 * np.abs(linear).max())
