"""Elastic joints (docs/elastic_joints.md) against independent results: the exact two-inertia
frequency of a rigid link, the exact frequencies of a flexible link whose root is held by the
spring-and-rotor chain (the beam's characteristic equation, solved here), the work of a
bang-bang motor torque against the energy, and the stiff-spring limit of the rigid joint."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from scipy.optimize import brentq

from flexlink.control.linearization import linearize
from flexlink.scenario import scenario_from_dict
from flexlink.simulation import simulate

EI, RHO_A, L, TIP = 12.0, 0.6, 1.0, 0.15  # N·m², kg/m, m, kg
K_SPRING, J_M, GEAR = 60.0, 2e-4, 12.0  # N·m/rad, kg·m², motor turns per link turn


def _scenario(modes: int, stiffness: float = K_SPRING, motor: dict[str, Any] | None = None,
              **simulation: Any) -> dict[str, Any]:
    """One link on an elastic joint whose motor is torque-driven (zero torque unless
    ``motor`` says otherwise), on a fixed hub."""
    joint = {"spring_stiffness": stiffness, "gear_ratio": GEAR, "drive": "torque",
             "torque": [{"profile": "step", "amplitude": 0.0}], "motor_inertia": J_M,
             **(motor or {})}
    return {"simulation": {"t_end": 1.0, "dt_out": 0.01, **simulation},
            "links": [{"name": "beam", "length": L, "mass_per_length": RHO_A, "tip_mass": TIP,
                       **({"EI": EI, "modes": modes} if modes else {"rigid": True})}],
            "joints": [joint]}


def _exact_frequencies(count: int, rigid: bool = False) -> np.ndarray:
    """The first ``count`` nonzero natural frequencies (rad/s) of the beam v(x) = xβ + w
    with v(0) = 0, EI v''(0) = −τ_s, EI v''(L) = ω² J_t v'(L) (J_t = 0 here),
    EI v'''(L) = −ω² m_t v(L), the root torque of the spring k in series with the reflected
    rotor J_r = N² J_m: τ_s = k ω² J_r v'(0) / (k − ω² J_r) (Lagrange's equations of
    ½∫ρA v̇² + ½ J_m θ̇_m² − ½∫EI v''² − ½ k (θ_m/N − v'(0))²). The characteristic
    determinant of V = a cos λx + b sin λx + c cosh λx + d sinh λx, multiplied by
    k − ω² J_r to remove its pole, is bracketed on a fine grid and refined by brentq."""
    Jr = J_M * GEAR**2

    def det(w: float) -> float:
        lam = (RHO_A * w**2 / EI) ** 0.25
        c, s, ch, sh = np.cos(lam * L), np.sin(lam * L), np.cosh(lam * L), np.sinh(lam * L)
        rows = np.array([
            [1.0, 0.0, 1.0, 0.0],
            [-EI * lam**2 * (K_SPRING - w**2 * Jr), K_SPRING * w**2 * Jr * lam,
             EI * lam**2 * (K_SPRING - w**2 * Jr), K_SPRING * w**2 * Jr * lam],
            [-c, -s, ch, sh],  # V''(L) = 0 (no tip inertia), divided by EI λ²
            [EI * lam**3 * s + TIP * w**2 * c, -EI * lam**3 * c + TIP * w**2 * s,
             EI * lam**3 * sh + TIP * w**2 * ch, EI * lam**3 * ch + TIP * w**2 * sh],
        ])
        return float(np.linalg.det(rows))

    grid = np.geomspace(0.5, 3000.0, 40000)
    values = np.array([det(w) for w in grid])
    roots = [brentq(det, a, b, xtol=1e-13, rtol=1e-14)
             for a, b, fa, fb in zip(grid[:-1], grid[1:], values[:-1], values[1:])
             if np.sign(fa) != np.sign(fb)]
    assert len(roots) >= count
    return np.array(roots[:count])


def test_rigid_link_has_the_two_inertia_frequency() -> None:
    """A rigid link (J_l = ρA L³/3 + m_t L²) on the spring to the rotor: one oscillation,
    ω² = k (1/J_l + 1/(N² J_m)), the rest a free rigid rotation."""
    plant = linearize(scenario_from_dict(_scenario(0)), at=0.0)
    J_l = RHO_A * L**3 / 3 + TIP * L**2
    exact = np.sqrt(K_SPRING * (1 / J_l + 1 / (GEAR**2 * J_M)))
    got = 2 * np.pi * plant.modes()[0]
    assert got.size == 1
    np.testing.assert_allclose(got[0], exact, rtol=1e-10)
    for name in ("joint1_motor_angle", "joint1_motor_rate"):
        assert name in plant.state_names and name in plant.output_names
    assert "joint1_spring_torque" in plant.output_names and "joint1_torque" in plant.input_names


def test_flexible_link_frequencies_match_the_exact_characteristic_equation() -> None:
    """A flexible link on the elastic joint, linearised at rest with 10 assumed modes: the
    first three frequencies within 0.5% of the beam's exact ones (and converging: 10 modes
    closer than 4)."""
    exact = _exact_frequencies(3)
    errors = []
    for modes in (4, 10):
        got = 2 * np.pi * linearize(scenario_from_dict(_scenario(modes)), at=0.0).modes()[0][:3]
        errors.append(np.abs(got / exact - 1))
    assert np.all(errors[1] < 1e-5), (errors, exact)  # measured: 3e-7 at most
    assert np.all(errors[1] <= errors[0] + 1e-12)


def test_energy_is_the_work_of_a_bang_bang_motor_torque() -> None:
    """Undamped, nonlinear model: kinetic (link, tip mass, rotor) + spring + strain energy
    equals the work ∫ τ_m dθ_m of a bang-bang motor torque at every output time (τ_m is
    constant between output times: the work is τ_m Δθ_m per piece, no quadrature), to 1e-8
    of the peak energy (measured 1.2e-9), through a slew of 84° that bends the link (tip
    deflection 45% of its length) and winds the spring hard."""
    from flexlink.dynamics.elastic_joints import spring_energy
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
    from flexlink.solvers.gauss_forward import solve_nonlinear_forward

    amplitude, start, duration = 0.4, 0.1, 0.6  # N·m at the motor shaft, s, s
    scenario = scenario_from_dict(_scenario(4, motor={"torque": [
        {"profile": "bang_bang", "amplitude": amplitude, "start": start,
         "duration": duration}]}))
    system = NonlinearForwardSystem(scenario.chain, scenario.base)
    t = np.arange(0.0, 1.0 + 1e-9, 0.01)
    solution = solve_nonlinear_forward(system, t, 1e-4, step=1.25e-3)
    y, v, _ = system.from_solution(solution)
    kinetic, elastic = system.energy(t, y, v)
    energy = kinetic + elastic
    motor = solution.q[:, system.free.index(system.loads.motor_index(0))]
    torque = scenario.chain.joints[0].motor.torque.value(0.5 * (t[1:] + t[:-1]))
    work = np.concatenate([[0.0], np.cumsum(torque * np.diff(motor))])
    assert np.abs(energy - work).max() < 1e-8 * energy.max()
    p, _, _ = system.rigid_state(t, y, v, np.zeros_like(y))
    spring = spring_energy(system.loads, p)
    assert spring.max() > 0.05 * energy.max() and (elastic - spring).max() > 0.01 * energy.max()
    assert np.ptp(solution.q[:, 0]) > 1.0  # a large slew (rad)


def test_a_stiff_spring_gives_the_rigid_torque_driven_joint() -> None:
    """As k grows the elastic joint becomes the rigid joint driven by N τ_m with the
    reflected rotor inertia N² J_m: joint angle and tip deflection converge to that run's
    (first-order model) with an error falling like 1/k."""
    motor = {"torque": [{"profile": "bang_bang", "amplitude": 0.01, "start": 0.1,
                         "duration": 0.6}]}
    rigid_joint = {"drive": "torque", "motor_inertia": GEAR**2 * J_M, "torque": [
        {"profile": "bang_bang", "amplitude": 0.01 * GEAR, "start": 0.1, "duration": 0.6}]}
    reference = _scenario(4, rtol=1e-8)
    reference["joints"] = [rigid_joint]
    rigid = simulate(scenario_from_dict(reference))
    errors = []
    for stiffness in (1e3, 1e4, 1e5):
        elastic = simulate(scenario_from_dict(_scenario(4, stiffness, motor, rtol=1e-8)))
        errors.append([np.abs(np.asarray(elastic[c]) - np.asarray(rigid[c])).max()
                       / np.abs(np.asarray(rigid[c])).max()
                       for c in ("joint1_angle", "beam_tip_Y")])
    errors = np.array(errors)
    assert np.all(errors[-1] < 2e-3), errors
    assert np.all(errors[1:] < errors[:-1] / 5), errors


@pytest.mark.slow
@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_elastic_joint_against_the_geometrically_exact_model(model: str) -> None:
    """The case ``elastic_joint`` of forward_fe_cases.py (the hub–beam's beam on an elastic
    joint, a bang-bang motor torque) against Exudyn's geometrically exact beams (32
    elements; the joint a pinned rotor body coupled to the link's hub by a coordinate
    spring): link angle and rate, motor angle, spring torque and tip deflection within 1% of
    their peaks, first order (stiffened, 6 modes) and nonlinear (4 modes, 2.5 ms steps).
    Measured: tip 0.32% and 0.29%, link and motor angles 0.03% (a 108° slew, tip deflection
    4.4% of L)."""
    pytest.importorskip("exudyn")
    from dataclasses import replace

    from tests.validation.forward_fe_cases import (
        CASES,
        error_of_peak,
        exudyn_signals,
        flexlink_scenario,
        flexlink_signals,
    )

    case = CASES["elastic_joint"]
    reference, _ = exudyn_signals(case, 32, 5e-4)
    scenario = flexlink_scenario(case, modes=6 if model == "first_order" else 4)
    if model == "nonlinear":
        scenario = replace(scenario, settings=replace(scenario.settings, model="nonlinear",
                                                      step=2.5e-3))
    errors = error_of_peak(flexlink_signals(case, simulate(scenario)), reference)
    assert 0.02 < np.abs(reference["tip"]).max() < 0.1
    assert max(errors.values()) < 0.01, errors


@pytest.mark.slow
def test_linearised_frequencies_match_an_fe_eigenvalue_analysis() -> None:
    """The plant linearised at rest (10 modes) against Exudyn's eigenvalues of the same arm
    (64 geometrically exact elements, a thin section so that shear and rotary inertia stay
    small; the rotor a pinned body on a coordinate spring): frequencies 1–3 within 0.5%
    (measured 3·10⁻⁵, 3·10⁻⁴, 1.1·10⁻³: the FE mesh's own O(h²) error, 4× that at 32)."""
    pytest.importorskip("exudyn")
    from flexlink.model import Link
    from tests.validation.exudyn_forward_reference import hub_beam_eigenfrequencies

    link = Link("beam", L, RHO_A, EI, tip_mass=TIP, thickness=0.005)
    fe = hub_beam_eigenfrequencies(link, 0.0, 0.0, 64, 3, rotor=(GEAR**2 * J_M, K_SPRING, 0.0))
    ours = 2 * np.pi * linearize(scenario_from_dict(_scenario(10)), at=0.0).modes()[0][:3]
    np.testing.assert_allclose(ours, fe, rtol=5e-3)
