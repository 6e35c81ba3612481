"""The compiled kernels of closed loops on the nonlinear model
(dynamics/_nonlinear_loops_numba.py) against differences of their own closure equations and
against the model's residual: the Jacobian G, the prescribed joints' share of Φ̇, γ (Φ̈ at
ÿ = 0), the mass matrix (the residual's change under unit accelerations) and the closure
at t = 0."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from numba import njit

from flexlink.dynamics import _nonlinear_loops_numba as kernels
from flexlink.dynamics.forward_kernel import inputs
from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
from flexlink.dynamics.nonlinear_loops import NonlinearLoopSystem
from flexlink.scenario import scenario_from_dict
from tests.validation.test_closed_loops import (
    FOUR_BAR,
    L2,
    ROD,
    SLIDER_CRANK,
    D,
    _four_bar_angles,
)

T = 0.13  # s: the crank is spinning up (rate and acceleration both non-zero)


# The kernels' parts have no Python wrappers (only kernels call them): reached from here
# through these.
@njit
def _prescribed(d, w, u):
    kernels.prescribed(d, w, u)


@njit
def _positions(d, w, Y):
    kernels.positions(d, w, Y, bool(1))


@njit
def _curvature(d, w, Y):
    kernels.curvature(d, w, Y)


@pytest.fixture(scope="module")
def loops() -> NonlinearLoopSystem:
    d = copy.deepcopy(FOUR_BAR)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 2.0,
                     "modes": 3}
    d["simulation"]["model"] = "nonlinear"
    scenario = scenario_from_dict(d)
    return NonlinearLoopSystem(NonlinearForwardSystem(scenario.chain, scenario.base),
                               scenario.closures)


def _on_base(mechanism: str, base: dict) -> NonlinearLoopSystem:
    """A slider-crank (flexible rod, slider line at 25° through (0.05, 0.02)) or a four-bar
    closed by a pin to the ground (crank, flexible coupler and rocker in series, the
    rocker's tip pinned at the base's point (D, 0)) on the ``base``."""
    if mechanism == "slider":
        d = copy.deepcopy(SLIDER_CRANK)
        d["links"][1] = {"name": "rod", "length": ROD, "mass_per_length": 0.2, "EI": 5.0,
                         "modes": 2, "tip_mass": 0.1}
        d["joints"][1]["initial_angle_deg"] = -40.0
        d["closures"][0].update(ground=[0.05, 0.02], angle_deg=25.0)
    else:
        d = copy.deepcopy(FOUR_BAR)
        d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 2.0,
                         "modes": 3}
        a, b, c = _four_bar_angles(np.pi / 2)
        d["joints"][1]["initial_angle_deg"] = np.degrees(b - a)
        d["joints"][2] = {"drive": "free", "initial_angle_deg": np.degrees(c + np.pi - b)}
        d["closures"] = [{"name": "pin", "link": "rocker", "ground": [D, 0.0]}]
    d["joints"][0] = {"drive": "free", "initial_angle_deg": 80.0, "initial_rate_deg_s": 90.0}
    d["base"] = base
    d["simulation"]["model"] = "nonlinear"
    scenario = scenario_from_dict(d)
    return NonlinearLoopSystem(NonlinearForwardSystem(scenario.chain, scenario.base,
                                                      gravity=(0.0, -9.81)),
                               scenario.closures)


MOVING = {
    "pinned": {"type": "pinned", "inertia": 0.01, "attitude_deg": 10.0},
    "free": {"type": "free", "mass": 2.0, "inertia": 0.01, "attitude_deg": -15.0},
    "cart": {"type": "cart", "mass": 3.0, "attitude_deg": 20.0,
             "cart": {"rail_angle_deg": 30.0, "drive": "force",
                      "force": [{"profile": "step", "amplitude": 1.0}]}},
    "cart-prescribed": {"type": "cart", "mass": 3.0, "attitude_deg": 20.0,
                        "cart": {"rail_angle_deg": 30.0, "drive": "prescribed",
                                 "motion": [{"profile": "cycloidal", "from": 0.0, "to": 0.2,
                                             "start": 0.0, "duration": 0.5}]}},
}
CASES = [(m, b) for m in ("slider", "pin") for b in MOVING]


@pytest.fixture(scope="module", params=CASES, ids=[f"{m}-{b}" for m, b in CASES])
def moving(request) -> NonlinearLoopSystem:
    mechanism, base = request.param
    return _on_base(mechanism, MOVING[base])


def _state(loops: NonlinearLoopSystem) -> np.ndarray:
    rng = np.random.default_rng(3)
    Y = loops.y0.copy()
    n = loops.system.n
    ny = loops.system.n_y
    Y[:n] = 1e-2 * rng.standard_normal(n)  # a visibly bent coupler
    Y[ny:] = rng.standard_normal(ny)
    return Y


def _phi(loops, w, t: float, Y: np.ndarray) -> tuple[np.ndarray, ...]:
    kernels.constraints(loops.data, w, inputs(loops.system.loads, np.array([t]))[0], Y)
    return w.Phi.copy(), w.G.copy(), w.gam.copy(), w.Phid.copy()


def test_jacobian_and_velocity_terms_are_the_closure_equations_derivatives(loops) -> None:
    _check_derivatives(loops)


def test_jacobian_and_velocity_terms_on_a_moving_base(moving) -> None:
    """A turning base turns the ground point and the slider's line: their terms on the
    attitude; a cart's travel moves the ground point with the mechanism."""
    _check_derivatives(moving)


def _check_derivatives(loops: NonlinearLoopSystem) -> None:
    w = loops.workspace()
    Y = _state(loops)
    ny = loops.system.n_y
    _, G, gam, phid = _phi(loops, w, T, Y)
    h = 1e-6
    for i in range(ny):
        up, down = Y.copy(), Y.copy()
        up[i] += h
        down[i] -= h
        diff = (_phi(loops, w, T, up)[0] - _phi(loops, w, T, down)[0]) / (2 * h)
        np.testing.assert_allclose(G[:, i], diff, atol=1e-8)

    def along(tau: float) -> np.ndarray:  # Φ on the path y + ẏ τ (ÿ = 0), joints prescribed
        Z = Y.copy()
        Z[:ny] += Y[ny:] * tau
        return _phi(loops, w, T + tau, Z)

    rate = (along(h)[0] - along(-h)[0]) / (2 * h)
    np.testing.assert_allclose(G @ Y[ny:] + phid, rate, atol=1e-7)
    # Φ̈ at ÿ = 0 is γ: Φ̇ = G ẏ + Φ̇ₚ differenced along the same path (ẏ constant)
    h = 1e-5
    dots = [g @ Y[ny:] + p for _, g, _, p in (along(h), along(-h))]
    np.testing.assert_allclose(gam, (dots[0] - dots[1]) / (2 * h), rtol=1e-6,
                               atol=1e-6 * np.abs(gam).max())


def test_mass_matrix_is_the_residuals_change_under_unit_accelerations(loops) -> None:
    """The constrained solve's M (`_nonlinear_numba.mass_matrix`) against the columns of
    the model's residual, which is affine in ÿ."""
    from flexlink.dynamics._nonlinear_forward_numba import residual
    from flexlink.dynamics._nonlinear_numba import mass_matrix

    w = loops.workspace()
    Y = _state(loops)
    ny = loops.system.n_y
    u = inputs(loops.system.loads, np.array([T]))[0]
    _phi(loops, w, T, Y)
    f = loops.data.fwd
    M = np.empty((f.Ay.shape[1],) * 2)
    mass_matrix(f.Ay, loops.data.At, f.G, f.rot_y, f.rot_J, w.c, w.s,
                np.empty((f.Ay.shape[0],) * 2), np.empty(f.Ay.shape[::-1]), M)
    X = np.zeros(ny)
    r0, r1 = np.empty(ny), np.empty(ny)
    residual(f, Y[:ny], Y[ny:], X, w.ang, w.rate, w.acc, w.rot_acc, u, r0)
    for k in range(ny):
        X[:] = 0.0
        X[k] = 1.0
        residual(f, Y[:ny], Y[ny:], X, w.ang, w.rate, w.acc, w.rot_acc, u, r1)
        np.testing.assert_allclose(M[:, k], r1 - r0, atol=1e-12 * np.abs(M).max())


def test_prescribed_parts_are_the_models_stage_inputs(loops) -> None:
    w = loops.workspace()
    t = np.array([T])
    kernels.constraints(loops.data, w, inputs(loops.system.loads, t)[0], loops.y0)
    stage = loops.system.stage_inputs(t)
    np.testing.assert_allclose(w.ang, stage.angle[0], atol=1e-14)
    np.testing.assert_allclose(w.rate, stage.rate[0], atol=1e-14)
    np.testing.assert_allclose(w.acc, stage.acceleration[0], atol=1e-12)
    np.testing.assert_allclose(w.rot_acc, stage.rot_acceleration[0], atol=1e-12)


def test_the_start_is_closed_and_projection_closes_a_bent_state(loops) -> None:
    w = loops.workspace()
    phi, *_ = _phi(loops, w, 0.0, loops.y0)
    assert np.abs(phi).max() < 1e-12 * loops.size
    Y = _state(loops)  # at T, where the prescribed crank turns: Φ̇ has its share
    assert kernels.project(loops.data, w, inputs(loops.system.loads, np.array([T]))[0], Y)
    phi, G, _, phid = _phi(loops, w, T, Y)
    ny = loops.system.n_y
    assert np.abs(phid).max() > 1e-2
    assert np.abs(phi).max() < 1e-12 * loops.size
    assert np.abs(G @ Y[ny:] + phid).max() < 1e-10


def test_constrained_accelerations_solve_the_models_equations_on_a_moving_base(moving
                                                                                ) -> None:
    """The kernel's ÿ and λ (the mass matrix with the base's translation columns) satisfy
    the model's residual r(ÿ) = Gᵀλ (`_nonlinear_forward_numba.residual`, gravity on) and
    G ÿ + γ = 0 at a projected, bent, moving state; Φ invariant under a rigid motion of the
    whole system (the base's coordinates with the mechanism)."""
    from flexlink.dynamics._nonlinear_forward_numba import residual
    from flexlink.solvers._radau_numba import rates_function

    loops = moving
    w = loops.workspace()
    Y = _state(loops)
    ny = loops.system.n_y
    u = inputs(loops.system.loads, np.array([T]))[0]
    assert kernels.project(loops.data, w, u, Y)
    dY = np.empty_like(Y)
    rates_function(loops.data, w)(u, Y, dY)
    a, lam = w.rhs[:ny].copy(), w.rhs[ny:].copy()
    _, G, gam, _ = _phi(loops, w, T, Y)
    r = np.empty(ny)
    residual(loops.data.fwd, Y[:ny], Y[ny:], a.copy(), w.ang, w.rate, w.acc, w.rot_acc, u, r)
    scale = np.abs(G.T @ lam).max() + np.abs(r).max()
    np.testing.assert_allclose(r, G.T @ lam, atol=1e-10 * scale)
    np.testing.assert_allclose(G @ a, -gam, atol=1e-10 * np.abs(gam).max())
    assert np.abs(dY[ny:] - a).max() == 0.0
    s = loops.system
    if s.base.turns:  # turning the base (and so everything on it) leaves Φ unchanged
        Z = Y.copy()
        Z[s.n + s.free.index(s.n_base - 1)] += 0.7
        assert np.abs(_phi(loops, w, T, Z)[0] - _phi(loops, w, T, Y)[0]).max() < 1e-12


def test_positions_need_no_rates_and_curvature_completes_them(moving) -> None:
    """The closure's Newton iteration evaluates `positions` alone: Φ, G, ∂Φ/∂β and the
    prescribed joints' share of Φ̇ do not depend on the rates of y, and `curvature` then
    gives the γ of the whole `constraints` (on every moving base)."""
    w = moving.workspace()
    Y = _state(moving)
    ny = moving.system.n_y
    Phi, G, gam, phid = _phi(moving, w, T, Y)
    GJ = w.GJ.copy()
    other = Y.copy()
    other[ny:] = np.random.default_rng(5).standard_normal(ny)
    _positions(moving.data, w, other)
    for got, want in ((w.Phi, Phi), (w.G, G), (w.GJ, GJ), (w.Phid, phid)):
        np.testing.assert_array_equal(got, want)
    _positions(moving.data, w, Y)
    _curvature(moving.data, w, Y)
    np.testing.assert_array_equal(w.gam, gam)


def test_nonlinear_closed_loops_default_to_the_radau_tolerance() -> None:
    """Closed loops on the nonlinear model run on Radau IIA, whose rtol is a global error
    as on first-order forward runs: without an rtol they take that path's default; the
    Gauss collocation's nonlinear runs keep theirs, and an rtol given is kept."""
    from flexlink.model.settings import DEFAULT_RTOL, FORWARD_RTOL

    d = copy.deepcopy(FOUR_BAR)
    d["simulation"]["model"] = "nonlinear"
    d["simulation"].pop("rtol", None)
    assert scenario_from_dict(d).settings.rtol == FORWARD_RTOL != DEFAULT_RTOL["nonlinear"]
    d["simulation"]["rtol"] = 1e-7
    assert scenario_from_dict(d).settings.rtol == 1e-7
    d = copy.deepcopy(FOUR_BAR)
    d["simulation"]["model"] = "nonlinear"
    d["simulation"].pop("rtol", None)
    del d["closures"]
    d["joints"] = [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.1}]}]
    d["links"] = d["links"][:1]
    assert scenario_from_dict(d).settings.rtol == DEFAULT_RTOL["nonlinear"]


def test_projection_turns_cos_and_sin_by_small_newton_steps(moving) -> None:
    """Near a closed state the projection turns the nodes' cos and sin by each Newton step
    instead of evaluating them again: they stay those of the closed angles to round-off, and
    the state closes as from a fresh evaluation."""
    w = moving.workspace()
    u = inputs(moving.system.loads, np.array([T]))[0]
    Y = _state(moving)
    assert kernels.project(moving.data, w, u, Y)  # closed, then moved by a small step
    ny, dep = moving.system.n_y, moving.data.dep
    Y[dep] += 3e-7
    Z = Y.copy()
    assert kernels.project(moving.data, w, u, Y)
    alpha = w.ang + moving.data.fwd.Ay @ Y[:ny]
    np.testing.assert_allclose(w.c, np.cos(alpha), rtol=0, atol=1e-15)
    np.testing.assert_allclose(w.s, np.sin(alpha), rtol=0, atol=1e-15)
    assert np.abs(w.Phi).max() <= moving.data.tol
    kernels.constraints(moving.data, w, u, Y)  # everything afresh at the projected state
    assert np.abs(w.Phi).max() <= moving.data.tol
    # the same projection with the steps' cos and sin evaluated afresh: one closed state
    fresh = moving.workspace()
    _prescribed(moving.data, fresh, u)
    for _ in range(kernels.NEWTON_ITERATIONS):
        _positions(moving.data, fresh, Z)
        if np.abs(fresh.Phi).max() <= moving.data.tol:
            break
        Z[dep] += np.linalg.solve(fresh.G[:, dep], -fresh.Phi)
    np.testing.assert_allclose(Y[:ny], Z[:ny], rtol=0, atol=1e-14)


def test_compiled_joint_torques_equal_the_numpy_ones(moving) -> None:
    """`NonlinearForwardSystem.joint_torques`: the compiled kernel (the model's inertia with
    the joints' columns appended) against the numpy equations, on every moving base under
    gravity, at bent and moving states."""
    system = moving.system
    rng = np.random.default_rng(11)
    t = np.array([0.0, 0.07, T])
    y, v, a = (rng.standard_normal((t.size, system.n_y)) for _ in range(3))
    y[:, :system.n] *= 1e-2
    compiled = system.joint_torques(t, y, v, a)
    reference = system.joint_torques(t, y, v, a, compiled=False)
    assert np.abs(reference).max() > 1e-3
    np.testing.assert_allclose(compiled, reference, rtol=0,
                               atol=1e-12 * np.abs(reference).max())
