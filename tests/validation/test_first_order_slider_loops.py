"""A slider inside a chain that a closure holds, on the first-order model: the mechanism of
test_nonlinear_slider_loops (a crank carrying a slider along its axis, a post on the block, a
rod pinned to the ground), whose closure kinematics carry the travel (`_loops_numba.slide`).
Independent checks: the rigid mechanism with a prescribed travel on its closed-form
kinematics; rigid links against the nonlinear model (both exact there) on fixed, free and
cart bases; the energy of the rigid mechanism against the drives' work; flexible links on a
free base against the nonlinear model, the gap falling faster than the amplitude (the
models' second-order difference); the closure residual through every run."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import flexlink
from flexlink.scenario import scenario_from_dict
from flexlink.simulation import output_times
from flexlink.simulation.forward import forward_system
from flexlink.simulation.nonlinear_forward import nonlinear_forward_system
from tests.unit.test_nonlinear_loops_kernel import MOVING
from tests.validation.test_nonlinear_slider_loops import CRANK, POST, _crank_angle, slider_loop_case

BASES = {"fixed": None, "free": MOVING["free"], "cart": MOVING["cart"]}


def first_order(d: dict) -> dict:
    d = copy.deepcopy(d)
    d["simulation"].update(model="first_order", geometric_stiffening=True)
    return d


def test_a_prescribed_travel_moves_the_rigid_mechanism_on_its_exact_kinematics() -> None:
    """No degree of freedom left: the crank angle is the closure's in closed form (within
    1e-10 rad over 0.2 rad), the residual ≤ 1e-12 of the loop, and the pin's force at t = 0
    balances the crank torque over the post (0.3 N·m / 0.3 m = 1 N)."""
    run = flexlink.simulate(scenario_from_dict(first_order(slider_loop_case("prescribed"))),
                            shapes=False)
    s, beta = np.asarray(run["joint2_position"]), np.asarray(run["joint1_angle"])
    exact = np.array([_crank_angle(x, b) for x, b in zip(s, beta)])
    print(f"crank angle: largest error {np.abs(beta - exact).max():.3g} rad over "
          f"{np.ptp(beta):.3g}")
    assert np.ptp(beta) > 0.1 and np.abs(beta - exact).max() < 1e-10
    assert run.metadata["closure_residual_relative"] <= 1e-12
    assert run["pin_force_x"][0] == pytest.approx(0.3 / POST, rel=1e-9)
    assert CRANK + s.max() < 1.0


@pytest.mark.parametrize("base", list(BASES))
def test_rigid_links_follow_the_nonlinear_model(base: str) -> None:
    """Crank torque and slider force, 0.5 s, rtol 1e-10: base, joints and the pin's force
    within 1e-8 of their ranges of the nonlinear run (measured ≤ 1e-12 on a fixed base)."""
    d = slider_loop_case("force", base=BASES[base])
    first = flexlink.simulate(scenario_from_dict(first_order(d)), shapes=False)
    nonlinear = flexlink.simulate(scenario_from_dict(d), shapes=False)
    names = ["joint1_angle", "joint2_position", "joint3_angle", "pin_force_x", "pin_force_y"]
    names += {"fixed": [], "free": ["base_x", "base_y", "base_attitude"],
              "cart": ["cart_position"]}[base]
    for name in names:
        ours, theirs = np.asarray(first[name]), np.asarray(nonlinear[name])
        gap = np.abs(ours - theirs).max() / np.ptp(ours)
        print(f"{base} {name}: range {np.ptp(ours):.3g}, gap {gap:.2g}")
        assert np.ptp(ours) > 1e-4 and gap < 1e-8, name
    assert first.metadata["closure_residual_relative"] < 1e-8


def test_rigid_energy_equals_the_work_of_the_crank_torque_and_the_slider_force() -> None:
    """Rigid links on a free base, undamped: the kinetic energy of the exact kinematics (the
    nonlinear model's, at the first-order run's states) changes by τ Δβ₁ + F Δs to 1e-8 of
    its peak; the closure forces do no work."""
    d = slider_loop_case("force", base=BASES["free"])
    scenario = scenario_from_dict(first_order(d))
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    run = flexlink.simulate(scenario, shapes=False)
    nu = len(forward_system(scenario).free)
    # the run's closed states (its channels: the free coordinates and their rates)
    q = np.stack([np.asarray(run[name]) for name in
                  ("base_x", "base_y", "base_attitude", "joint1_angle", "joint2_position",
                   "joint3_angle")], 1)
    qd = np.stack([np.asarray(run[name]) for name in
                   ("base_x_rate", "base_y_rate", "base_attitude_rate", "joint1_rate", "joint2_velocity",
                    "joint3_rate")], 1)
    assert q.shape[1] == nu
    system = nonlinear_forward_system(scenario_from_dict(d))
    kinetic, _ = system.energy(t, q, qd)
    mid = 0.5 * (t[1:] + t[:-1])
    joints = scenario.chain.joints
    work = np.concatenate([[0.0], np.cumsum(
        joints[0].torque.value(mid) * np.diff(q[:, 3])
        + joints[1].drive.torque.value(mid) * np.diff(q[:, 4]))])
    gap = np.abs(kinetic - kinetic[0] - work).max() / kinetic.max()
    print(f"energy − work {gap:.3g} of {kinetic.max():.4g} J")
    assert np.ptp(q[:, 4]) > 0.01 and gap < 1e-8


def test_flexible_links_on_a_free_base_approach_the_nonlinear_model() -> None:
    """Crank (EI 40) and rod (EI 5) flexible on a free base, drives at full and at a tenth
    of their size: the first-order run within 2% of each range of the nonlinear run at full
    size (measured 1.2%), 1e-3 at a tenth (measured 5e-4), the gap falling more than
    tenfold: their difference is of second order; residual ≤ 1e-8 of the loop."""
    gaps = []
    for scale in (1.0, 0.1):
        d = slider_loop_case("force", flexible=True, base=BASES["free"])
        d["joints"][0]["torque"][0]["amplitude"] *= scale
        d["joints"][1]["force"][0]["amplitude"] *= scale
        first = flexlink.simulate(scenario_from_dict(first_order(d)), shapes=False)
        nonlinear = flexlink.simulate(scenario_from_dict(d), shapes=False)
        assert first.metadata["closure_residual_relative"] < 1e-8
        gap = max(np.abs(np.asarray(first[n]) - np.asarray(nonlinear[n])).max()
                  / np.ptp(np.asarray(first[n]))
                  for n in ("base_x", "base_attitude", "joint1_angle", "joint2_position",
                            "joint3_angle"))
        gaps.append(gap)
    print(f"gaps {gaps}")
    assert gaps[0] < 0.02 and gaps[1] < 1e-3 and gaps[0] > 10.0 * gaps[1]
