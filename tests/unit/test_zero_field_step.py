"""The difference step of a zero-valued angle field (`sensitivities.field_step`): an angle
is stepped on the radian's scale, so that the derivative at zero carries no round-off of
the rates over a step of a few nano-radians."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

import flexlink
from flexlink.simulation.sensitivities import field_step, scenario_file

ROOT = Path(__file__).resolve().parents[2]
LINE_ANGLE = "closures[0].angle_deg"  # the slider-crank's line, along X: zero degrees


def test_an_angle_is_stepped_on_the_radian_scale_other_fields_as_before() -> None:
    radian = 180.0 / math.pi
    assert field_step(0.0, "degree") == field_step(1e-3, "degree") == 1e-5 * radian
    assert field_step(90.0, "degree") == 1e-5 * 90.0
    assert field_step(0.0, "degree s-1") == 1e-5 * radian
    assert field_step(0.0, "m") == 1e-6  # no natural size: as before
    assert field_step(-2.0, "m") == 2e-5


def test_the_derivative_in_a_zero_angle_is_smooth_there() -> None:
    """The slider-crank's line angle, zero, on its first 0.05 s: the derivative at 0 equals
    the mean of those at ±0.01° (the run is smooth in the angle: they differ from it by
    (0.01°)²/2 of the second derivative, ~1e-8 relative). With a step of 1e-6 of the value's
    unit at zero (1.7e-8 rad) and of 1e-5 of it at ±0.01° (1.7e-9 rad), the rates' round-off
    over the steps put 1e-5 … 1e-3 of noise into them."""
    file = scenario_file(flexlink.load_scenario(ROOT / "examples" / "slider_crank.toml"))
    path = file.locate(LINE_ANGLE).path
    derivative, size = {}, {}
    for angle in (-0.01, 0.0, 0.01):
        scenario = file.build({path: angle, ("simulation", "t_end"): 0.05,
                               ("simulation", "rtol"): 1e-10})
        results = flexlink.simulate(scenario, shapes=False, sensitivities=[LINE_ANGLE])
        derivative[angle] = {name: results.sensitivities.sel(channel=name,
                                                             field=LINE_ANGLE).values
                             for name in results.names}
        size = {name: float(np.max(np.abs(results[name]))) for name in results.names}
    largest = max(size.values())
    checked = 0
    for name, at_zero in derivative[0.0].items():
        peak = float(np.max(np.abs(at_zero)))
        if size[name] <= 1e-9 * largest or peak <= 1e-6 * size[name]:
            continue  # zero to round-off (the free joint's torque), or not moved by the angle
        mean = 0.5 * (derivative[-0.01][name] + derivative[0.01][name])
        assert np.max(np.abs(at_zero - mean)) <= 1e-6 * peak, name
        checked += 1
    assert checked >= 5
