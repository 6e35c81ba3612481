"""The closed loops' kernel on the nonlinear model with a slider inside the chain
(`_nonlinear_loops_numba.constraints`: the travel s is the length of the slider's line node):
G, the prescribed share of Φ̇ and γ against differences of the closure equations, with the
travel free or prescribed, on fixed and moving bases; the constrained ÿ, λ against the
model's residual; the dependent joints and the start chosen on this model's kinematics."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.nonlinear_loops import NonlinearLoopSystem
from flexlink.scenario import scenario_from_dict
from flexlink.simulation.nonlinear_forward import nonlinear_forward_system
from tests.unit.test_nonlinear_loops_kernel import MOVING, _check_derivatives, _phi
from tests.unit.test_nonlinear_loops_kernel import (
    test_constrained_accelerations_solve_the_models_equations_on_a_moving_base as _solved,
)
from tests.validation.test_nonlinear_slider_loops import slider_loop_case

BASES = {"fixed": None, **{k: MOVING[k] for k in ("pinned", "free", "cart")}}
CASES = [(drive, base) for drive in ("force", "prescribed") for base in BASES]


@pytest.fixture(scope="module", params=CASES, ids=[f"{d}-{b}" for d, b in CASES])
def loops(request) -> NonlinearLoopSystem:
    drive, base = request.param
    scenario = scenario_from_dict(slider_loop_case(drive, flexible=True, base=BASES[base]))
    return NonlinearLoopSystem(nonlinear_forward_system(scenario), scenario.closures)


def test_jacobian_and_velocity_terms_carry_the_travel(loops) -> None:
    assert loops.system.slides
    _check_derivatives(loops)


def test_constrained_accelerations_solve_the_models_equations(loops) -> None:
    _solved(loops)


def test_the_start_closes_the_loop_at_the_given_travel(loops) -> None:
    """The dependent joints (the travel and the rod when it is free) are chosen and the loop
    closed on this model: the start keeps the given travel 0.1 m and rod angle −90°, where
    the loop is closed already."""
    s = loops.system
    w = loops.workspace()
    phi, *_ = _phi(loops, w, 0.0, loops.y0)
    assert np.abs(phi).max() < 1e-12 * loops.size
    p = s.rigid_state(np.zeros(1), loops.y0[None, :s.n_y], loops.y0[None, s.n_y:],
                      np.zeros((1, s.n_y)))[0][0]
    k = s.n_base
    assert p[k + 1] == pytest.approx(0.1, abs=1e-12)
    assert p[k + 2] == pytest.approx(-np.pi / 2, abs=1e-12)
