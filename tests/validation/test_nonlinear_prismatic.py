"""A slider inside a chain on the geometrically nonlinear model (docs/prismatic_joints.md)
against a geometrically exact FE model (Exudyn) at a large deflection: Case 23's beam on a
block sliding along a rotating rigid link (tests/validation/test_prismatic.py
`slider_fe_case`), made 8× softer and turned by a moment 10/3× larger, so that the beam's tip
deflects by a third of its length."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from flexlink.model import Scenario
from tests.validation.test_prismatic import slider_fe_case

EI, MOMENT = 1.5, 2.0  # N·m², N·m


def large_slider_case(modes: int = 6, model: str = "nonlinear",
                      rtol: float | None = 1e-6) -> tuple[Scenario, dict]:
    """The large-deflection case (the module docstring) on ``model`` at ``rtol`` (None: the
    model's default); the scenario and the Exudyn model's arguments but the element count."""
    scenario, args = slider_fe_case(modes, EI=EI, moment_amplitude=MOMENT)
    settings = dataclasses.replace(scenario.settings, model=model, rtol=rtol)
    return dataclasses.replace(scenario, settings=settings), args


@pytest.mark.slow
def test_large_deflection_slider_against_exudyn() -> None:
    """The nonlinear model (6 modes) against Exudyn's Simo–Reissner beam (32 elements): the
    link's angle, the slider's travel and the beam's tip deflection (a peak of 36% of its
    length) within 1% of their peaks; the stiffened first-order model is off by more than
    the nonlinear model on the deflection (it is outside its validity)."""
    from flexlink import simulate

    from .exudyn_slider_reference import simulate_slider_exudyn

    pytest.importorskip("exudyn")
    scenario, args = large_slider_case()
    exact = simulate_slider_exudyn(**args, elements=32)
    r = simulate(scenario, shapes=False)
    first = simulate(large_slider_case(model="first_order")[0], shapes=False)
    assert np.abs(exact["tip_deflection"]).max() > 0.3 * 0.8
    errors = {}
    for ours, theirs in (("joint1_angle", "angle"), ("joint2_position", "travel"),
                         ("tip", "tip_deflection")):
        reference = exact[theirs]
        errors[ours] = np.abs(np.asarray(r[ours]) - reference).max() / np.abs(reference).max()
        assert errors[ours] < 0.01, (ours, errors[ours])
    first_error = (np.abs(np.asarray(first["tip"]) - exact["tip_deflection"]).max()
                   / np.abs(exact["tip_deflection"]).max())
    assert first_error > errors["tip"]
