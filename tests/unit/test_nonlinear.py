"""The nonlinear model's equations, computed two ways (docs/nonlinear.md)."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.channels.nonlinear import sensor_values, tip_values
from flexlink.dynamics.arc import ArcQuadrature
from flexlink.dynamics.nonlinear import NonlinearSystem
from flexlink.model import Link, PiezoSensor, PointSensor
from flexlink.solvers import Solution
from flexlink.solvers.gauss import hermite_quintic, integrate_gauss
from tests.helpers import CubicMotion, chain_of, paper_links

T0 = 0.37


def _system(modes: int = 3, tip_inertia: float = 0.0,
            gravity: tuple[float, float] = (0.0, 0.0)) -> NonlinearSystem:
    link1, link2 = paper_links(modes=modes, damping=False)
    link1 = Link(**{**link1.__dict__, "tip_inertia": 2e-4}) if tip_inertia else link1
    link2 = Link(**{**link2.__dict__, "tip_mass": 0.02, "tip_inertia": tip_inertia})
    motions = [CubicMotion(0.1, 0.5, 0.3, -0.2), CubicMotion(1.0, -0.4, 0.7, 0.1)]
    return NonlinearSystem(chain_of([link1, link2], motions), gravity=gravity)


def _state(system: NonlinearSystem, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    # decaying with the mode number, as in a real motion (keeps q̈ and the differences moderate)
    scale = np.concatenate([0.05 / (1 + np.arange(arc.dphi.shape[1]))**3 for arc in system.arcs])
    return rng.normal(size=system.n) * scale, rng.normal(size=system.n) * 10 * scale


def test_cumulative_quadrature_is_exact_for_polynomials() -> None:
    quad = ArcQuadrature(0.6, 3, 8)
    s = np.array([0.0, 0.05, 0.2, 0.33, 0.6])
    f = 3 * quad.x**7 - quad.x**2 + 1
    exact = 3 * s**8 / 8 - s**3 / 3 + s
    assert np.allclose(quad.cumulative(s) @ f, exact, rtol=0, atol=1e-14)


@pytest.mark.parametrize("modes", [5, 6, 7])
def test_one_wide_panel_is_as_accurate_as_two_of_twelve_points(modes: int) -> None:
    """Above λ = 12 the default rule's single panel (⌈λ⌉ + 2 points) has fewer nodes than
    two panels of 12 and gives every clamped frequency of the linearised model at least as
    close to its value with 8 panels (a beam with a tip mass)."""
    from scipy.linalg import eigh

    def frequencies(panels: int | None, points: int | None) -> tuple[np.ndarray, int]:
        link = Link("beam", 0.8, 0.6, 12.0, tip_mass=0.2, thickness=0.01, modes=modes)
        system = NonlinearSystem(chain_of([link], [CubicMotion(0.0)]), panels, points)
        M = system.mass_matrix(system.angle0[None, :])[0]
        return np.sqrt(eigh(system.K, M, eigvals_only=True)), system.nodes

    reference, _ = frequencies(8, None)
    default, nodes = frequencies(None, None)
    two, nodes_two = frequencies(2, None)
    assert nodes < nodes_two == 24
    assert np.abs(default / reference - 1).max() <= max(np.abs(two / reference - 1).max(),
                                                        1e-10)


@pytest.mark.parametrize(("tip_inertia", "gravity"),
                         [(0.0, (0.0, 0.0)), (3e-5, (0.0, 0.0)), (3e-5, (3.0, -9.81))])
def test_equations_of_motion_match_the_lagrangian(tip_inertia: float,
                                                  gravity: tuple[float, float]) -> None:
    """d/dt ∂T/∂q̇ − ∂T/∂q (central differences of the kinetic energy) = −K q − ∂V/∂q at q̈ of
    the model, V = −Σ m g·r the weights' potential (from the point positions, not the
    equations' gravity term)."""
    system = _system(tip_inertia=tip_inertia, gravity=gravity)
    q, qd = _state(system)
    qdd = system.accelerations(np.array([T0]), q[None], qd[None])[0]
    n, h, dt = system.n, 1e-6, 1e-5

    def kinetic(t: float, qq: np.ndarray, vv: np.ndarray) -> float:
        return float(system.energy(np.array([t]), qq[None], vv[None])[0][0])

    def gradient(t, qq, vv, wrt_rate: bool) -> np.ndarray:
        out = np.zeros(n)
        for i, e in enumerate(np.eye(n) * h):
            plus = kinetic(t, qq, vv + e) if wrt_rate else kinetic(t, qq + e, vv)
            minus = kinetic(t, qq, vv - e) if wrt_rate else kinetic(t, qq - e, vv)
            out[i] = (plus - minus) / (2 * h)
        return out

    later = gradient(T0 + dt, q + dt * qd + 0.5 * dt**2 * qdd, qd + dt * qdd, True)
    earlier = gradient(T0 - dt, q - dt * qd + 0.5 * dt**2 * qdd, qd - dt * qdd, True)
    inertia = (later - earlier) / (2 * dt) - gradient(T0, q, qd, False)
    weight = np.array([(system.potential(np.array([T0]), (q + e)[None])
                        - system.potential(np.array([T0]), (q - e)[None]))[0] / (2 * h)
                       for e in np.eye(n) * h])
    elastic = system.K @ q + weight
    assert np.abs(inertia + elastic).max() < 1e-4 * np.abs(elastic).max()


def _positions(system: NonlinearSystem, k: int, x: np.ndarray, t: float, q: np.ndarray):
    beta = system.joint_history(np.array([t])).angle
    alpha = system.node_angles(q[None], beta)[0]
    rows = system.position_rows(k, x)
    return np.stack([rows @ np.cos(alpha), rows @ np.sin(alpha)], -1)


def test_joint_torques_and_accelerometer_against_finite_differences() -> None:
    """Motor torques = moment of the outboard inertia forces about the joint, and n·r̈ of a point,
    from positions differentiated in time along q(t) = q + q̇ t + ½ q̈ t²."""
    system = _system(tip_inertia=3e-5)
    q, qd = _state(system, 1)
    qdd = system.accelerations(np.array([T0]), q[None], qd[None])[0]
    dt = 2e-5

    def at(s: float) -> np.ndarray:
        return q + qd * s + 0.5 * qdd * s**2

    link1, link2 = system.chain.links
    x2 = np.concatenate([system.arcs[1].quad.x, [link2.length]])
    m2 = np.concatenate([link2.mass_per_length * system.arcs[1].quad.w, [link2.tip_mass]])
    r = [_positions(system, 1, x2, T0 + s, at(s)) for s in (-dt, 0.0, dt)]
    acc = (r[2] - 2 * r[1] + r[0]) / dt**2
    joint = _positions(system, 0, np.array([link1.length]), T0, q)[0]
    arm = r[1] - joint
    moment = np.sum(m2 * (arm[:, 0] * acc[:, 1] - arm[:, 1] * acc[:, 0]))
    tip_angle = [system.tip_A[1] @ at(s) + system.joint_history(np.array([T0 + s])).angle[0].sum()
                 for s in (-dt, 0.0, dt)]
    moment += link2.tip_inertia * (tip_angle[2] - 2 * tip_angle[1] + tip_angle[0]) / dt**2
    torque = system.joint_torques(np.array([T0]), q[None], qd[None], qdd[None])[0]
    assert torque[1] == pytest.approx(moment, rel=1e-4)

    traj = Solution(np.array([T0]), q[None], qd[None], qdd[None], "test")
    hist = system.joint_history(traj.t)
    sensors = (PointSensor("a", "acceleration", 1, 0.45), PointSensor("w", "deflection", 1, 0.45),
               PointSensor("s", "slope", 1, 0.45), PiezoSensor("p", 1, 0.1, 0.45, 1, 1, 1, 1, 1))
    channels = {name: v[0] for name, v in sensor_values(system, traj, sensors, hist).items()}
    point = [_positions(system, 1, np.array([0.45]), T0 + s, at(s))[0] for s in (-dt, 0.0, dt)]
    angle = system.joint_history(np.array([T0])).angle[0].sum() + system.root_A[1] @ q
    psi = system.modal[1].shapes.evaluate(np.array([0.45]), 1)[0] @ q[system.arcs[1].coords]
    normal = np.array([-np.sin(angle + psi), np.cos(angle + psi)])
    assert channels["a"] == pytest.approx(normal @ (point[2] - 2 * point[1] + point[0]) / dt**2,
                                          rel=1e-4)
    root = _positions(system, 1, np.array([0.0]), T0, q)[0]
    assert channels["w"] == pytest.approx(
        np.array([-np.sin(angle), np.cos(angle)]) @ (point[1] - root), rel=1e-10)
    assert channels["s"] == pytest.approx(psi, rel=1e-12)
    tip = {name: v[0] for name, v in tip_values(system, traj, hist).items()}
    end = _positions(system, 1, np.array([link2.length]), T0, q)[0]
    assert (tip["link2_tip_X"], tip["link2_tip_Y"]) == pytest.approx(tuple(end), rel=1e-12)


def test_energy_is_conserved_with_joints_held_and_no_damping() -> None:
    """Free vibration, link 2 released with a 0.53 rad tip rotation: the energy error falls as
    h⁴ (measured 1.6e-7, 9.7e-9 of the energy at h = 2, 1 ms)."""
    link1, link2 = paper_links(modes=3, damping=False)
    system = NonlinearSystem(chain_of([link1, link2], [CubicMotion(0.3), CubicMotion(1.2)]))
    q0 = np.zeros(system.n)
    q0[0], q0[3], q0[4] = 0.02, 0.08, 0.01
    drift = []
    for h in (2e-3, 1e-3):
        t, q, v = integrate_gauss(system, 0.4, h, q0=q0)
        kinetic, elastic = system.energy(t, q, v)
        energy = kinetic + elastic
        drift.append(np.abs(energy - energy[0]).max() / energy[0])
    assert drift[1] < 1e-6
    assert drift[0] / drift[1] > 8  # fourth order: 16


def test_quintic_hermite_reproduces_a_quintic() -> None:
    t = np.linspace(0.0, 1.0, 5)
    c = np.array([0.3, -1.0, 2.0, 0.5, -0.7, 1.1])

    def p(s, d=0):
        poly = np.polynomial.Polynomial(c).deriv(d)
        return poly(s)[:, None]

    s = np.linspace(0.0, 1.0, 37)
    q, v, a = hermite_quintic(t, p(t), p(t, 1), p(t, 2), s)
    assert np.allclose(q, p(s), atol=1e-13) and np.allclose(v, p(s, 1), atol=1e-12)
    assert np.allclose(a, p(s, 2), atol=1e-11)


@pytest.mark.parametrize("gravity", [(0.0, 0.0), (2.0, -9.81)])
def test_compiled_and_numpy_loops_agree(gravity: tuple[float, float]) -> None:
    """The numba kernels (step loop, batched accelerations) are the numpy algorithm compiled."""
    pytest.importorskip("numba")
    from tests.helpers import SmoothStep

    link1, link2 = paper_links(modes=3, damping=True)
    motions = [SmoothStep(0.0, 1.5, 0.0, 0.6), SmoothStep(1.5, 2.9, 0.0, 0.6)]
    system = NonlinearSystem(chain_of([link1, Link(**{**link2.__dict__, "tip_mass": 0.01,
                                                       "tip_inertia": 1e-6})], motions),
                             gravity=gravity)
    runs = [integrate_gauss(system, 0.8, 4e-3, compiled=c) for c in (True, False)]
    for a, b in zip(runs[0][1:], runs[1][1:]):
        assert np.abs(a - b).max() <= 1e-8 * np.abs(b).max()
    t, q, v = runs[0]
    fast = system.accelerations(t, q, v, compiled=True)
    slow = system.accelerations(t, q, v, compiled=False)
    assert np.abs(fast - slow).max() <= 1e-12 * np.abs(slow).max()


def test_scenario_selects_the_nonlinear_model_and_names_bad_values() -> None:
    from flexlink.scenario import ScenarioError, scenario_from_dict
    from flexlink.simulation import simulate
    from tests.unit.test_scenario import minimal

    d = minimal()
    d["simulation"].update(model="nonlinear", step=0.005)
    d["sensors"].append({"name": "acc", "kind": "acceleration", "link": "a", "x": 1.0})
    scenario = scenario_from_dict(d)
    assert (scenario.settings.model, scenario.settings.step) == ("nonlinear", 0.005)
    results = simulate(scenario)
    assert results.metadata["model"] == "nonlinear"
    assert np.all(np.isfinite(results["acc"])) and np.abs(results["tip"]).max() > 0
    d["simulation"].update(model="nonlinaer", step=0.0)
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    text = "\n".join(info.value.problems)
    assert "simulation.model must be one of 'first_order', 'nonlinear'" in text
    assert "did you mean 'nonlinear'" in text
    assert "simulation.step must be > 0 s, got 0.0" in text
