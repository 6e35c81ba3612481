"""Linearised plants (`control.linearize`) of first-order mechanisms with a slider on a moving
base: the open chain of test_first_order_slider_travel on a free base, and the slider loop of
test_nonlinear_slider_loops (closure to the ground) on a free base. Independent check: the
plant at rest, driven by a small step of the hub torque, against the nonlinear model's run
of the same step (`model = "nonlinear"`, another model and integrator): the difference is of
second order in the step (it halves relative to the response when the step halves)."""

from __future__ import annotations

import copy

import numpy as np
import pytest
from scipy.signal import lsim

import flexlink
from flexlink.control.linearization import linearize
from flexlink.scenario import scenario_from_dict
from tests.unit.test_nonlinear_loops_kernel import MOVING
from tests.validation.test_first_order_slider_travel import spinning_slider
from tests.validation.test_nonlinear_slider_loops import slider_loop_case

START = 0.01  # s, the step's start: the plant is linearised at rest before it


def _open_chain(torque: float) -> dict:
    """spinning_slider without the base's moment and the slider's force: a step ``torque``
    on the hub, 0.5 s."""
    d = spinning_slider(False, 0.5, 1e-10)
    d["base"].pop("loads")
    d["joints"][0]["torque"] = [{"profile": "step", "amplitude": torque, "start": START}]
    d["joints"][1]["force"] = [{"profile": "step", "amplitude": 0.0}]
    d["simulation"]["dt_out"] = 0.002
    return d


def _loop(torque: float) -> dict:
    """The slider loop on a free base, flexible crank and rod, a step ``torque`` on the
    crank."""
    d = slider_loop_case("force", flexible=True, base=MOVING["free"])
    d["joints"][0]["torque"] = [{"profile": "step", "amplitude": torque, "start": START}]
    d["joints"][1]["force"] = [{"profile": "step", "amplitude": 0.0}]
    return d


def _loop_on_a_cart(torque: float) -> dict:
    """The slider loop on a force-driven cart (its force held at zero), the crank's step
    ``torque``."""
    d = _loop(torque)
    d["base"] = copy.deepcopy(MOVING["cart"])
    d["base"]["cart"]["force"] = [{"profile": "step", "amplitude": 0.0}]
    return d


CASES = {"open": (_open_chain, ["base_attitude", "joint1_angle", "joint2_position"], 1e-3),
         "loop": (_loop, ["joint1_angle", "joint2_position", "joint3_angle", "pin_force_x"],
                  5e-5),
         "loop_base_pose": (_loop, ["base_x", "base_y", "base_attitude", "base_x_rate",
                                    "base_y_rate", "base_attitude_rate"], 5e-5),
         "loop_cart": (_loop_on_a_cart, ["cart_position", "cart_velocity", "joint1_angle"],
                       5e-5)}


def _gap(case: str, torque: float) -> float:
    """The largest difference between the plant's step response and the nonlinear run,
    relative to each output's range."""
    build, names, _ = CASES[case]
    d = build(torque)
    first = copy.deepcopy(d)
    first["simulation"].update(model="first_order", geometric_stiffening=True)
    plant = linearize(scenario_from_dict(first), 0.0, inputs=["joint1_torque"], outputs=names)
    assert plant.equilibrium
    d["simulation"]["model"] = "nonlinear"
    run = flexlink.simulate(scenario_from_dict(d), shapes=False)
    t = np.asarray(run.time)
    step = np.where(t >= START - 1e-12, torque, 0.0)
    _, response, _ = lsim((plant.A, plant.B, plant.C, plant.D), step, t, interp=False)
    gap = 0.0
    for i, name in enumerate(names):
        ours = np.asarray(run[name]) - np.asarray(run[name])[0]
        assert np.ptp(ours) > 0, name
        gap = max(gap, float(np.abs(response[:, i] - ours).max() / np.ptp(ours)))
    return gap


@pytest.mark.parametrize("case", list(CASES))
def test_the_plant_at_rest_is_the_nonlinear_response_to_a_small_step(case: str) -> None:
    """Steps of 1e-3 and 5e-4 N·m (the loop: 5e-5 and 2.5e-5): the plant within 1e-3 of each
    output's range of the nonlinear run (measured 3.8e-4 open, 4.5e-4 loop), and the gap
    halving with the step (second order). The loop's plant outputs its moving base's pose
    and rates (free base, cart) under the open chain's names."""
    torque = CASES[case][2]
    gaps = [_gap(case, scale * torque) for scale in (1.0, 0.5)]
    print(f"{case}: gaps {gaps}")
    assert gaps[0] < 1e-3 and 1.6 < gaps[0] / gaps[1] < 2.4


def test_frozen_modes_of_the_space_gantry_interlace_with_the_clamped_hub() -> None:
    """examples/space_gantry.toml at rest (t = 0) and along its move: the free hub's i-th
    elastic frequency lies between the i-th and the (i+3)-th of the same mechanism with its
    hub clamped (three constraints added: Rayleigh's interlacing), and a slider's column of
    the configurations is its link angle (90°), not its travel."""
    import dataclasses
    from pathlib import Path

    from flexlink.control.modes import frozen_modes
    from flexlink.model import Base

    example = Path(__file__).resolve().parents[2] / "examples" / "space_gantry.toml"
    free = flexlink.load_scenario(example)
    clamped = dataclasses.replace(free, base=Base())
    at_rest = frozen_modes(free, [0.0])
    f_free = at_rest.frequency_hz[0]
    f_clamped = frozen_modes(clamped, [0.0]).frequency_hz[0]
    n = f_free.size - 3
    assert n >= 2
    print(f"free {f_free}, clamped {f_clamped}")
    assert np.all(f_free[:n] >= f_clamped[:n] * (1 - 1e-9))
    assert np.all(f_free[:n] <= f_clamped[3:3 + n] * (1 + 1e-9))
    moving = frozen_modes(free, [0.0, 2.0, 4.0])
    np.testing.assert_allclose(moving.configurations[:, 1], 90.0)
    np.testing.assert_allclose(moving.configurations[:, 0], [0.0, 30.0, 60.0], atol=1e-9)
    assert np.all(np.abs(np.diff(moving.frequency_hz[:, 0])) > 1e-3)  # the carriage moved
