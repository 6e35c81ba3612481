"""The closure kinematics of the compiled loop kernels (dynamics/_loops_numba.py) against
the exact kinematics of tests/validation/brute_force.py (positions, with and without the
foreshortening of geometric stiffening), the Jacobian G against differences of Φ and γ
against the second difference of Φ along a motion with q̈ = 0; and the constrained
accelerations against the numpy ForwardSystem's equations with the multipliers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexlink.dynamics.forward import ForwardSystem
from flexlink.dynamics.forward_kernel import inputs
from flexlink.dynamics.loops import LoopSystem
from flexlink.model import ZERO, Base, Chain, Closure, Link, TorqueDrive
from flexlink.motion.profiles import Spinup
from tests.unit._loops_checks import (
    closure_differences,
    constraints,
    load_state,
    numpy_equations,
    phi_at,
    random_state,
    solve_constrained,
)
from tests.validation.brute_force import chain_points

CRANK, COUPLER, ROCKER, D = 0.1, 0.3, 0.25, (0.3, 0.05)


def _four_bar(stiffening: bool, x: float = COUPLER) -> LoopSystem:
    links = (Link("crank", CRANK, 2.0, 40.0, modes=2),
             Link("coupler", COUPLER, 0.3, 20.0, modes=3, mode_shapes="pinned_pinned"),
             Link("rocker", ROCKER, 1.0, 30.0, modes=2, tip_mass=0.05))
    joints = (Spinup(100.0, 0.0, 0.5, 80.0), TorqueDrive(ZERO, math.radians(-55.0)),
              TorqueDrive(ZERO, math.radians(100.0)))
    system = ForwardSystem(Chain(links, joints), Base("fixed", attachments=((2, D),)),
                           stiffening)
    return LoopSystem(system, [Closure("pin", "revolute", 1, x, 2, ROCKER)])


@pytest.mark.parametrize("stiffening", [False, True])
def test_closure_positions_are_the_exact_kinematics(stiffening: bool) -> None:
    loops = _four_bar(stiffening)
    y, u = random_state(loops, 1)
    work = loops.workspace(y.size)
    load_state(loops.data, work, u, y)
    phi = phi_at(loops, work, work.q.copy(), work.v.copy())
    q = work.q
    modal = loops.system.modal
    nr = loops.system.n_rigid
    z = q[nr:]
    chain = chain_points(modal[:2], q[:2], z[:modal[0].n + modal[1].n], stiffening)
    rocker = chain_points(modal[2:], q[2:3], z[modal[0].n + modal[1].n:], stiffening)
    gap = chain[1][1][:, -1] - (np.asarray(D) + rocker[0][1][:, -1])
    assert np.abs(phi - gap).max() < 1e-9 * (CRANK + COUPLER)


@pytest.mark.parametrize("stiffening", [False, True])
def test_jacobian_and_acceleration_terms_are_derivatives_of_the_closure(stiffening: bool
                                                                        ) -> None:
    loops = _four_bar(stiffening, x=0.21)  # a point inside the coupler, not its tip
    y, u = random_state(loops, 2)
    work = loops.workspace(y.size)
    load_state(loops.data, work, u, y)
    q0, v0 = work.q.copy(), work.v.copy()
    constraints(loops.data, work)
    G, gamma = work.G.copy(), work.gam.copy()
    fd, second, first = closure_differences(loops, work, q0, v0)
    for c in range(q0.size):
        assert np.abs(fd[:, c] - G[:, c]).max() < 1e-7 * max(1.0, np.abs(G).max()), c
    assert np.abs(second - gamma).max() < 1e-5 * max(1.0, np.abs(gamma).max())
    assert np.abs(G @ v0 - first).max() < 1e-8


@pytest.mark.parametrize("stiffening", [False, True])
def test_constrained_accelerations_satisfy_the_numpy_equations(stiffening: bool) -> None:
    """M ẍ + r = Q + Gᵀλ on the free and elastic rows (ForwardSystem.matrices, the
    reference) and G ẍ + γ = 0, at the kernel's accelerations and multipliers."""
    loops = _four_bar(stiffening)
    y, u = random_state(loops, 3)
    work = loops.workspace(y.size)
    assert solve_constrained(loops.data, work, u, y)
    residual, f, closure = numpy_equations(loops, work, u)
    scale = np.abs(f).max()
    assert np.abs(residual).max() < 1e-9 * scale
    assert np.abs(closure).max() < 1e-9 * np.abs(work.gam).max()


def _moving(kind: str, closure: str) -> LoopSystem:
    """The four-bar (``closure`` = "revolute": the coupler pinned to the rocker) or a
    slider-crank (``"slider"``: the coupler's tip on a line through a point of the base,
    the rocker left hanging) on a moving base: free, pinned, or a cart on a rail at 20°
    (prescribed travel) with its attitude 15°. Ground points and lines are fixed in the
    base."""
    from flexlink.model import Cart

    links = (Link("crank", CRANK, 2.0, 40.0, modes=2),
             Link("coupler", COUPLER, 0.3, 20.0, modes=3, mode_shapes="pinned_pinned"),
             Link("rocker", ROCKER, 1.0, 30.0, modes=2, tip_mass=0.05))
    joints = (Spinup(100.0, 0.0, 0.5, 80.0), TorqueDrive(ZERO, math.radians(-55.0)),
              TorqueDrive(ZERO, math.radians(100.0)))
    if kind == "cart":
        base = Base("cart", 3.0, attachments=((2, D),), position=(0.1, -0.2),
                    attitude=math.radians(15.0),
                    cart=Cart(Spinup(30.0, 0.0, 0.5, 0.0), math.radians(20.0)))
    else:
        base = Base(kind, 3.0, 0.2, attachments=((2, D),), position=(0.1, -0.2),
                    attitude=0.3, velocity=(0.4, -0.1), rate=0.7)
    system = ForwardSystem(Chain(links, joints), base, True)
    if closure == "revolute":
        return LoopSystem(system, [Closure("pin", "revolute", 1, 0.21, 2, ROCKER)])
    return LoopSystem(system, [Closure("piston", "slider", 1, COUPLER, None, 0.0, (0.05, 0.1),
                                       math.radians(30.0))])


@pytest.mark.parametrize("closure", ["revolute", "slider"])
@pytest.mark.parametrize("kind", ["free", "pinned", "cart"])
def test_a_moving_base_carries_the_closures_ground_and_its_derivatives(kind: str,
                                                                       closure: str) -> None:
    """On a moving base: G against central differences of Φ over every coordinate (the
    base's included), γ against the second difference of Φ along a motion with q̈ = 0
    (a slider's line turns with a pinned or free base), and a closure to the ground in the
    base frame: Φ unchanged by a rigid motion of the whole mechanism with its base."""
    loops = _moving(kind, closure)
    y, u = random_state(loops, 4)
    work = loops.workspace(y.size)
    load_state(loops.data, work, u, y)
    if kind != "cart":  # the base's own rates: random too
        work.v[:loops.system.n_base] = np.random.default_rng(5).standard_normal(
            loops.system.n_base)
    q0, v0 = work.q.copy(), work.v.copy()
    constraints(loops.data, work)
    G, gamma, phi0 = work.G.copy(), work.gam.copy(), work.Phi.copy()
    assert np.abs(phi0).max() > 1e-3  # a state off the closure: the terms do not vanish
    fd, second, _ = closure_differences(loops, work, q0, v0)
    for c in range(q0.size):
        assert np.abs(fd[:, c] - G[:, c]).max() < 1e-7 * max(1.0, np.abs(G).max()), c
    assert np.abs(second - gamma).max() < 1e-5 * max(1.0, np.abs(gamma).max())
    if kind == "free":  # translate and turn the base: every point, pivot and line with it
        moved = q0.copy()
        moved[0] += 0.3
        moved[1] -= 0.2
        shifted = phi_at(loops, work, moved, v0)
        assert np.abs(shifted - phi0).max() < 1e-12
    if kind != "cart":
        turned = q0.copy()
        turned[loops.system.n_base - 1] += 0.4
        if kind == "free":  # about the base's reference point
            c, s = np.cos(0.4), np.sin(0.4)
            turned[0], turned[1] = c * q0[0] - s * q0[1], s * q0[0] + c * q0[1]
        rotated = phi_at(loops, work, turned, v0)
        if closure == "slider":  # a distance to the line: unchanged
            assert abs(rotated[0] - phi0[0]) < 1e-12
        else:  # the gap turns with the mechanism
            c, s = np.cos(0.4), np.sin(0.4)
            assert np.abs(rotated - [c * phi0[0] - s * phi0[1], s * phi0[0] + c * phi0[1]]
                          ).max() < 1e-12


@pytest.mark.parametrize("kind", ["free", "pinned", "cart"])
def test_constrained_accelerations_on_a_moving_base_satisfy_the_numpy_equations(kind: str
                                                                               ) -> None:
    """M ẍ + r = Q + Gᵀλ on the free rows (the base's too) and G ẍ + γ = 0 on a moving
    base, as on a fixed one."""
    loops = _moving(kind, "revolute")
    y, u = random_state(loops, 6)
    work = loops.workspace(y.size)
    assert solve_constrained(loops.data, work, u, y)
    residual, f, closure = numpy_equations(loops, work, u)
    assert np.abs(residual).max() < 1e-9 * np.abs(f).max()
    assert np.abs(closure).max() < 1e-9 * np.abs(work.gam).max()


def test_the_outputs_pass_returns_the_rates_of_its_projected_states() -> None:
    """closed_states projects each state and takes its rates from the same constrained
    solve: equal to the bit to the rates of the state, which project it again."""
    from flexlink.dynamics.loops import closed_states
    from flexlink.solvers._radau_numba import rates_function

    loops = _four_bar(True)
    states = np.array([random_state(loops, seed)[0] for seed in (7, 8, 9)])
    nu = len(loops.system.free)
    states[:, loops.dep] += 1e-3  # off the loop: the pass must close them
    states[:, nu + loops.dep] += 0.1
    t = np.array([0.1, 0.2, 0.3])
    u = inputs(loops.system, t)
    closed, dy, lam, _, residual = closed_states(loops, t, states, u)
    assert np.all(residual <= loops.data.tol)
    assert np.abs(closed[:, loops.dep] - states[:, loops.dep]).min() > 1e-6
    work = loops.workspace(states.shape[1])
    rates = rates_function(loops.data, work)
    for i in range(t.size):
        expected = np.empty(states.shape[1])
        rates(u[i], states[i], expected)
        assert np.array_equal(dy[i], expected)
        assert solve_constrained(loops.data, work, u[i], states[i])
        assert np.array_equal(work.yp, closed[i])
        assert np.array_equal(work.rhs[nu + loops.system.n:], lam[i])
