"""Sensitivities of the nonlinear model with prescribed joints (Gauss collocation,
simulation/nonlinear_sensitivities.py, solvers/gauss_sensitivity.py): on uniform steps the
tangent is the derivative of the computed run (central differences of runs on the same
steps), on adaptive steps it agrees with converged central differences of tight runs;
fields of different kinds (stiffness, mass, tip mass, damping, length, a motion's angle, a
sensor's gain)."""

from __future__ import annotations

import numpy as np
import pytest

import flexlink
from flexlink.scenario import paper_experiment_path, resolve_scenario_dict
from flexlink.scenario.load import scenario_from_dict
from flexlink.simulation.sensitivities import scenario_file

FIELDS = ["links[0].EI", "links[1].mass_per_length", "links[0].tip_mass",
          "links[1].damping_ratio", "links[1].length", "joints[1].motion[0].to_deg",
          "sensors[pzt].capacitance"]


def _paper(**simulation: object):
    """The paper arm on the nonlinear model, its move started at once (0.4 s)."""
    d = resolve_scenario_dict(paper_experiment_path())
    d.pop("flexlink_version", None)
    d["simulation"].update({"t_end": 0.5, "model": "nonlinear", **simulation})
    for joint in d["joints"]:
        joint["motion"][0].update(start=0.0, duration=0.4)
    d["sensors"][1]["x"] = 0.5  # off link 2's tip: its length moves both ways
    return scenario_file(scenario_from_dict(d))


def _differences(file, text: str, rels: tuple[float, ...], **settings: object
                 ) -> list[dict[str, np.ndarray]]:
    """Central differences of runs with the field moved by rel · |value| for each rel."""
    target = file.locate(text)
    value = float(target.value)
    moved = {("simulation", key): v for key, v in settings.items()}
    out = []
    for rel in rels:
        h = rel * abs(value)
        runs = [flexlink.simulate(file.build({target.path: value + s * h, **moved}),
                                  shapes=False) for s in (1, -1)]
        out.append({name: (runs[0][name] - runs[1][name]) / (2 * h) for name in runs[0].names})
    return out


def _worst(results, field: str, reference: dict[str, np.ndarray]) -> float:
    """The largest difference over channels, relative to each channel's peak derivative."""
    worst = 0.0
    for channel, ref in reference.items():
        s = results.sensitivity(channel, field).values
        peak = max(np.abs(ref).max(), np.abs(s).max())
        if peak > 0.0:
            worst = max(worst, float(np.abs(s - ref).max() / peak))
    return worst


def test_uniform_steps_give_the_derivative_of_the_computed_run() -> None:
    """On uniform steps (simulation.step) the moved runs share the run's discretisation:
    their differences approach the derivative of what was computed as δ² (measured down to
    δ = 1e-4 of the value); Richardson's extrapolation of δ = 2e-4, 1e-4 within 1e-6 of
    each channel's peak derivative."""
    file = _paper(step=2e-3)
    results = flexlink.simulate(file.build(), shapes=False, sensitivities=FIELDS)
    for field in FIELDS:
        coarse, fine = _differences(file, field, (2e-4, 1e-4), step=2e-3)
        reference = {name: (4 * fine[name] - coarse[name]) / 3 for name in fine}
        assert _worst(results, field, reference) < 1e-6, field


@pytest.mark.parametrize("field", ["links[0].EI", "links[1].damping_ratio",
                                   "joints[1].motion[0].to_deg"])
def test_adaptive_run_matches_converged_differences(field: str) -> None:
    """At rtol 1e-10 against Richardson-extrapolated differences of runs at rtol 1e-12
    (measured: within 1e-6 of each channel's peak derivative)."""
    file = _paper()
    results = flexlink.simulate(file.build({("simulation", "rtol"): 1e-10}), shapes=False,
                                sensitivities=[field])
    coarse, fine = _differences(file, field, (2e-3, 1e-3), rtol=1e-12)
    reference = {name: (4 * fine[name] - coarse[name]) / 3 for name in fine}
    assert _worst(results, field, reference) < 1e-5
