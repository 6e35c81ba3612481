"""`links[i].initial_modal_rates` (docs/scenario.md): a link that starts vibrating, on both
models, and the refusals that name the field."""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest

from flexlink import simulate
from flexlink.dynamics.first_order import chain_modal_data
from flexlink.scenario import ScenarioError, scenario_from_dict

RATES = [0.01, -0.004, 0.002]  # m/s


def _beam(**link) -> dict:
    """A cantilever (1 m, 2 kg/m, EI = 40 N·m², 3 clamped–free modes) on a joint held at 0
    on a fixed base (a forward run), undamped, 0.2 s."""
    return {"simulation": {"t_end": 0.2, "dt_out": 0.001, "rtol": 1e-9},
            "links": [{"name": "beam", "length": 1.0, "mass_per_length": 2.0, "EI": 40.0,
                       "modes": 3, "initial_modal_rates": list(RATES), **link}],
            "joints": [{"motion": [{"profile": "cycloidal", "from_deg": 0, "to_deg": 0,
                                    "start": 0, "duration": 1}]}],
            "base": {"type": "fixed"},
            "sensors": [{"name": "tip", "kind": "deflection", "link": "beam", "x": 1.0}]}


@pytest.mark.parametrize("model, tol", [("first_order", 1e-8), ("nonlinear", 2e-6)])
def test_a_clamped_beam_rings_in_its_modes_from_the_given_rates(model: str, tol: float) -> None:
    """Each clamped–free mode of the held beam rings on its own: tip(t) = Σ φ_i(L) q̇_i(0)
    sin(ω_i t)/ω_i. First order within 8e-10 of the peak (the integration's tolerance); the
    nonlinear model within 6e-7 (its geometric terms, second order in 2 mm at the tip)."""
    d = _beam()
    d["simulation"]["model"] = model
    scenario = scenario_from_dict(d)
    run = simulate(scenario)
    data = chain_modal_data(scenario.chain, scenario.base)[0]
    omega = 2 * np.pi * data.natural_frequencies_hz
    expected = (data.tip_value * np.asarray(RATES) / omega) @ np.sin(np.outer(omega, run.time))
    assert np.abs(run["tip"] - expected).max() < tol * np.abs(expected).max()


def test_without_the_key_the_run_starts_at_rest() -> None:
    d = _beam()
    del d["links"][0]["initial_modal_rates"]
    assert np.abs(simulate(scenario_from_dict(d))["tip"]).max() == 0.0


@pytest.mark.parametrize("value, message", [
    ([0.01, 0.0], "links[0].initial_modal_rates: 2 values for 3 modes (links[0].modes)"),
    ([0.01, math.nan, 0.0], "links[0].initial_modal_rates[1] = nan is not a finite number"),
    ([0.01, math.inf, 0.0], "links[0].initial_modal_rates[1] = inf is not a finite number"),
    (0.01, "links[0].initial_modal_rates: expected an array of numbers"),
    (["a", 0, 0], "links[0].initial_modal_rates: expected an array of numbers"),
])
def test_bad_rates_are_refused_naming_the_field(value, message: str) -> None:
    d = _beam()
    d["links"][0]["initial_modal_rates"] = value
    with pytest.raises(ScenarioError, match=message.replace("[", r"\[").replace("(", r"\(")
                       .replace(")", r"\)").replace(".", r"\.")):
        scenario_from_dict(d)


def test_refused_on_a_rigid_link_and_on_a_run_of_prescribed_joints() -> None:
    rigid = _beam(rigid=True)
    for key in ("EI", "modes"):
        del rigid["links"][0][key]
    with pytest.raises(ScenarioError, match=r"links\[0\]\.initial_modal_rates: a rigid link"):
        scenario_from_dict(rigid)
    prescribed = copy.deepcopy(_beam())
    del prescribed["base"]
    with pytest.raises(ScenarioError, match=r"links\[0\]\.initial_modal_rates: every joint is "
                                            "prescribed"):
        scenario_from_dict(prescribed)


def test_the_model_refuses_a_wrong_count() -> None:
    """A `Link` built in Python with the wrong count is refused when the run is set up."""
    import dataclasses

    scenario = scenario_from_dict(_beam())
    link = dataclasses.replace(scenario.chain.links[0], initial_modal_rates=(0.1,))
    bad = dataclasses.replace(scenario, chain=dataclasses.replace(scenario.chain,
                                                                  links=(link,)))
    with pytest.raises(ValueError, match=r"links\[0\]\.initial_modal_rates: need 3 finite"):
        simulate(bad)
