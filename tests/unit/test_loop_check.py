"""Closed loops that saturate or go unstable say so (control/loop_check.py)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

import flexlink
from flexlink.control.loop_check import closed_loop_radius, phases

EXAMPLE = Path(__file__).parents[2] / "examples" / "active_damping.toml"


def _with_gain(scenario: flexlink.model.Scenario, gain: float, t_end: float | None = None
               ) -> flexlink.model.Scenario:
    controllers = tuple(dataclasses.replace(c, gain=gain) for c in scenario.controllers)
    settings = scenario.settings if t_end is None else dataclasses.replace(
        scenario.settings, t_end=t_end)
    return dataclasses.replace(scenario, controllers=controllers, settings=settings)


def test_the_ppf_loop_goes_unstable_where_its_static_loop_gain_passes_one() -> None:
    """PPF's stability limit is a static loop gain g·G(0) = 1 (G(0) = −C A⁻¹ B, actuator
    volts to sensor volts about the final configuration): the sampled closed loop's
    eigenvalues cross the unit circle there."""
    scenario = flexlink.load_scenario(EXAMPLE)
    plant = flexlink.linearize(scenario, at=[90, 170], inputs=["pzt_actuator_voltage"],
                               outputs=["pzt"])
    limit = 1.0 / float(-(plant.C @ np.linalg.solve(plant.A, plant.B))[0, 0])
    assert closed_loop_radius(_with_gain(scenario, 0.95 * limit))[0] < 1.0
    assert closed_loop_radius(_with_gain(scenario, 1.05 * limit))[0] > 1.0
    assert 1029.0 / limit == pytest.approx(0.72, abs=0.005)  # the example's comment


def test_tripling_the_example_gain_warns_of_saturation_and_instability() -> None:
    scenario = flexlink.load_scenario(EXAMPLE)
    tripled = flexlink.simulate(_with_gain(scenario, 3 * 1029.0, t_end=15.0), shapes=False)
    warning = tripled.metadata["control_warning"]
    assert "actuator pzt_actuator sat at its ±200 V limit" in warning
    assert "from 1.5 to 15 s" in warning  # the rest after the manoeuvre, not only during it
    assert "unstable about the final configuration" in warning
    late = tripled.time > 14.0
    assert np.abs(tripled["link2_tip_deflection"][late]).max() > 5e-3  # it grows
    nominal = flexlink.simulate(scenario, shapes=False)
    assert "unstable" not in nominal.metadata.get("control_warning", "")
    assert "from 1.5 to 5 s" not in nominal.metadata.get("control_warning", "")


def test_phases_are_cut_at_the_motion_breakpoints() -> None:
    scenario = flexlink.load_scenario(EXAMPLE)
    assert phases(scenario, 5.0) == [(0.0, 0.5), (0.5, 1.5), (1.5, 5.0)]
