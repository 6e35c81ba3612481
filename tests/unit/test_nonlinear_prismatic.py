"""Sliders inside a chain on the geometrically nonlinear model (dynamics/nonlinear_forward.py,
docs/prismatic_joints.md): the compiled residual against the numpy equations, the rigid
limit against the first-order model (both exact there), energy against work, and the
scenario path (channels, travel)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from flexlink.dynamics.forward import ForwardSystem
from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
from flexlink.model import (
    Base,
    Chain,
    Step,
    TorqueDrive,
)
from tests.unit._slider_cases import telescope, telescoping_arm


def _random_states(system: NonlinearForwardSystem, seed: int = 1, b: int = 6):
    rng = np.random.default_rng(seed)
    t = rng.uniform(0.0, 1.5, b)
    y = 0.1 * rng.normal(size=(b, system.n_y))
    y[:, system.n:] = rng.uniform(-0.5, 0.5, (b, system.n_y - system.n))
    return t, y, rng.normal(size=(b, system.n_y)), rng.normal(size=(b, system.n_y))


@pytest.mark.parametrize("gravity", [(0.0, 0.0), (0.0, -9.81)])
@pytest.mark.parametrize("drive", ["force", "prescribed", "servo"])
def test_compiled_residual_matches_the_numpy_equations(drive: str, gravity) -> None:
    """Random states: the compiled accelerations equal the numpy ones to 1e-9 of their size
    (the round-off of the two solves), with the slider's travel free or an input."""
    system = NonlinearForwardSystem(telescope(drive), Base(), gravity=gravity)
    assert len(system.lines) == 1 and (system.line_col[0] >= 0) == (drive != "prescribed")
    t, y, v, _ = _random_states(system)
    got = system.accelerations(t, y, v, compiled=True)
    expected = system.accelerations(t, y, v, compiled=False)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("cart", [False, True], ids=["fixed", "cart"])
@pytest.mark.parametrize("drive", ["force", "prescribed", "servo"])
def test_compiled_joint_torques_match_the_numpy_equations(drive: str, cart: bool) -> None:
    """Random states, gravity on: the compiled joint torques (a slider's column the force
    along its line) equal the numpy ones to round-off, the travel free or an input, on a
    fixed base and on a cart."""
    from flexlink.model import Cart

    base = Base("cart", mass=1.0, cart=Cart()) if cart else Base()
    system = NonlinearForwardSystem(telescope(drive), base, gravity=(0.0, -9.81))
    t, y, v, a = _random_states(system)
    got = system.joint_torques(t, y, v, a, compiled=True)
    expected = system.joint_torques(t, y, v, a, compiled=False)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12 * np.abs(expected).max())


def test_equations_are_the_lagrangian_of_the_point_masses() -> None:
    """The residual's inertia part on every free coordinate equals d/dt ∂T/∂ẏ − ∂T/∂y of
    the kinetic energy from the exact positions (`point_motion`), by central differences,
    along a random motion y(t) = y0 + v0 t + ½ a0 t² (undamped, no gravity, no loads)."""
    chain = telescope("force", torques=(0.0, 0.0, 0.0))
    chain = Chain(tuple(replace(link, damping_ratio=0.0) for link in chain.links), chain.joints)
    system = NonlinearForwardSystem(chain, Base())
    rng = np.random.default_rng(7)
    m = system.n + system.nu
    y0, v0, a0 = 0.2 * rng.normal(size=m), rng.normal(size=m), rng.normal(size=m)
    y0[system.line_col[0]] = 0.3
    t0 = 0.9  # every drive's force is off

    def kinetic(y: np.ndarray, v: np.ndarray) -> float:
        return float(system.energy(np.array([t0]), y[None], v[None])[0][0])

    h = 1e-5
    grad_v = lambda y, v: np.array([(kinetic(y, v + h * e) - kinetic(y, v - h * e)) / (2 * h)
                                    for e in np.eye(m)])
    y_at = lambda dt: y0 + v0 * dt + 0.5 * a0 * dt**2
    v_at = lambda dt: v0 + a0 * dt
    dt = 1e-4
    ddt = (grad_v(y_at(dt), v_at(dt)) - grad_v(y_at(-dt), v_at(-dt))) / (2 * dt)
    grad_y = np.array([(kinetic(y0 + h * e, v0) - kinetic(y0 - h * e, v0)) / (2 * h)
                       for e in np.eye(m)])
    t = np.array([t0])
    residual = system.residual(t, y0[None], v0[None], a0[None], system.stage_inputs(t))[0]
    elastic = np.zeros(m)
    elastic[:system.n] = system.K @ y0[:system.n]
    lagrange = ddt - grad_y
    np.testing.assert_allclose(residual - elastic, lagrange, rtol=0,
                               atol=1e-5 * np.abs(lagrange).max())


def assert_rigid_models_agree(chain: Chain, gravity) -> None:
    """Rigid links: the nonlinear and first-order models' free accelerations and every
    joint's torque or force agree to round-off at random states."""
    system = NonlinearForwardSystem(chain, Base(), gravity=gravity)
    first = ForwardSystem(chain, Base(), gravity=gravity)
    t, y, v, _ = _random_states(system, seed=5)
    nu = system.nu
    got = system.accelerations(t, y, v, compiled=True)
    none = np.zeros((t.size, 0))
    expected = first.accelerations(t, y[:, :nu], v[:, :nu], none, none, v[:, nu:])[0]
    np.testing.assert_allclose(got[:, :nu], expected, rtol=0,
                               atol=1e-12 * np.abs(expected).max())
    p, pd, pdd = system.rigid_state(t, y, v, got)
    torques = system.joint_torques(t, y, v, got)
    reference = first.joint_torques(p, pd, pdd, none, none, none)
    np.testing.assert_allclose(torques, reference, rtol=0,
                               atol=1e-12 * np.abs(reference).max())


@pytest.mark.parametrize("gravity", [(0.0, 0.0), (3.0, -9.81)])
@pytest.mark.parametrize("drive", ["force", "prescribed", "servo"])
def test_rigid_limit_equals_the_first_order_model(drive: str, gravity) -> None:
    """Rigid links (no modes): both models are exact, so the free rigid coordinates'
    accelerations and every joint's torque or force agree to round-off."""
    assert_rigid_models_agree(telescope(drive, modes=0), gravity)


def test_energy_equals_the_drives_work() -> None:
    """Undamped links under gravity, constant drive torques and force from t = 0: kinetic +
    elastic + gravitational energy changes by the drives' work τ Δβ + F Δs, to the
    integration tolerance."""
    from flexlink.solvers.gauss_forward import solve_nonlinear_forward

    tau, force, tau3 = 0.8, 1.5, -0.1
    chain = telescope("force", torques=(tau, force, tau3))
    links = tuple(replace(link, damping_ratio=0.0) for link in chain.links)
    joints = (TorqueDrive(Step(tau), 0.2, 0.3), replace(
        chain.joints[1], drive=TorqueDrive(Step(force), 0.1, 0.2)), chain.joints[2])
    system = NonlinearForwardSystem(Chain(links, joints), Base(), gravity=(0.0, -9.81))
    t = np.linspace(0.0, 1.5, 301)
    solution = solve_nonlinear_forward(system, t, rtol=1e-8)
    y, v, a = system.from_solution(solution)
    kinetic, strain = system.energy(t, y, v)
    energy = kinetic + strain + system.potential(t, y)
    p = system.rigid_state(t, y, v, a)[0]
    work = tau * (p[:, 0] - p[0, 0]) + force * (p[:, 1] - p[0, 1]) + tau3 * (p[:, 2] - p[0, 2])
    assert np.ptp(p[:, 1]) > 0.3  # the slider travels
    np.testing.assert_allclose(energy - energy[0], work, rtol=0,
                               atol=1e-6 * np.abs(kinetic).max())


# --- scenario path -----------------------------------------------------------------------------

def _example() -> dict:
    return telescoping_arm(t_end=0.5, model="nonlinear")


def test_the_example_runs_on_the_nonlinear_model_with_the_slider_channels() -> None:
    """examples/telescoping_arm.toml with model = "nonlinear": the slider's channels in m,
    m/s, N; its position is the prescribed travel; at this small deflection the stiffened
    first-order run's hub torque and arm tip agree within 0.5% of their peaks (measured
    0.04%, 0.08%, 0.05%)."""
    from flexlink import simulate
    from flexlink.scenario import scenario_from_dict

    d = _example()
    scenario = scenario_from_dict(d)
    r = simulate(scenario, shapes=False)
    for name, unit in (("joint2_position", "m"), ("joint2_velocity", "m s-1"),
                       ("joint2_force", "N")):
        assert r.channels[name].unit == unit
    joint = scenario.chain.joints[1]
    np.testing.assert_allclose(r["joint2_position"], joint.evaluate(r.time)[0], atol=1e-12)
    d["simulation"]["model"] = "first_order"
    first = simulate(scenario_from_dict(d), shapes=False)
    for name in ("joint1_torque", "arm_tip_X", "arm_tip_Y"):
        scale = np.abs(first[name]).max()
        assert np.abs(r[name] - first[name]).max() < 5e-3 * scale, name


def test_a_driven_slider_that_leaves_its_travel_ends_the_nonlinear_run() -> None:
    """A force-driven slider pushed past its travel on the nonlinear model: the run ends with
    an error naming joints[1].travel and the first output time outside (never clipped)."""
    from flexlink import simulate
    from flexlink.errors import SimulationError
    from flexlink.scenario import scenario_from_dict

    d = _example()
    slider = {k: v for k, v in d["joints"][1].items() if k not in ("motion",)}
    slider.update(drive="force", force=[{"profile": "step", "amplitude": 5.0}],
                  initial_position=0.1, initial_velocity=0.0, travel=[0.0, 0.15])
    d["joints"][1] = slider
    with pytest.raises(SimulationError, match=r"joints\[1\].travel\): s = 0.15\d* m at t = 0.1"):
        simulate(scenario_from_dict(d), shapes=False)
