"""The nonlinear model against independent solutions: the exact elastica of a cantilever under a
large tip load, the first-order stiffened model in the small-motion limit, and convergence with
the number of modes and quadrature points (docs/validation.md, "Nonlinear model")."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, root

from flexlink.dynamics.nonlinear import NonlinearSystem
from flexlink.model import Chain, Link, PointSensor, Scenario, SimulationSettings
from flexlink.motion import Cycloidal
from flexlink.simulation import simulate
from tests.helpers import CubicMotion, SmoothStep, chain_of, paper_links

LENGTH, EI = 0.6, 0.1633  # m, N·m² (the paper's link 2)


def elastica_tip(load: float) -> tuple[float, float]:
    """Exact tip (x, y) / L of a clamped inextensible cantilever under a dead transverse tip load
    P (load = PL²/EI): EI θ″ = −P cos θ, θ(0) = 0, θ′(L) = 0, shot on θ′(0)."""

    def shoot(kappa0: float) -> tuple[float, np.ndarray]:
        sol = solve_ivp(lambda s, y: [y[1], -load * np.cos(y[0]), np.cos(y[0]), np.sin(y[0])],
                        (0.0, 1.0), [0.0, kappa0, 0.0, 0.0], rtol=1e-12, atol=1e-12)
        return sol.y[1, -1], sol.y[:, -1]

    kappa0 = brentq(lambda k: shoot(k)[0], 0.0, load)  # θ′(0) = M(0)/EI ∈ (0, PL²/EI)
    end = shoot(kappa0)[1]
    return float(end[2]), float(end[3])


def static_tip(load: float, modes: int, panels: int | None = None) -> tuple[float, float]:
    """Tip (x, y) / L of the nonlinear model: K q = (∂r_tip/∂q)ᵀ F, solved by Newton."""
    link = Link("beam", LENGTH, 0.0636, EI, modes=modes)
    system = NonlinearSystem(Chain((link,), (CubicMotion(0.0),)), panels=panels)
    beta = np.zeros((1, 1))
    q = np.zeros(system.n)
    def residual(q: np.ndarray, force: np.ndarray) -> np.ndarray:
        jac = system.point_jacobian(0, LENGTH, q[None], beta)[0]
        return system.K @ q - jac.T @ force

    for fraction in np.linspace(0.1, 1.0, 10):  # load continuation
        force = np.array([0.0, fraction * load * EI / LENGTH**2])
        q = root(residual, q, args=(force,), tol=1e-12).x
    assert np.abs(residual(q, force)).max() < 1e-9 * np.abs(system.K @ q).max()
    alpha = system.node_angles(q[None], beta)[0]
    row = system.position_rows(0, np.array([LENGTH]))[0]
    return float(row @ np.cos(alpha)) / LENGTH, float(row @ np.sin(alpha)) / LENGTH


def test_elastica_reference_small_load_limit() -> None:
    """The shooting solution reproduces linear beam theory (y = PL³/3EI) for a small load."""
    assert elastica_tip(1e-4)[1] == pytest.approx(1e-4 / 3, rel=1e-4)


@pytest.mark.parametrize("load", [1.0, 3.0, 10.0])
def test_large_static_deflection_matches_the_exact_elastica(load: float) -> None:
    """PL²/EI = 1, 3, 10: tip deflection 30%, 60%, 81% of L. Eight modes: measured errors
    of (x, y) 1.7e-5, 1.6e-5, 2.5e-6 L (docs/validation.md)."""
    exact = np.array(elastica_tip(load))
    errors = [np.abs(np.array(static_tip(load, m)) - exact).max() for m in (2, 4, 8)]
    assert errors[2] < 5e-5
    assert errors[2] < errors[1] < errors[0]  # converges with the number of modes


def test_quadrature_is_converged_by_default() -> None:
    """Doubling the panels changes the static tip position by less than 1e-9 L."""
    default = np.array(static_tip(3.0, 6))
    finer = np.array(static_tip(3.0, 6, panels=8))
    assert np.abs(default - finer).max() < 1e-9


def _arm(scale: float, model: str) -> dict[str, np.ndarray]:
    links = paper_links(modes=3, damping=True)
    motions = [SmoothStep(0.0, scale * np.radians(90.0), 0.0, 1.0),
               SmoothStep(np.radians(90.0), np.radians(90.0 + scale * 80.0), 0.0, 1.0)]
    sensors = (PointSensor("acc", "acceleration", 0, 1.37),
               PointSensor("w2", "deflection", 1, 0.6), PointSensor("s2", "slope", 1, 0.3))
    r = simulate(Scenario(chain_of(links, motions), sensors,
                          SimulationSettings(1.5, 0.005, geometric_stiffening=True, model=model,
                                             step=2.5e-3 if model == "nonlinear" else None)))
    return {name: r[name] for name in ("acc", "w2", "s2", "joint1_torque", "joint2_torque")}


def test_small_motion_limit_is_the_stiffened_first_order_model() -> None:
    """The swing scaled down by 100 and 1000: the relative difference from the first-order
    stiffened model falls with the amplitude (it is a second-order effect)."""
    differences = []
    for scale in (1e-2, 1e-3):
        ours, first = _arm(scale, "nonlinear"), _arm(scale, "first_order")
        differences.append(max(np.abs(ours[k] - first[k]).max() / np.abs(first[k]).max()
                               for k in ours))
    assert differences[1] < 2e-4
    assert differences[1] < 0.3 * differences[0]


def test_fast_manoeuvre_against_stored_exact_solution() -> None:
    """The 0.5 s swing (link 2's tip deflects 87% of its length, bending past 90°) against the
    stored 64-element Exudyn solution (tests/validation/data/README.md), 8 modes, 2.5 ms steps:
    measured 0.40% (accelerometer), 0.12%, 0.27% (tip deflections), 0.32% (PZT) of peak."""
    data = np.load(Path(__file__).parent / "data" / "exudyn_paper_arm_D0.5.npz")
    motions = [Cycloidal(0.0, 90.0, 0.5, 0.5), Cycloidal(90.0, 170.0, 0.5, 0.5)]
    sensors = (PointSensor("acc", "acceleration", 0, 1.37),
               PointSensor("w1", "deflection", 0, 1.37), PointSensor("w2", "deflection", 1, 0.6),
               PointSensor("s_start", "slope", 1, 0.01), PointSensor("s_end", "slope", 1, 0.04))
    r = simulate(Scenario(chain_of(paper_links(modes=8, damping=False), motions), sensors,
                          SimulationSettings(3.0, 0.002, model="nonlinear", step=0.0025)))
    ours = {"acc": r["acc"], "w1": r["w1"], "w2": r["w2"], "piezo": r["s_end"] - r["s_start"]}
    assert np.allclose(r.time, data["t"])
    assert np.abs(data["w2"]).max() > 0.8 * 0.6
    errors = {k: np.abs(ours[k] - data[k]).max() / np.abs(data[k]).max() for k in ours}
    assert max(errors.values()) < 0.006, errors


def test_work_of_joint_torques_equals_energy_change_in_a_violent_swing() -> None:
    """Undamped, β₁ 0→180° and β₂ −90→90° in 0.4 s (link 2's tip section turns by ~130°
    relative to its root): ∫ τ·β̇ dt = ΔT + ΔV (measured 7.5e-6 of the peak energy, the
    trapezoidal rule's error) — torques, equations and integration in the large."""
    from scipy.integrate import cumulative_trapezoid

    from flexlink.solvers.gauss import solve_nonlinear

    motions = [Cycloidal(0.0, 180.0, 0.2, 0.4), Cycloidal(-90.0, 90.0, 0.2, 0.4)]
    system = NonlinearSystem(chain_of(paper_links(modes=4, damping=False), motions))
    t = np.arange(0.0, 1.0 + 1e-9, 5e-4)
    solution = solve_nonlinear(system, t, 1e-4, step=0.0025)
    q, v, a = solution.q, solution.q_dot, solution.q_ddot
    kinetic, elastic = system.energy(t, q, v)
    energy = kinetic + elastic - kinetic[0] - elastic[0]
    power = (system.joint_torques(t, q, v, a) * system.joint_history(t).rate).sum(axis=1)
    work = cumulative_trapezoid(power, t, initial=0.0)
    tip_rotation = q[:, system.arcs[1].coords] @ system.modal[1].tip_slope
    assert np.abs(tip_rotation).max() > 2.0  # rad: far beyond small rotations
    assert np.abs(energy - work).max() < 1e-4 * np.abs(energy).max()
