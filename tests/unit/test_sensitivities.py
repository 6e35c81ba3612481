"""Sensitivities of a run's channels (simulate(..., sensitivities=...)) and the Objective.

Checked against central differences of runs: on the run's own discretisation (the map the
sensitivities differentiate, `solvers.lawson.integrate_lawson_on`) for ten fields of
different kinds, and of adaptive tight-tolerance runs (the continuous derivative)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import flexlink
from flexlink.scenario.fields import ScenarioFile
from flexlink.simulation.common import output_times
from flexlink.simulation.prescribed import run_prescribed
from flexlink.simulation.sensitivities import SensitivityError, scenario_file
from flexlink.solvers.lawson import integrate_lawson_discretised, integrate_lawson_on

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

# ten fields of different kinds: bending stiffness (as EI and as a thickness), mass per
# length, tip mass, damping ratios, sensor gains, joint angles (one of them zero)
FIELDS = ["links[0].EI", "links[1].mass_per_length", "links[0].tip_mass",
          "links[1].damping_ratio", "links[0].damping_ratio", "sensors[pzt].capacitance",
          "sensors[pzt].d31", "joints[1].motion[0].to_deg", "joints[0].motion[0].from_deg",
          "links[1].thickness"]


def _paper(t_end: float = 2.0, **settings: float) -> ScenarioFile:
    """The paper experiment, shortened (fewer vibration periods to difference across)."""
    file = scenario_file(flexlink.load_paper_experiment())
    raw = dict(file.raw)
    raw["simulation"] = {**raw["simulation"], "t_end": t_end, **settings}
    return ScenarioFile(raw, file.base_dir, file.name, file.source)


def _worst(results: flexlink.Results, field: str, fd: dict[str, np.ndarray]) -> float:
    """The largest error of the field's sensitivities over the channels, each relative to
    that channel's largest derivative (channels the field does not move: to 1e-12)."""
    worst = 0.0
    for name, d in fd.items():
        got = results.sensitivity(name, field).values
        scale = np.abs(d).max()
        if scale == 0.0:
            assert np.abs(got).max() <= 1e-12, (field, name)
            continue
        worst = max(worst, float(np.abs(got - d).max() / scale))
    return worst


def _frozen_differences(file: ScenarioFile, field: str) -> dict[str, np.ndarray]:
    """Every channel's derivative in ``field`` by fourth-order central differences of runs
    on the discretisation of the run at the file's own values (converged: the step of
    1e-4 × the value agrees with 3e-5 × to ~1e-8)."""
    scenario = file.build()
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    settled = []

    def adaptive(system, times, rtol, atol, progress):
        solution, disc = integrate_lawson_discretised(system, times, rtol, atol, progress)
        settled.append(disc)
        return solution

    run_prescribed(scenario, t, lambda _: None, False, adaptive)

    def on(system, times, rtol, atol, progress):
        return integrate_lawson_on(system, times, settled[0])

    target = file.locate(field)
    value = float(target.value)
    h = 1e-4 * abs(value) if value else 1e-4
    runs = {j: run_prescribed(file.build({target.path: value + j * h}), t, lambda _: None,
                              False, on).values for j in (-2, -1, 1, 2)}
    return {name: (8 * (runs[1][name] - runs[-1][name]) - (runs[2][name] - runs[-2][name]))
            / (12 * h) for name in runs[1]}


def test_sensitivities_are_the_derivative_of_the_computed_run() -> None:
    file = _paper()
    scenario = file.build()
    results = flexlink.simulate(scenario, sensitivities=FIELDS)
    assert results.sensitivities.dims == ("time", "channel", "field")
    assert list(results.sensitivities.coords["field"].values) == FIELDS
    plain = flexlink.simulate(scenario)
    for name in plain.names:  # the run itself is unchanged
        np.testing.assert_array_equal(results[name], plain[name])
    for field in FIELDS:
        assert _worst(results, field, _frozen_differences(file, field)) < 1e-6, field


def test_a_run_starting_in_equilibrium_under_gravity() -> None:
    """The start z₀(p) moves with the fields too (its derivative is added to ∂z/∂p)."""
    file = _paper(t_end=1.0, initial="equilibrium", gravity=[0.0, -9.81])
    fields = ["links[0].EI", "links[0].tip_mass", "simulation.gravity[1]"]
    results = flexlink.simulate(file.build(), sensitivities=fields)
    for field in fields:
        assert _worst(results, field, _frozen_differences(file, field)) < 1e-6, field


def test_a_run_whose_joints_never_move() -> None:
    """Regression: a table with static blocks only (the joints at rest for the whole run)
    could not be tabulated for the derivatives (an empty array reshaped with -1)."""
    file = _paper(t_end=0.02, initial="equilibrium", gravity=[0.0, -9.81])
    fields = ["links[0].EI", "links[0].tip_mass"]
    results = flexlink.simulate(file.build(), sensitivities=fields)
    for field in fields:
        fd = _frozen_differences(file, field)
        moved = 0
        for name, d in fd.items():
            got = results.sensitivity(name, field).values
            scale = np.abs(d).max()
            if scale < 1e-8:  # at rest: accelerations are round-off / step on both sides
                assert np.abs(got).max() < 1e-8, (field, name)
                continue
            moved += 1
            assert np.abs(got - d).max() < 1e-6 * scale, (field, name)
        assert moved >= 5, field  # the start z₀(p) moves deflections, strains, the sensor


def test_sensitivities_approach_the_continuous_derivative_at_tight_tolerance() -> None:
    file = _paper(t_end=1.6, rtol=1e-9)
    fields = ["links[0].EI", "joints[1].motion[0].to_deg"]
    results = flexlink.simulate(file.build(), sensitivities=fields)
    for field in fields:
        target = file.locate(field)
        value = float(target.value)
        h = 1e-3 * abs(value)
        runs = {j: flexlink.simulate(file.build({target.path: value + j * h}), shapes=False)
                for j in (-2, -1, 1, 2)}
        fd = {name: (8 * (runs[1][name] - runs[-1][name]) - (runs[2][name] - runs[-2][name]))
              / (12 * h) for name in runs[1].names}
        assert _worst(results, field, fd) < 1e-6, field


def test_units_are_the_channel_unit_over_the_field_unit() -> None:
    results = flexlink.simulate(_paper(t_end=0.6).build(),
                                sensitivities=["links[0].EI", "joints[1].motion[0].to_deg",
                                               "links[1].damping_ratio"])
    assert results.sensitivity("link2_tip_deflection", "links[0].EI").attrs["units"] \
        == "m-1 N-1"
    assert results.sensitivity("link1_tip_acceleration", "joints[1].motion[0].to_deg"
                               ).attrs["units"] == "m s-2 degree-1"
    assert results.sensitivity("pzt", "links[1].damping_ratio").attrs["units"] == "V"
    with pytest.raises(KeyError, match="link9"):
        results.sensitivity("link9", "links[0].EI")


@pytest.mark.parametrize(("field", "message"), [
    (None, "at least one field"),
    ("links[5].EI", "links"),
    ("links[0].name", "links\\[0\\].name"),
    ("links[0].modes", "links\\[0\\].modes"),
    ("joints[0].motion[0].duration", "joints\\[0\\].motion\\[0\\].duration"),
    ("simulation.dt_out", "simulation.dt_out"),
    ("simulation.rtol", "simulation.rtol"),
])
def test_bad_fields_are_refused_before_anything_runs(field: str | None, message: str,
                                                     monkeypatch: pytest.MonkeyPatch) -> None:
    from flexlink.simulation import sensitivities

    def never(*args: object) -> None:
        raise AssertionError("ran")

    monkeypatch.setattr(sensitivities, "run_with_sensitivities", never)
    with pytest.raises(SensitivityError, match=message):
        flexlink.simulate(_paper().build(), sensitivities=[] if field is None else [field])


def test_paths_without_sensitivities_are_refused_naming_the_path() -> None:
    controlled = flexlink.load_scenario(EXAMPLES / "active_damping.toml")
    with pytest.raises(SensitivityError, match="closed_loop path.*prescribed joints"):
        flexlink.simulate(controlled, sensitivities=["links[0].mass_per_length"])
    file = _paper()
    raw = dict(file.raw)
    raw["simulation"] = {**raw["simulation"], "method": "magnus"}
    with pytest.raises(SensitivityError, match="method = 'magnus'"):
        flexlink.simulate(ScenarioFile(raw).build(), sensitivities=["links[0].EI"])
    import dataclasses

    with pytest.raises(SensitivityError, match="not built from a scenario file"):
        flexlink.simulate(dataclasses.replace(file.build()), sensitivities=["links[0].EI"])


def test_objective_value_and_gradient_for_scipy() -> None:
    file = _paper(t_end=2.0)
    objective = flexlink.Objective(file.build(), ["links[0].damping_ratio",
                                                  "joints[1].motion[0].to_deg"],
                                   flexlink.MeanSquare("link2_tip_deflection", after=1.5))
    value, gradient = objective(objective.x0)
    results = objective.results(objective.x0)
    keep = results.time >= 1.5
    assert value == pytest.approx(np.mean(results["link2_tip_deflection"][keep] ** 2),
                                  rel=1e-12)
    for k in range(2):
        h = np.zeros(2)
        h[k] = 1e-4 * objective.x0[k]
        fp = objective(objective.x0 + h)[0]
        fm = objective(objective.x0 - h)[0]
        assert gradient[k] == pytest.approx((fp - fm) / (2 * h[k]), rel=1e-5)
    wrong = flexlink.Objective(file.build(), ["links[0].EI"], flexlink.MeanSquare("link9"))
    with pytest.raises(SensitivityError, match="link9"):
        wrong(wrong.x0)


def test_a_scenario_read_from_disk_takes_sensitivities() -> None:
    path = EXAMPLES / "offset_payload.toml"
    scenario = flexlink.load_scenario(path)
    field = "links[0].mass_per_length"
    results = flexlink.simulate(scenario, sensitivities=[field])
    assert results.sensitivities.shape[2] == 1
    fd = _frozen_differences(ScenarioFile.read(path), field)
    assert _worst(results, field, fd) < 1e-6


def test_the_installation_warm_up_of_the_tangent_loop_needs_no_xarray(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The kernel build's environment has numpy, scipy and numba only: the sensitivities'
    warm-up run computes them (and an objective's gradient) without labelling them; they
    are labelled (an xarray import, which would fail there) when first read."""
    import sys

    from flexlink.cli import warmup_run, warmup_scenarios

    scenario = warmup_scenarios()["sensitivities"]
    monkeypatch.setitem(sys.modules, "xarray", None)  # any `import xarray` now fails
    warmup_run("sensitivities", scenario)
    results = flexlink.simulate(scenario, sensitivities=["links[0].EI"])
    with pytest.raises(ImportError):
        results.sensitivities  # noqa: B018 — reading them labels them
