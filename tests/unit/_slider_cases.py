"""Slider set-ups shared by the unit tests of sliders inside a chain (test_prismatic.py,
test_nonlinear_prismatic.py, test_slider_point.py and the kernels' tests)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from flexlink.model import Chain, Link, PositionServo, PrismaticJoint, Step, TorqueDrive
from flexlink.motion import Cycloidal, Travel

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "telescoping_arm.toml"


def telescope(drive: str = "force", modes: int = 2, torques=(0.8, 1.5, -0.1)) -> Chain:
    """A flexible link turned by a torque, a slider at its tip (line at 20°, carried link at
    −15°, a 0.35 kg block) carrying a flexible link with a tip mass, then a third link on a
    revolute joint. ``drive``: the slider's "force" (``torques[1]``, N), "prescribed"
    travel or position "servo"; ``torques`` (N·m, N, N·m): the joints' steps."""
    links = (Link("a", 0.9, 1.4, 40.0, modes=modes, damping_ratio=0.01),
             Link("b", 0.6, 0.8, 25.0, tip_mass=0.2, modes=modes),
             Link("c", 0.4, 0.5, 15.0, modes=min(modes, 1)))
    slider_drive = {"force": TorqueDrive(Step(torques[1], 0.0, 0.7), 0.1, 0.2),
                    "prescribed": Travel(Cycloidal(0.05, 0.4, 0.1, 1.0)),
                    "servo": PositionServo(Travel(Cycloidal(0.05, 0.4, 0.1, 1.0)), 8.0, 0.5,
                                           30.0, 20.0)}[drive]
    joints = (TorqueDrive(Step(torques[0], 0.0, 0.5), 0.2, 0.3),
              PrismaticJoint(slider_drive, np.radians(20.0), np.radians(-15.0), mass=0.35),
              TorqueDrive(Step(torques[2]), 0.1))
    return Chain(links, joints)


def telescoping_arm(**simulation: Any) -> dict:
    """examples/telescoping_arm.toml as a resolved scenario dict, its [simulation] table
    updated with ``simulation`` (e.g. a shorter t_end)."""
    from flexlink.scenario import resolve_scenario_dict

    d = resolve_scenario_dict(EXAMPLE)
    d["simulation"].update(simulation)
    return d
