"""The results name the integrator that ran: forward runs (a free hub moved by its loads, or
servo-driven joints) run the compiled Radau IIA integrator and say so; a solve_ivp method
asked for is named as such."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import flexlink
from flexlink.solvers.forward import FAST_METHOD

EXAMPLES = Path(__file__).parents[2] / "examples"


def test_the_method_label_is_the_integrator_that_ran() -> None:
    slew = flexlink.load_scenario(EXAMPLES / "satellite_slew.toml")
    short = dataclasses.replace(slew, settings=dataclasses.replace(slew.settings, t_end=1.0))
    assert flexlink.simulate(short, shapes=False).metadata["method"] == FAST_METHOD == "radau5"
    servo = flexlink.load_scenario(EXAMPLES / "paper_servo.toml")
    short = dataclasses.replace(servo, settings=dataclasses.replace(
        servo.settings, t_end=0.2, method="DOP853"))
    assert flexlink.simulate(short, shapes=False).metadata["method"] == "DOP853"
