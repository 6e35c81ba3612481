"""The nonlinear model with rigid coordinates (dynamics/nonlinear_forward.py): its equations
against the Lagrangian of its own kinematics (finite differences of the kinetic energy), against
the prescribed-joint nonlinear model, and the compiled kernels and loop against the numpy
reference to round-off."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.nonlinear import NonlinearSystem
from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem, StageInputs
from flexlink.model import Base, Chain, Link, Table, TorqueDrive
from flexlink.motion import Cycloidal, Hold
from flexlink.solvers.gauss_forward import integrate_gauss_forward
from tests.helpers import paper_links
from tests.unit.test_forward_kernel import SYSTEMS


def _system(name: str) -> NonlinearForwardSystem:
    first_order = SYSTEMS[name](True)
    return NonlinearForwardSystem(first_order.chain, first_order.base,
                                  gravity=first_order.gravity)


def _random_state(system: NonlinearForwardSystem, nt: int, seed: int = 3
                  ) -> tuple[np.ndarray, ...]:
    rng = np.random.default_rng(seed)
    t = rng.uniform(0.0, 1.5, nt)
    y = rng.normal(size=(nt, system.n_y))
    y[:, :system.n] *= 0.05  # large deflections
    return t, y, rng.normal(size=(nt, system.n_y)), rng.normal(size=(nt, system.n_y))


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_compiled_kernels_match_the_numpy_equations(name: str) -> None:
    """Random states (large deflections, rigid angles of ±2 rad, servo integrals that saturate
    and not) of a free base with two branches and base loads, a pinned hub with a torque table,
    the paper arm on servos: residuals agree to 1e-11 of their size, accelerations (through
    M's condition number at these random states) to 1e-9."""
    from flexlink.dynamics._nonlinear_forward_numba import residual

    system = _system(name)
    t, y, v, a = _random_state(system, 10)
    expected = system.accelerations(t, y, v, compiled=False)
    got = system.accelerations(t, y, v, compiled=True)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())
    inp = system.stage_inputs(t)
    reference = system.residual(t, y, v, a, inp)
    data = system.kernel_data()
    out = np.empty(system.n_y)
    for i in range(t.size):
        residual(data, y[i], v[i], a[i], *(np.ascontiguousarray(x[i]) for x in inp), out)
        np.testing.assert_allclose(out, reference[i], rtol=0,
                                   atol=1e-11 * np.abs(reference[i]).max())


def test_step_end_accelerations_along_a_run_match_the_numpy_equations() -> None:
    """The compiled accelerations of a run's step ends (the mass matrix assembled from the node
    angles) against numpy's direct solve (its columns from the residual), to 1e-12 of the
    peak."""
    system = _system("pinned")
    t, y, v = integrate_gauss_forward(system, 0.5, 2e-3)
    expected = system.accelerations(t, y, v, compiled=False)
    got = system.accelerations(t, y, v, compiled=True)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


@pytest.mark.parametrize("name", ["free", "pinned", "free_gravity", "pinned_gravity"])
def test_equations_are_the_lagrangian_of_the_kinematics(name: str) -> None:
    """Inertia and elastic rows equal d/dt ∂T/∂ẏ − ∂T/∂y + K q + ∂V/∂y, T = ½Σ m|ṙ|² + ½Σ J α̇²
    and V = −Σ m g·r from the point positions (energy(), potential(), not the G, s form of the
    residual nor its gravity term), by central differences
    along y(t) = y + ẏ τ + ½ ÿ τ² (prescribed joints move with t). The applied forces and the
    σ rows are left out (the servo-free systems: drive torques are the applied forces)."""
    system = _system(name)
    t, y, v, a = _random_state(system, 3, seed=11)
    n, nu = system.n, system.nu
    rows = slice(0, n + nu)
    e = 1e-4

    def kinetic(tt: float, yy: np.ndarray, vv: np.ndarray) -> float:
        return float(system.energy(np.array([tt]), yy[None], vv[None])[0][0])

    def momentum(tt: float, yy: np.ndarray, vv: np.ndarray) -> np.ndarray:
        out = np.zeros(system.n_y)
        for i in range(n + nu):
            d = np.zeros(system.n_y)
            d[i] = e
            out[i] = (kinetic(tt, yy, vv + d) - kinetic(tt, yy, vv - d)) / (2 * e)
        return out

    for b in range(t.size):
        tau = 2e-5  # (the fast high modes: larger steps see their third derivatives)
        dpdt = (momentum(t[b] + tau, y[b] + v[b] * tau + 0.5 * a[b] * tau**2, v[b] + a[b] * tau)
                - momentum(t[b] - tau, y[b] - v[b] * tau + 0.5 * a[b] * tau**2,
                           v[b] - a[b] * tau)) / (2 * tau)
        dTdy = np.zeros(system.n_y)
        for i in range(n + nu):
            d = np.zeros(system.n_y)
            d[i] = e
            dTdy[i] = (kinetic(t[b], y[b] + d, v[b]) - kinetic(t[b], y[b] - d, v[b])) / (2 * e)
            dTdy[i] -= (system.potential(t[b:b + 1], (y[b] + d)[None])[0]
                        - system.potential(t[b:b + 1], (y[b] - d)[None])[0]) / (2 * e)
        lagrange = dpdt - dTdy
        lagrange[:n] += system.K @ y[b, :n] + system.D @ v[b, :n]
        inp = system.stage_inputs(t[b:b + 1])
        Q, _ = system.applied(t[b:b + 1], y[b:b + 1], v[b:b + 1])
        ours = system.residual(t[b:b + 1], y[b:b + 1], v[b:b + 1], a[b:b + 1], inp)[0]
        ours[n:n + nu] += Q[0]
        scale = np.abs(ours[rows]).max()
        np.testing.assert_allclose(ours[rows], lagrange[rows], rtol=0, atol=2e-6 * scale)


def test_prescribed_joints_on_a_fixed_hub_are_the_prescribed_model() -> None:
    """No free rigid coordinate: q̈ and the joint torques are NonlinearSystem's (the validated
    prescribed-joint model) to round-off."""
    chain = Chain(paper_links(3), (Cycloidal(0.0, 90.0, 0.0, 1.0), Cycloidal(0.0, -60.0, 0.2, 0.6)))
    ours, theirs = NonlinearForwardSystem(chain), NonlinearSystem(chain)
    assert ours.n_y == theirs.n
    t, y, v, _ = _random_state(ours, 6)
    a = ours.accelerations(t, y, v, compiled=False)
    np.testing.assert_allclose(a, theirs.accelerations(t, y, v, compiled=False), rtol=0,
                               atol=1e-10 * np.abs(a).max())
    torque = ours.joint_torques(t, y, v, a)
    np.testing.assert_allclose(torque, theirs.joint_torques(t, y, v, a), rtol=0,
                               atol=1e-10 * np.abs(torque).max())


def test_both_compiled_residuals_are_one_formulation() -> None:
    """Every joint prescribed on a fixed hub: the compiled residual with rigid coordinates
    (none free) and the prescribed-joint one, from their own records and stage inputs, agree
    to round-off at random states — in a gravity field, with a tip mass and inertia (the
    rotary rows)."""
    from flexlink.dynamics._nonlinear_forward_numba import residual as forward
    from flexlink.dynamics._nonlinear_numba import residual as prescribed

    link1, link2 = paper_links(3)
    link2 = Link(**{**link2.__dict__, "tip_mass": 0.01, "tip_inertia": 1e-4})
    chain = Chain((link1, link2), (Cycloidal(0.0, 90.0, 0.0, 1.0), Cycloidal(0.0, -60.0, 0.2, 0.6)))
    gravity = (3.0, -9.81)
    ours = NonlinearForwardSystem(chain, gravity=gravity)
    theirs = NonlinearSystem(chain, gravity=gravity)
    t, y, v, a = _random_state(ours, 6)
    rows_f = ours.stage_inputs(t)
    rows_p = theirs.node_inputs(t).stage_inputs()
    out_f, out_p = np.empty(ours.n_y), np.empty(theirs.n)
    for i in range(t.size):
        forward(ours.kernel_data(), y[i], v[i], a[i], *(np.ascontiguousarray(x[i]) for x in rows_f),
                out_f)
        prescribed(theirs.kernel_data(), y[i], v[i], a[i], *(x[i] for x in rows_p), out_p)
        np.testing.assert_allclose(out_f, out_p, rtol=0, atol=1e-11 * np.abs(out_p).max())


def test_a_driven_joint_torque_is_its_drive() -> None:
    """On a solution, the joint-torque reading of a torque-driven joint (inertia row with the
    motor inertia) equals the applied torque."""
    drive = TorqueDrive(Table((0.0, 0.5, 1.5), (1.0, -2.0, 0.5)), motor_inertia=0.3)
    system = NonlinearForwardSystem(Chain(paper_links(2), (drive, Hold(10.0))),
                                    Base("pinned", inertia=0.5))
    t, y, v, _ = _random_state(system, 5)
    a = system.accelerations(t, y, v)
    torque = system.joint_torques(t, y, v, a)
    np.testing.assert_allclose(torque[:, 0], drive.torque.value(t), rtol=0, atol=1e-10)


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_compiled_loop_matches_the_numpy_loop(name: str) -> None:
    """20 steps of the compiled Gauss loop equal the numpy loop (gauss.py's Newton on the
    numpy residual) to 1e-10 of the state's size."""
    system = _system(name)
    _, y, v = integrate_gauss_forward(system, 0.1, 0.005, compiled=True)
    _, y2, v2 = integrate_gauss_forward(system, 0.1, 0.005, compiled=False)
    np.testing.assert_allclose(y, y2, rtol=0, atol=1e-10 * np.abs(y).max())
    np.testing.assert_allclose(v, v2, rtol=0, atol=1e-10 * np.abs(v).max())


def test_stage_inputs_carry_the_attachment_turn() -> None:
    """A branch attached at c = (0, 0.5) on a base turned by θ_b: its root sits at
    R_b + A(θ_b)c, the attachment node's angle is θ_b + π/2 with weight |c|."""
    base = Base("free", mass=1.0, inertia=1.0, attachments=((0, (0.0, 0.5)),))
    system = NonlinearForwardSystem(Chain((Link("a", 1.0, 1.0, 10.0, modes=2),), (Hold(0.0),)),
                                    base)
    y = np.zeros((1, system.n_y))
    y[0, system.n:system.n + 3] = (0.2, -0.1, 0.3)  # x, y, θ_b
    inp: StageInputs = system.stage_inputs(np.zeros(1))
    alpha = y @ system.Ay.T + inp.angle
    root = system.root_W[0] @ np.stack([np.cos(alpha[0]), np.sin(alpha[0])], -1) + (0.2, -0.1)
    np.testing.assert_allclose(root, [0.2 - 0.5 * np.sin(0.3), -0.1 + 0.5 * np.cos(0.3)],
                               atol=1e-14)
