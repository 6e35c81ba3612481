"""A slider inside a chain that a closure holds, on the nonlinear model: a crank (0.5 m)
carries a slider along its axis; on the block a post (0.3 m) stands at 90° to the line; a
rod (0.4 m) on a free joint at the post's tip is pinned to the ground at (1.0, 0.3) m. The
closure rows carry the travel s as the length of the slider's line node
(`_nonlinear_loops_numba.constraints`). The checks are independent of the first-order
model (which runs the mechanism too: test_first_order_slider_loops.py): the exact
kinematics of the rigid mechanism with a prescribed travel (one equation in the crank
angle), the energy against the drives' work with rigid and with flexible links, the closure
residual and the constraint forces' share on each joint."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

import flexlink
from flexlink.scenario import scenario_from_dict
from flexlink.simulation import output_times
from flexlink.simulation.nonlinear_forward import nonlinear_forward_system, run_nonlinear_forward

CRANK, POST, ROD, PIN = 0.5, 0.3, 0.4, (1.0, 0.3)


def slider_loop_case(drive: str = "force", flexible: bool = False, base: dict | None = None,
                     t_end: float = 0.5, rtol: float = 1e-10) -> dict:
    """The mechanism above, crank torque 0.3 N·m for 0.3 s; the slider ``drive``: "force"
    (±0.5 N bang-bang over 0.4 s), "free" or "prescribed" (cycloidal 0.1 → 0.2 m in 0.4 s);
    ``flexible``: the crank (EI 40 N·m²) and the rod (EI 5 N·m²) bend, 2 modes each,
    undamped."""
    def link(name: str, length: float, mass: float, EI: float) -> dict:
        if not flexible:
            return {"name": name, "length": length, "mass_per_length": mass, "rigid": True}
        return {"name": name, "length": length, "mass_per_length": mass, "EI": EI,
                "modes": 2, "damping_ratio": 0.0}

    slider = {"type": "prismatic", "axis_angle_deg": 0.0, "link_angle_deg": 90.0,
              "mass": 0.4}
    if drive == "force":
        slider.update(drive="force", initial_position=0.1, force=[
            {"profile": "bang_bang", "amplitude": 0.5, "start": 0.0, "duration": 0.4}])
    elif drive == "free":
        slider.update(drive="free", initial_position=0.1)
    else:
        slider.update(drive="prescribed", motion=[
            {"profile": "cycloidal", "from": 0.1, "to": 0.2, "start": 0.0, "duration": 0.4}])
    d = {"simulation": {"t_end": t_end, "dt_out": 0.002, "rtol": rtol, "model": "nonlinear"},
         "links": [link("crank", CRANK, 2.0, 40.0),
                   {"name": "post", "length": POST, "mass_per_length": 1.0, "rigid": True},
                   link("rod", ROD, 0.8, 5.0)],
         "joints": [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.3,
                                                    "start": 0.0, "duration": 0.3}]},
                    slider, {"drive": "free", "initial_angle_deg": -90.0}],
         "closures": [{"name": "pin", "link": "rod", "x": ROD, "ground": list(PIN)}]}
    if base is not None:
        d["base"] = base
    return d


def _crank_angle(s: float, guess: float) -> float:
    """The rigid mechanism's crank angle (rad) for the travel s (m): the post's tip P =
    (CRANK + s) e(β) + POST e⊥(β) lies ROD from the pin."""
    def gap(beta: float) -> float:
        e, n = np.array([np.cos(beta), np.sin(beta)]), np.array([-np.sin(beta), np.cos(beta)])
        return float(np.linalg.norm(np.array(PIN) - (CRANK + s) * e - POST * n) - ROD)

    return brentq(gap, guess - 0.3, guess + 0.3, xtol=1e-15)


def test_a_prescribed_travel_moves_the_rigid_mechanism_on_its_exact_kinematics() -> None:
    """Prescribed travel: no degree of freedom is left; the crank and rod angles are those
    of the loop's closure in closed form (within 1e-10 rad), the residual ≤ 1e-12 of the
    loop, and the pin force at t = 0 balances the crank torque statically (0.3 N·m over the
    post's 0.3 m: 1 N)."""
    run = flexlink.simulate(scenario_from_dict(slider_loop_case("prescribed")), shapes=False)
    s = np.asarray(run["joint2_position"])
    beta = np.asarray(run["joint1_angle"])
    exact = np.array([_crank_angle(x, b) for x, b in zip(s, beta)])
    print(f"crank angle: largest error {np.abs(beta - exact).max():.3g} rad over a range of "
          f"{np.ptp(beta):.3g}")
    assert np.ptp(beta) > 0.1 and np.abs(beta - exact).max() < 1e-10
    # the rod's absolute angle points from the post's tip to the pin
    tip = ((CRANK + s)[:, None] * np.stack([np.cos(beta), np.sin(beta)], -1)
           + POST * np.stack([-np.sin(beta), np.cos(beta)], -1))
    rod = np.arctan2(PIN[1] - tip[:, 1], PIN[0] - tip[:, 0])
    absolute = beta + np.pi / 2 + np.asarray(run["joint3_angle"])
    assert np.abs(np.angle(np.exp(1j * (absolute - rod)))).max() < 1e-10
    assert run.metadata["closure_residual_relative"] <= 1e-12
    assert run["pin_force_x"][0] == pytest.approx(1.0, rel=1e-9)


@pytest.mark.parametrize("flexible", [False, True], ids=["rigid", "flexible"])
def test_energy_equals_the_work_of_the_crank_torque_and_the_slider_force(flexible: bool
                                                                         ) -> None:
    """No damping, no gravity: kinetic (+ strain) energy = τ Δβ₁ + F Δs (piecewise constant
    drives whose switches are output times); the closure forces do no work."""
    scenario = scenario_from_dict(slider_loop_case("force", flexible))
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    run = run_nonlinear_forward(scenario, t, None, False)
    system = nonlinear_forward_system(scenario)
    y, v, _ = system.from_solution(run.solution)
    kinetic, strain = system.energy(t, y, v)
    energy = kinetic + strain
    mid = 0.5 * (t[1:] + t[:-1])
    joints = scenario.chain.joints
    work = np.concatenate([[0.0], np.cumsum(
        joints[0].torque.value(mid) * np.diff(run.values["joint1_angle"])
        + joints[1].drive.torque.value(mid) * np.diff(run.values["joint2_position"]))])
    gap = np.abs(energy - energy[0] - work).max() / energy.max()
    print(f"flexible={flexible}: energy - work {gap:.3g} of {energy.max():.4g} J, strain "
          f"energy up to {strain.max():.3g} J, residual "
          f"{run.metadata['closure_residual_relative']:.3g}")
    assert np.ptp(run.values["joint2_position"]) > 0.01
    assert gap < 1e-7
    assert run.metadata["closure_residual_relative"] <= 1e-8
    if flexible:
        assert strain.max() > 1e-4 * energy.max()



def test_a_loop_with_a_slider_that_cannot_close_is_refused_with_its_residual() -> None:
    """The travel prescribed at 0.1 m and the pin 2 m away, beyond the mechanism's reach
    (1.07 m): refused before the run, naming the closure and its residual."""
    d = slider_loop_case("prescribed")
    d["closures"][0]["ground"] = [2.0, 0.3]
    with pytest.raises(flexlink.errors.SimulationError,
                       match=r"does not close at t = 0.*closures\[0\] \('pin', residual "):
        flexlink.simulate(scenario_from_dict(d), shapes=False)
