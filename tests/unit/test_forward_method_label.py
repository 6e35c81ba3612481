"""The results name the integrator that ran: a forward run whose joints are all prescribed
(the satellite slew: a free hub moved by its loads) runs the Lawson loop and says so."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import flexlink

EXAMPLES = Path(__file__).parents[2] / "examples"


def test_the_method_label_is_the_loop_that_ran() -> None:
    slew = flexlink.load_scenario(EXAMPLES / "satellite_slew.toml")
    short = dataclasses.replace(slew, settings=dataclasses.replace(slew.settings, t_end=1.0))
    assert flexlink.simulate(short, shapes=False).metadata["method"] == "lawson"
    servo = flexlink.load_scenario(EXAMPLES / "paper_servo.toml")
    short = dataclasses.replace(servo, settings=dataclasses.replace(servo.settings, t_end=0.2))
    assert flexlink.simulate(short, shapes=False).metadata["method"] == "rk4"
