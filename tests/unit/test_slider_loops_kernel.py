"""The first-order closed loops' kernel (`_loops_numba.frames`, `slide`) with a slider inside
the chain (the mechanism of tests/validation/test_nonlinear_slider_loops.py, crank and rod
flexible): frame k sits on the block at the travel s along the line through the parent's
section, turned with it. G against central differences of Φ over every coordinate (the
travel's column included), γ against the second difference of Φ along a motion with q̈ = 0,
on fixed and moving bases with the travel force-driven or prescribed; the constrained
accelerations against the numpy equations with the multipliers; the start closed at the
given travel."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.forward_kernel import inputs
from flexlink.dynamics.loops import LoopSystem
from flexlink.scenario import scenario_from_dict
from flexlink.simulation.forward import forward_system
from tests.unit._loops_checks import (
    closure_differences,
    constraints,
    load_state,
    numpy_equations,
    random_state,
    solve_constrained,
    velocity_terms,
)
from tests.unit.test_nonlinear_loops_kernel import MOVING
from tests.validation.test_nonlinear_slider_loops import slider_loop_case

BASES = {"fixed": None, **{k: MOVING[k] for k in ("pinned", "free", "cart")}}
CASES = [(drive, base) for drive in ("force", "prescribed") for base in BASES]


@pytest.fixture(scope="module", params=CASES, ids=[f"{d}-{b}" for d, b in CASES])
def loops(request) -> LoopSystem:
    drive, base = request.param
    d = slider_loop_case(drive, flexible=True, base=BASES[base])
    d["simulation"].update(model="first_order", geometric_stiffening=True)
    scenario = scenario_from_dict(d)
    return LoopSystem(forward_system(scenario), scenario.closures)


def test_jacobian_and_acceleration_terms_carry_the_travel(loops) -> None:
    y, u = random_state(loops, 2)
    work = loops.workspace(y.size)
    load_state(loops.data, work, u, y)
    system = loops.system
    if system.n_base:  # the base's own rates: random too
        work.v[:system.n_base] = np.random.default_rng(5).standard_normal(system.n_base)
    travel = system.joint_index(1)
    work.v[travel] = 0.7  # the block sliding
    q0, v0 = work.q.copy(), work.v.copy()
    constraints(loops.data, work)
    G, gamma = work.G.copy(), work.gam.copy()
    assert np.abs(G[:, travel]).max() > 0.1
    fd, second, first = closure_differences(loops, work, q0, v0)
    for c in range(q0.size):
        assert np.abs(fd[:, c] - G[:, c]).max() < 1e-7 * max(1.0, np.abs(G).max()), c
    assert np.abs(second - gamma).max() < 1e-5 * max(1.0, np.abs(gamma).max())
    assert np.abs(G @ v0 - first).max() < 1e-8


def test_the_pass_without_jacobians_gives_the_full_passs_gamma(loops) -> None:
    """The projection's last pass (rates changed at the same coordinates) computes Φ and γ
    alone: the same numbers as the full pass, and G left as the full pass at those
    coordinates made it."""
    y, u = random_state(loops, 4)
    work = loops.workspace(y.size)
    load_state(loops.data, work, u, y)
    constraints(loops.data, work)
    G = work.G.copy()
    work.v[:] = np.random.default_rng(6).standard_normal(work.v.size)
    velocity_terms(loops.data, work)
    assert np.array_equal(work.G, G)
    gamma, phi = work.gam.copy(), work.Phi.copy()
    assert np.abs(gamma).max() > 0.0
    constraints(loops.data, work)
    assert np.array_equal(work.gam, gamma)
    assert np.array_equal(work.Phi, phi)
    assert np.array_equal(work.G, G)


def test_constrained_accelerations_satisfy_the_numpy_equations(loops) -> None:
    """M ẍ + r = Q + Gᵀλ on the free and elastic rows (ForwardSystem.matrices) and
    G ẍ + γ = 0, at the kernel's accelerations and multipliers."""
    y, u = random_state(loops, 3)
    work = loops.workspace(y.size)
    assert solve_constrained(loops.data, work, u, y)
    residual, f, closure = numpy_equations(loops, work, u)
    assert np.abs(residual).max() < 1e-9 * np.abs(f).max()
    assert np.abs(closure).max() < \
        1e-9 * max(np.abs(work.gam).max(), 1e-12)


def test_the_start_closes_the_loop_at_the_given_travel(loops) -> None:
    """The given travel 0.1 m and rod angle −90° close the loop already: the start keeps
    them, closed to the kernel's tolerance."""
    system = loops.system
    work = loops.workspace(loops.y0.size)
    u = inputs(system, np.zeros(1))[0]
    load_state(loops.data, work, u, loops.y0)
    constraints(loops.data, work)
    assert np.abs(work.Phi).max() < 1e-11 * loops.size
    k = system.n_base
    p = system.rigid_state(np.zeros(1), loops.y0[None, :len(system.free)],
                           loops.y0[None, len(system.free):2 * len(system.free)],
                           np.zeros((1, len(system.free))))[0][0]
    assert p[k + 1] == pytest.approx(0.1, abs=1e-12)
    assert p[k + 2] == pytest.approx(-np.pi / 2, abs=1e-12)
