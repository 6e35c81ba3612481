"""Sensitivities of the nonlinear model with prescribed joints (Gauss collocation,
simulation/nonlinear_sensitivities.py, solvers/gauss_sensitivity.py): on uniform steps the
tangent is the derivative of the computed run (central differences of runs on the same
steps), on adaptive steps it agrees with converged central differences of tight runs;
fields of different kinds (stiffness, mass, tip mass, damping, length, a motion's angle, a
sensor's gain)."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

import flexlink
from flexlink.scenario import paper_experiment_path, resolve_scenario_dict
from flexlink.scenario.load import scenario_from_dict
from flexlink.simulation.sensitivities import scenario_file
from tests.unit.test_forward_sensitivities import FREE_BASE, HUB_BEAM

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


def _value(file, text: str) -> float:
    return float(file.locate(text).value)


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


SECOND = ("acceleration", "torque")  # channels of q̈ (the interpolant's second derivative)


def _worst(results, field: str, reference: dict[str, np.ndarray], value: float,
           second: bool | None = None) -> float:
    """The largest difference over channels (``second``: only those of accelerations and
    torques, or only the others), relative to each channel's peak derivative, at least
    1e-4 of the channel's size over the field's (for those of accelerations and torques:
    the size over the field's). A channel that is zero to round-off must have a derivative
    of round-off size (1e-8 of the largest channel per unit of the field: a conserved
    momentum is kept to Newton's tolerance); one whose derivative vanishes (a momentum
    that the field does not change) within 1e-5 of its size over the field's."""
    largest = max(np.abs(results[name]).max() for name in results.names)
    worst = 0.0
    for channel, ref in reference.items():
        is_second = any(word in channel for word in SECOND)
        if second is not None and second != is_second:
            continue
        s = results.sensitivity(channel, field).values
        size = np.abs(results[channel]).max()
        if size <= 1e-9 * largest:
            assert np.abs(s).max() * abs(value) <= 1e-8 * largest, (field, channel)
            continue
        scale = size / abs(value)
        if np.abs(ref).max() <= 1e-6 * scale:
            assert np.abs(s).max() <= 1e-5 * scale, (field, channel)
            continue
        peak = max(np.abs(ref).max(), np.abs(s).max(), (1.0 if is_second else 1e-4) * scale)
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
        assert _worst(results, field, reference, _value(file, field)) < 1e-6, field


@pytest.mark.parametrize("field", ["links[0].EI", "links[0].tip_mass",
                                   "joints[1].motion[0].to_deg"])
def test_adaptive_run_matches_converged_differences(field: str) -> None:
    """At rtol 1e-10 against Richardson-extrapolated differences of runs at rtol 1e-12:
    positions, strains and tips within 1e-6 of each channel's peak derivative (measured
    for the tip mass: 4e-10 … 2.1e-7). Accelerations and joint torques read q̈, the
    interpolant's second derivative, whose derivative converges more slowly with the run's
    tolerance (the tangent moves by 2e-5 between rtol 1e-10 and 1e-11, the differences'
    Richardson estimates disagree by 1e-5): within 5e-5."""
    file = _paper()
    results = flexlink.simulate(file.build({("simulation", "rtol"): 1e-10}), shapes=False,
                                sensitivities=[field])
    coarse, fine = _differences(file, field, (2e-3, 1e-3), rtol=1e-12)
    reference = {name: (4 * fine[name] - coarse[name]) / 3 for name in fine}
    assert _worst(results, field, reference, _value(file, field), second=False) < 1e-6
    assert _worst(results, field, reference, _value(file, field), second=True) < 5e-5


def test_controllers_on_the_nonlinear_model_are_refused_before_anything_runs() -> None:
    from pathlib import Path

    from flexlink.scenario.fields import ScenarioFile
    from flexlink.simulation.sensitivities import SensitivityError

    file = scenario_file(flexlink.load_scenario(
        Path(__file__).parents[2] / "examples" / "active_damping.toml"))
    raw = dict(file.raw)
    raw["simulation"] = {**raw["simulation"], "model": "nonlinear"}
    with pytest.raises(SensitivityError, match="controllers on the nonlinear model"):
        flexlink.simulate(ScenarioFile(raw).build(), sensitivities=["links[0].EI"])


def _driven(text: str, **simulation: object):
    d = tomllib.loads(text)
    d["simulation"].update({"model": "nonlinear", **simulation})
    return scenario_file(scenario_from_dict(d))


DRIVEN = ["links[0].EI", "joints[0].torque[0].amplitude", "joints[0].motor_inertia",
          "sensors[0].x", "links[0].damping_ratio", "links[0].tip_mass"]


def test_driven_uniform_steps_give_the_derivative_of_the_computed_run() -> None:
    """The torque-driven hub–beam on the nonlinear model, uniform steps (measured: 1e-11 …
    2e-8 of each channel's peak derivative)."""
    file = _driven(HUB_BEAM, step=2e-3)
    results = flexlink.simulate(file.build(), shapes=False, sensitivities=DRIVEN)
    for field in DRIVEN:
        coarse, fine = _differences(file, field, (2e-4, 1e-4), step=2e-3)
        reference = {name: (4 * fine[name] - coarse[name]) / 3 for name in fine}
        assert _worst(results, field, reference, _value(file, field)) < 1e-6, field


@pytest.mark.parametrize("text, fields", [
    (HUB_BEAM, ["links[0].EI", "joints[0].motor_inertia", "links[0].damping_ratio"]),
    (FREE_BASE, ["base.inertia", "base.rate_deg_s", "links[0].mass_per_length"]),
])
def test_driven_adaptive_runs_match_converged_differences(text: str, fields: list[str]
                                                          ) -> None:
    """Adaptive runs at rtol 1e-10 against Richardson differences of runs at rtol 1e-12
    (measured: 1.5e-8 … 2.7e-7 of each channel's peak derivative on positions, rates and
    tips; on the free base's joint torque 1.3e-5 of the torque's size per unit relative
    change of the field)."""
    file = _driven(text, rtol=1e-10)
    results = flexlink.simulate(file.build(), shapes=False, sensitivities=fields)
    for field in fields:
        coarse, fine = _differences(file, field, (1e-3, 5e-4), rtol=1e-12)
        # the torque-driven joint's torque is its drive's; once the drive stops it is the
        # equations' round-off (1e-11 … 5e-9 N·m), whose derivative is round-off over δ
        reference = {name: (4 * fine[name] - coarse[name]) / 3 for name in fine
                     if not (text == HUB_BEAM and name == "joint1_torque")}
        value = _value(file, field)
        assert _worst(results, field, reference, value, second=False) < 2e-6, field
        assert _worst(results, field, reference, value, second=True) < 5e-5, field


def test_a_field_that_moves_an_input_breakpoint_is_refused() -> None:
    from flexlink.simulation.sensitivities import SensitivityError

    file = _driven(HUB_BEAM)
    with pytest.raises(SensitivityError, match="duration"):
        flexlink.simulate(file.build(), sensitivities=["joints[0].torque[0].duration"])


def test_analytic_stage_jacobians_match_differences_of_the_residual() -> None:
    """The prescribed model's R_Q, R_V, R_X (solvers.gauss_sensitivity.prescribed_jacobians)
    against central differences of the compiled residual at the replayed stages of the
    paper run, with gravity and a motion under way (measured: 1e-10 of each matrix's
    largest entry)."""
    from flexlink.simulation.nonlinear_sensitivities import _Prescribed
    from flexlink.solvers.gauss_sensitivity import (
        difference_jacobians,
        prescribed_jacobians,
        replay,
    )

    scenario = _paper(gravity=[0.0, -9.81]).build()
    system = _Prescribed.system(scenario)
    nodes: list = []
    _Prescribed.run(scenario, np.linspace(0.0, 0.5, 6), None, False, nodes)
    steps = replay(system.kernel_data(), lambda t: _Prescribed.stage_inputs(system, t),
                   *nodes[0], _Prescribed.newton(system))
    assert steps.mismatch < 1e-8
    Q, V = steps.stages()
    pick = np.arange(0, steps.h.size, max(1, steps.h.size // 20))
    index = 2 * pick + 1
    stage = Q[pick, 1], V[pick, 1], steps.X[pick, 1]
    analytic = prescribed_jacobians(system.kernel_data(), steps.rows)(index, *stage)
    differences = difference_jacobians(system.kernel_data(), steps.rows)(index, *stage)
    for a, d in zip(analytic, differences, strict=True):
        assert np.abs(a - d).max() <= 1e-8 * np.abs(d).max()
