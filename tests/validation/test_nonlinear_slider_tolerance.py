"""The default tolerance of a slider on the nonlinear model (`model.settings.default_rtol`,
docs/nonlinear.md §4, "Sliders"): on Case 23 (tests/validation/test_prismatic.py
`slider_fe_case`, 4 modes) the time-integration error of the run at the default rtol — its
difference from the same equations at rtol 1e-9 — is at most a tenth of the model's own error
on every channel compared with the geometrically exact FE model: the hub angle and rate, the
travel and its rate, the beam's tip deflection (max |difference| / peak)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from flexlink import Results, simulate
from flexlink.model.settings import NONLINEAR_SLIDER_RTOL
from tests.validation.test_prismatic import slider_fe_case

# The model's own error of each channel, 4 modes: the run at rtol 1e-10 against Exudyn's
# Simo–Reissner beam with 64 elements and 0.125 ms steps (benchmarks/
# nonlinear_slider_tolerance.py; the slow test below measures it again)
MODEL_ERROR = {"joint1_angle": 2.8e-4, "joint1_rate": 1.6e-2, "joint2_position": 9.9e-5,
               "joint2_velocity": 1.0e-3, "tip": 3.4e-3}
FE_SIGNAL = {"joint1_angle": "angle", "joint1_rate": "rate", "joint2_position": "travel",
             "joint2_velocity": "travel_rate", "tip": "tip_deflection"}


def _run(modes: int, rtol: float | None) -> Results:
    scenario, _ = slider_fe_case(modes)
    return simulate(dataclasses.replace(scenario, settings=dataclasses.replace(
        scenario.settings, model="nonlinear", rtol=rtol)), shapes=False)


def _error(ours: object, reference: object) -> float:
    reference = np.asarray(reference)
    return float(np.abs(np.asarray(ours) - reference).max() / np.abs(reference).max())


def _integration_errors() -> dict[str, float]:
    default = _run(4, None)
    assert default.metadata["rtol"] == NONLINEAR_SLIDER_RTOL
    tight = _run(4, 1e-9)
    return {name: _error(default[name], tight[name]) for name in MODEL_ERROR}


def test_the_default_tolerance_keeps_a_tenth_of_the_sliders_model_error() -> None:
    """Against the measured model error, and against the part of it that more modes remove
    (a lower bound computed here: 6 modes at rtol 1e-9), whichever is larger."""
    errors = _integration_errors()
    tight, more = _run(4, 1e-9), _run(6, 1e-9)
    for name, measured in MODEL_ERROR.items():
        model = max(measured, _error(tight[name], more[name]))
        assert errors[name] <= model / 10, (name, errors[name], model)


@pytest.mark.slow
def test_the_default_tolerance_against_the_fe_models_error() -> None:
    """The same with the model's error measured here against Exudyn (64 elements, steps of
    0.125 ms)."""
    pytest.importorskip("exudyn")
    from .exudyn_slider_reference import simulate_slider_exudyn

    _, args = slider_fe_case(4)
    fe = simulate_slider_exudyn(**args, elements=64, dt=1.25e-4)
    tight = _run(4, 1e-10)
    errors = _integration_errors()
    for name, signal in FE_SIGNAL.items():
        model = _error(tight[name], fe[signal])
        assert errors[name] <= model / 10, (name, errors[name], model)
