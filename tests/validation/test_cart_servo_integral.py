"""A velocity-PID servo with an integral term on a cart's travel (model.Cart,
docs/scenario.md "[base.cart]"): on an inclined rail, the weight's component along it is a
constant load the integral carries, exactly as a joint servo's integral carries a weight's
moment."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexlink import simulate
from flexlink.scenario import scenario_from_dict

G = 9.81
RAIL = 25.0  # deg
MASS = 2.0 + 0.8 * 0.6 + 0.1  # cart, beam, tip mass (kg)
GAIN, RATE_PER_VOLT, P = 60.0, 0.05, 200.0  # N·s/m, (m/s)/V, V/m


def _scenario(model: str, I: float, initial: str = "rest") -> dict:
    """A flexible beam standing on a cart on a 25° rail in gravity; the servo holds the
    travel at 0 for 0.5 s, then moves it by 0.2 m in 1 s."""
    return {
        "simulation": {"name": "cart-integral", "t_end": 6.0, "dt_out": 0.01,
                       "gravity": [0.0, -G], "model": model, "initial": initial},
        "base": {"type": "cart", "mass": 2.0, "cart": {
            "rail_angle_deg": RAIL, "drive": "servo", "servo": "velocity_pid", "P": P,
            "I": I, "D": 0.0, "saturation_V": 10.0, "rate_per_volt": RATE_PER_VOLT,
            "loop_gain": GAIN, "force_limit": 100.0,
            "reference": [{"profile": "cycloidal", "from": 0.0, "to": 0.2, "start": 0.5,
                           "duration": 1.0}]}},
        "links": [{"name": "beam", "length": 0.6, "mass_per_length": 0.8, "EI": 20.0,
                   "tip_mass": 0.1, "damping_ratio": 0.02, "modes": 3}],
        "joints": [{"motion": [{"profile": "hold", "angle_deg": 90.0 + RAIL}]}]}


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_the_integral_removes_the_steady_error_of_a_weight_along_the_rail(model: str) -> None:
    """Without I the cart settles short of its reference by the proportional droop
    e = M g sin α / (K_v r P) (the velocity loop's force K_v r P e balances the weight along
    the rail); with I it reaches the reference."""
    droop = MASS * G * math.sin(math.radians(RAIL)) / (GAIN * RATE_PER_VOLT * P)
    without = simulate(scenario_from_dict(_scenario(model, 0.0)))
    assert without["cart_position"][-1] == pytest.approx(0.2 - droop, rel=1e-6)
    with_i = simulate(scenario_from_dict(_scenario(model, 400.0)))
    assert abs(with_i["cart_position"][-1] - 0.2) < 1e-4 * droop


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_an_equilibrium_start_puts_the_weight_on_the_integral(model: str) -> None:
    """initial = "equilibrium": the cart starts on its reference at rest, the integral
    carrying the weight along the rail, so it does not move before the reference does."""
    r = simulate(scenario_from_dict(_scenario(model, 400.0, "equilibrium")))
    before = r.time < 0.5
    assert np.abs(r["cart_position"][before]).max() < 1e-9
    weight = MASS * G * math.sin(math.radians(RAIL))
    assert r["cart_force"][0] == pytest.approx(weight, rel=1e-6)
