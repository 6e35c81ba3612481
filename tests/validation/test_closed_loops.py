"""Closed loops (four-bar, slider-crank) on the first-order forward model against the
analytic rigid kinematics, the crank torque from the rate of change of the kinetic energy
(virtual work), the energy of a freely turning mechanism, and the closure residual."""

from __future__ import annotations

import copy
import math
import re

import numpy as np
import pytest

from flexlink import simulate
from flexlink.scenario import scenario_from_dict
from flexlink.scenario.errors import ScenarioError

L1, L2, L3, D = 0.1, 0.3, 0.25, 0.3  # crank, coupler, rocker, ground pivots' distance (m)
MASS = (2.0, 0.3, 2.0)  # kg/m

FOUR_BAR = {
    "simulation": {"name": "four-bar", "t_end": 1.0, "dt_out": 1e-3, "rtol": 1e-8},
    "links": [
        {"name": "crank", "length": L1, "mass_per_length": MASS[0], "rigid": True},
        {"name": "coupler", "length": L2, "mass_per_length": MASS[1], "rigid": True},
        {"name": "rocker", "length": L3, "mass_per_length": MASS[2], "rigid": True},
    ],
    "joints": [
        {"motion": [{"profile": "spinup", "to_rate_deg_s": 720.0, "start": 0.0,
                     "duration": 0.5, "from_deg": 90.0}]},
        {"drive": "free", "initial_angle_deg": -60.0},
        {"drive": "free", "base_point": [D, 0.0], "initial_angle_deg": 100.0},
    ],
    "closures": [{"name": "pin", "link": "coupler", "to_link": "rocker"}],
}

R, ROD = 0.152, 0.304  # the classic slider-crank: crank and connecting rod (m)
SLIDER_CRANK = {
    "simulation": {"name": "slider-crank", "t_end": 0.6, "dt_out": 5e-4, "rtol": 1e-8},
    "links": [
        {"name": "crank", "length": R, "mass_per_length": 1.0, "rigid": True},
        {"name": "rod", "length": ROD, "mass_per_length": 0.2, "rigid": True, "tip_mass": 0.1},
    ],
    "joints": [
        {"motion": [{"profile": "spinup", "to_rate_deg_s": 1000.0, "start": 0.0,
                     "duration": 0.3, "from_deg": 30.0}]},
        {"drive": "free", "initial_angle_deg": -40.0},
    ],
    "closures": [{"name": "piston", "kind": "slider", "link": "rod", "ground": [0.0, 0.0]}],
}


def _bar_energy(m: float, L: float, origin_v: np.ndarray, theta: np.ndarray,
                omega: np.ndarray) -> np.ndarray:
    """Kinetic energy of a uniform rigid bar (mass m, length L) turning at omega about its
    end, which moves at origin_v (nt, 2)."""
    e_perp = np.stack([-np.sin(theta), np.cos(theta)], -1)
    vc = origin_v + 0.5 * L * omega[:, None] * e_perp
    return 0.5 * m * np.sum(vc**2, 1) + 0.5 * m * L**2 / 12 * omega**2


def _four_bar_energy(r) -> np.ndarray:
    b1, b2, b3 = (r[f"joint{k}_angle"] for k in (1, 2, 3))
    w1, w2, w3 = (r[f"joint{k}_rate"] for k in (1, 2, 3))
    zero = np.zeros((b1.size, 2))
    tip = L1 * w1[:, None] * np.stack([-np.sin(b1), np.cos(b1)], -1)
    return (_bar_energy(MASS[0] * L1, L1, zero, b1, w1)
            + _bar_energy(MASS[1] * L2, L2, tip, b1 + b2, w1 + w2)
            + _bar_energy(MASS[2] * L3, L3, zero, b3, w3))


def _rate(f: np.ndarray, t: np.ndarray) -> np.ndarray:
    """df/dt by fourth-order central differences on a uniform grid (NaN at two points
    of each end)."""
    out = np.full(f.shape, np.nan)
    out[2:-2] = (f[:-4] - 8 * f[1:-3] + 8 * f[3:-1] - f[4:]) / (12 * (t[1] - t[0]))
    return out


@pytest.fixture(scope="module")
def four_bar():
    return simulate(scenario_from_dict(FOUR_BAR))


def test_rigid_four_bar_follows_the_analytic_kinematics(four_bar) -> None:
    r = four_bar
    crank = r["joint1_angle"]
    a = L1 * np.stack([np.cos(crank), np.sin(crank)], -1)
    to_a = a - np.array([D, 0.0])
    rho = np.hypot(*to_a.T)
    spread = np.arccos((L3**2 + rho**2 - L2**2) / (2 * L3 * rho))
    rocker = r["joint3_angle"]
    branch = np.sign(np.sin(rocker[0] - np.arctan2(to_a[0, 1], to_a[0, 0])))
    exact = np.arctan2(to_a[:, 1], to_a[:, 0]) + branch * spread
    assert np.abs(np.angle(np.exp(1j * (rocker - exact)))).max() < 1e-9
    b = np.array([D, 0.0]) + L3 * np.stack([np.cos(exact), np.sin(exact)], -1)
    coupler = np.arctan2(*(b - a)[:, ::-1].T)
    theta2 = crank + r["joint2_angle"]
    assert np.abs(np.angle(np.exp(1j * (theta2 - coupler)))).max() < 1e-9


def test_rigid_four_bar_closes_to_round_off(four_bar) -> None:
    r = four_bar
    gap = np.hypot(r["coupler_tip_X"] - r["rocker_tip_X"], r["coupler_tip_Y"] - r["rocker_tip_Y"])
    size = L1 + L2 + L3
    assert gap.max() < 1e-8 * size
    assert r.metadata["closure_residual_relative"] < 1e-8


def test_crank_torque_is_the_rate_of_change_of_kinetic_energy(four_bar) -> None:
    """Virtual work: τ ω = dT/dt for a rigid mechanism without other loads; the free joints'
    torques are zero (the constraint forces are not the motors')."""
    r = four_bar
    t = r.time
    energy = _four_bar_energy(r)
    power = _rate(energy, t)
    w1 = r["joint1_rate"]
    tau = r["joint1_torque"]
    # differences across the spin-up's end (the acceleration jumps) are not derivatives
    moving = (w1 > 0.2 * w1.max()) & (np.abs(t - 0.5) > 2.5e-3) & np.isfinite(power)
    assert np.abs(tau[moving] * w1[moving] - power[moving]).max() < 1e-6 * np.nanmax(np.abs(power))
    for k in (2, 3):
        assert np.abs(r[f"joint{k}_torque"]).max() < 1e-9 * np.abs(tau).max()


def test_free_rigid_four_bar_keeps_its_kinetic_energy() -> None:
    """A crank set turning (a free joint with an initial rate), no loads: the constraint
    forces do no work, the energy stays constant to the integration tolerance."""
    d = copy.deepcopy(FOUR_BAR)
    d["joints"][0] = {"drive": "free", "initial_angle_deg": 90.0, "initial_rate_deg_s": 360.0}
    r = simulate(scenario_from_dict(d))
    energy = _four_bar_energy(r)
    assert np.abs(energy / energy[0] - 1).max() < 1e-6
    assert r["joint1_angle"][-1] - r["joint1_angle"][0] > 2.0  # it turned


def test_rigid_slider_crank_follows_the_analytic_kinematics_and_work() -> None:
    r = simulate(scenario_from_dict(SLIDER_CRANK))
    theta = r["joint1_angle"]
    phi = -np.arcsin(R * np.sin(theta) / ROD)
    assert np.abs(theta + r["joint2_angle"] - phi).max() < 1e-9
    x = R * np.cos(theta) + ROD * np.cos(phi)
    assert np.abs(r["rod_tip_X"] - x).max() < 1e-9 * (R + ROD)
    assert np.abs(r["rod_tip_Y"]).max() < 1e-10 * (R + ROD)
    t = r.time
    w1, w2 = r["joint1_rate"], r["joint2_rate"]
    zero = np.zeros((t.size, 2))
    tip = R * w1[:, None] * np.stack([-np.sin(theta), np.cos(theta)], -1)
    piston_v = -R * np.sin(theta) * w1 - ROD * np.sin(phi) * (w1 + w2)
    energy = (_bar_energy(R, R, zero, theta, w1) + _bar_energy(0.2 * ROD, ROD, tip, phi, w1 + w2)
              + 0.5 * 0.1 * piston_v**2)
    power = _rate(energy, t)
    tau = r["joint1_torque"]
    moving = (w1 > 0.2 * w1.max()) & (np.abs(t - 0.3) > 1.5e-3) & np.isfinite(power)
    assert np.abs(tau[moving] * w1[moving] - power[moving]).max() < 1e-6 * np.nanmax(np.abs(power))
    # the piston's normal force balances the rod: nonzero while it accelerates
    assert np.abs(r["piston_normal_force"]).max() > 0


def test_a_loop_that_cannot_close_is_refused_with_its_residual() -> None:
    d = copy.deepcopy(FOUR_BAR)
    d["joints"][2]["base_point"] = [1.0, 0.0]  # beyond the coupler's and rocker's reach
    with pytest.raises(Exception, match=r"closures\[0\] \('pin', residual [0-9.e-]+ m\)") as info:
        simulate(scenario_from_dict(d))
    # the least gap the free coupler and rocker leave: from the crank pin (0, L1) to the pivot
    gap = float(re.search(r"residual ([0-9.e-]+) m", str(info.value)).group(1))
    assert gap == pytest.approx(math.hypot(1.0, L1) - (L2 + L3), rel=1e-3)


def test_a_closure_on_a_missing_link_is_refused_naming_the_field() -> None:
    d = copy.deepcopy(FOUR_BAR)
    d["closures"][0]["to_link"] = "rocket"
    with pytest.raises(ScenarioError, match=r"closures\[0\]\.to_link: unknown link 'rocket'"):
        scenario_from_dict(d)


def test_more_prescribed_joints_than_the_loop_allows_are_refused() -> None:
    d = copy.deepcopy(FOUR_BAR)
    d["joints"][1] = {"motion": [{"profile": "hold", "angle_deg": -60.0}]}
    with pytest.raises(Exception, match="more prescribed joints than degrees of freedom"):
        simulate(scenario_from_dict(d))


def _four_bar_angles(crank: float) -> tuple[float, float, float]:
    """Absolute angles of crank, coupler and rocker closing the loop (the branch of FOUR_BAR's
    initial guess: the rocker on the side of the spread's minus sign)."""
    a = L1 * np.array([np.cos(crank), np.sin(crank)])
    to_a = a - np.array([D, 0.0])
    rho = np.hypot(*to_a)
    rocker = np.arctan2(to_a[1], to_a[0]) - np.arccos((L3**2 + rho**2 - L2**2) / (2 * L3 * rho))
    b = np.array([D, 0.0]) + L3 * np.array([np.cos(rocker), np.sin(rocker)])
    return crank, float(np.arctan2(*(b - a)[::-1])), float(rocker)


@pytest.mark.parametrize(("crank_deg", "flexible_rocker"), [(90.0, False), (200.0, True)])
def test_linearised_frequencies_match_a_finite_element_eigenanalysis(
        crank_deg: float, flexible_rocker: bool) -> None:
    """The four-bar at rest with its crank free (one mechanism motion: a zero frequency),
    a flexible coupler (and rocker) in their default pinned–pinned bases: the lowest
    frequencies of the constrained first-order equations against frame elements
    (tests/validation/loop_fe.py, converged to < 1e-5 with 80 elements per flexible link)."""
    from flexlink.dynamics.forward import ForwardSystem
    from flexlink.dynamics.loops import LoopSystem, loop_frequencies
    from tests.validation.loop_fe import four_bar_frequencies

    coupler, rocker = (L2, 0.3, 20.0), (L3, MASS[2], 60.0 if flexible_rocker else math.inf)
    d = copy.deepcopy(FOUR_BAR)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": coupler[1],
                     "EI": coupler[2], "modes": 8}
    if flexible_rocker:
        d["links"][2] = {"name": "rocker", "length": L3, "mass_per_length": rocker[1],
                         "EI": rocker[2], "modes": 8}
    d["joints"][0] = {"drive": "free", "initial_angle_deg": crank_deg}
    angles = _four_bar_angles(math.radians(crank_deg))
    d["joints"][1]["initial_angle_deg"] = math.degrees(angles[1] - angles[0])
    d["joints"][2]["initial_angle_deg"] = math.degrees(angles[2])
    scenario = scenario_from_dict(d)
    assert scenario.chain.links[1].mode_shapes == "pinned_pinned"
    loops = LoopSystem(ForwardSystem(scenario.chain, scenario.base, True), scenario.closures)
    model = loop_frequencies(loops)[:5]
    fe = four_bar_frequencies((L1, MASS[0], math.inf), coupler, rocker, (D, 0.0), angles,
                              EA=1e8, elements=80, count=5)
    assert model[0] < 1e-3 and fe[0] < 0.1  # the mechanism's motion
    assert np.abs(model[1:] / fe[1:] - 1).max() < 5e-3


@pytest.mark.parametrize(("stiffening", "bound"), [(False, 1e-3), (True, 2e-2)])
def test_free_flexible_four_bar_conserves_the_exact_energy(stiffening: bool, bound: float
                                                           ) -> None:
    """A turning four-bar with a flexible coupler, no damping, no loads: the energy of the
    exact kinematics (tests/validation/brute_force.py: kinetic energy of every point plus
    the bending energy) on the simulated trajectory stays constant to third order in the
    deflection (measured: 1.5e-4 of the peak bending energy without stiffening, 4e-3 with
    it, as the open chains of test_energy.py); the bounds are those of test_energy.py and
    a tenth of it."""
    from flexlink.dynamics.forward import ForwardSystem
    from flexlink.simulation.forward import run_forward
    from tests.validation.brute_force import exact_energy

    d = copy.deepcopy(FOUR_BAR)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": MASS[1], "EI": 20.0,
                     "modes": 4}
    d["joints"][0] = {"drive": "free", "initial_angle_deg": 90.0, "initial_rate_deg_s": 720.0}
    d["simulation"].update(t_end=0.3, geometric_stiffening=stiffening)
    scenario = scenario_from_dict(d)
    t = np.linspace(0.0, 0.3, 301)
    run = run_forward(scenario, t, lambda _: None, with_shapes=False)
    system = ForwardSystem(scenario.chain, scenario.base, stiffening)
    nu = len(system.free)
    z, zd = run.solution.q[:, nu:], run.solution.q_dot[:, nu:]
    beta = np.stack([run.values[f"joint{k}_angle"] for k in (1, 2, 3)], 1)
    rate = np.stack([run.values[f"joint{k}_rate"] for k in (1, 2, 3)], 1)
    energy, strain = np.empty(t.size), np.empty(t.size)
    for i, ti in enumerate(t):
        def angles(s: float, i: int = i, ti: float = ti) -> np.ndarray:
            return beta[i, :2] + rate[i, :2] * (s - ti)
        energy[i], strain[i] = exact_energy(scenario.chain.links[:2], system.modal[:2], angles,
                                            ti, z[i], zd[i], stiffening)
    energy += 0.5 * MASS[2] * L3**3 / 3 * rate[:, 2] ** 2  # the rigid rocker about its pivot
    assert strain.max() > 1e-4 * energy[0]  # the coupler bends
    assert np.abs(energy - energy[0]).max() < bound * strain.max()


@pytest.mark.parametrize("name", ["four_bar", "slider_crank"])
def test_the_examples_run_closed(name: str) -> None:
    """examples/four_bar.toml and slider_crank.toml (shortened): closed to round-off, the
    flexible member in its pinned–pinned basis, the free joint without torque."""
    from pathlib import Path

    from flexlink.scenario import resolve_scenario_dict

    path = Path(__file__).resolve().parents[2] / "examples" / f"{name}.toml"
    d = resolve_scenario_dict(path)
    d["simulation"]["t_end"] = 0.05
    scenario = scenario_from_dict(d)
    assert "pinned_pinned" in [link.mode_shapes for link in scenario.chain.links]
    r = simulate(scenario)
    assert r.metadata["closure_residual_relative"] < 1e-8
    assert np.abs(r["joint2_torque"]).max() < 1e-8 * np.abs(r["joint1_torque"]).max()


def test_pin_force_turns_the_rocker(four_bar) -> None:
    """The rigid rocker turns about its pivot under the pin's force only: (B − D) × (−λ) =
    (m L²/3) α, λ the pin_force channels (the force on the coupler's tip), α from the
    rocker's rate by differences."""
    r = four_bar
    t = r.time
    rocker = r["joint3_angle"]
    arm = L3 * np.stack([np.cos(rocker), np.sin(rocker)], -1)
    force = -np.stack([r["pin_force_x"], r["pin_force_y"]], -1)
    moment = arm[:, 0] * force[:, 1] - arm[:, 1] * force[:, 0]
    alpha = _rate(r["joint3_rate"], t)
    inertia = MASS[2] * L3**3 / 3
    ok = np.isfinite(alpha) & (np.abs(t - 0.5) > 2.5e-3)
    assert np.abs(moment[ok] - inertia * alpha[ok]).max() < 1e-6 * np.abs(moment).max()


def test_torque_driven_crank_work_is_the_energy_change() -> None:
    """A driven crank (drive = "torque"): its joint stays independent, the coupler and rocker
    follow; the work of the torque equals the kinetic energy gained (rigid bars)."""
    d = copy.deepcopy(FOUR_BAR)
    d["joints"][0] = {"drive": "torque", "initial_angle_deg": 90.0,
                      "torque": [{"profile": "step", "amplitude": 0.05, "start": 0.0}]}
    r = simulate(scenario_from_dict(d))
    assert r.metadata["dependent_joints"] == "joint2 joint3"
    t = r.time
    energy = _four_bar_energy(r)
    power = 0.05 * r["joint1_rate"]
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    assert energy[-1] > 0.1
    assert np.abs(work - (energy - energy[0])).max() < 1e-5 * energy[-1]
    assert np.allclose(r["joint1_torque"], 0.05, rtol=1e-9)


def test_four_bar_released_under_gravity_keeps_its_energy() -> None:
    """Gravity (the base's acceleration −g of the synthesis) acts on the closed mechanism:
    released at rest, the rigid four-bar swings with kinetic + potential energy constant."""
    d = copy.deepcopy(FOUR_BAR)
    d["joints"][0] = {"drive": "free", "initial_angle_deg": 60.0}
    d["joints"][1]["initial_angle_deg"] = -30.0
    d["simulation"].update(gravity=[0.0, -9.81])
    r = simulate(scenario_from_dict(d))
    b1, b2, b3 = (r[f"joint{k}_angle"] for k in (1, 2, 3))
    height = (MASS[0] * L1 * 0.5 * L1 * np.sin(b1)
              + MASS[1] * L2 * (L1 * np.sin(b1) + 0.5 * L2 * np.sin(b1 + b2))
              + MASS[2] * L3 * 0.5 * L3 * np.sin(b3))
    energy = _four_bar_energy(r) + 9.81 * height
    swing = _four_bar_energy(r).max()
    assert swing > 1e-3  # it moves
    assert np.abs(energy - energy[0]).max() < 1e-6 * swing
