"""Sampled controllers outside the first-order prescribed path (docs/closed_loop.md): PPF on
the nonlinear model at small amplitude damps the first mode as the first-order closed loop
does; an over-gained loop is reported unstable, not NaN."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.errors import SimulationError
from flexlink.scenario import scenario_from_dict
from flexlink.simulation import model_path, simulate
from tests.validation.test_ppf import beam, first_mode, ppf


def decay_rate(results, t_from: float = 0.3) -> float:
    """ζω of the free decay of the sensor signal: slope of log of its successive peaks."""
    t = np.asarray(results.time)
    y = np.asarray(results["pzt"])
    keep = t > t_from
    t, y = t[keep], y[keep]
    peaks = np.flatnonzero((y[1:-1] > y[:-2]) & (y[1:-1] >= y[2:])) + 1
    slope = np.polyfit(t[peaks], np.log(y[peaks]), 1)[0]
    return -slope


def test_ppf_on_the_nonlinear_model_matches_first_order() -> None:
    """2 modes, PPF tuned on mode 1: the decay rate of the collocated sensor agrees within 2%
    (the pulse deflects the tip by ~1 mm: the geometric terms are negligible)."""
    d = beam(2, [], t_end=1.5)
    m, _, k, b, s = first_mode(scenario_from_dict(d))
    f1 = np.sqrt(k / m) / (2 * np.pi)
    d["controllers"] = [ppf(f1, 0.3 * k / (b * s))]  # static loop gain 0.3
    d["simulation"]["rtol"] = 1e-6
    rates = {}
    for model in ("first_order", "nonlinear"):
        d["simulation"]["model"] = model
        sc = scenario_from_dict(d)
        assert model_path(sc) == ("closed_loop" if model == "first_order" else "nonlinear")
        results = simulate(sc, shapes=False)
        rates[model] = decay_rate(results)
        assert np.abs(np.asarray(results["ppf_command"])).max() > 0.0
    open_loop = np.sqrt(k / m) * 0.005
    print(f"decay rates {rates}, open loop {open_loop:.4g} 1/s")
    assert rates["first_order"] > 2 * open_loop  # the loop damps
    assert abs(rates["nonlinear"] / rates["first_order"] - 1) < 0.02


def test_unstable_loop_on_the_nonlinear_model_is_reported() -> None:
    d = beam(2, [], t_end=1.5)
    m, _, k, b, s = first_mode(scenario_from_dict(d))
    f1 = np.sqrt(k / m) / (2 * np.pi)
    d["controllers"] = [ppf(f1, 3.0 * k / (b * s))]  # PPF is unstable above g·b·s = k
    d["simulation"]["model"] = "nonlinear"
    with pytest.raises(SimulationError, match="closed loop unstable"):
        simulate(scenario_from_dict(d), shapes=False)
