"""A sweep's worker runs each case without its `Results` and reads cases that differ only in
their sensors from one run: every case still equals its own `simulate` run bit for bit, for
fields of each kind (stiffness, tip mass, motion, sensor gain and position)."""

from __future__ import annotations

import copy
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

from flexlink.batch import sweep
from flexlink.batch.runner import CaseRunner
from flexlink.scenario import paper_experiment_path, scenario_from_dict
from flexlink.simulation import simulate

from .test_sweep import short_paper


def _set_EI(raw: dict[str, Any], value: float) -> None:
    del raw["links"][0]["E"]
    raw["links"][0]["EI"] = value


def _set(*keys: Any) -> Callable[[dict[str, Any], float], None]:
    def setter(raw: dict[str, Any], value: float) -> None:
        entry = raw
        for key in keys[:-1]:
            entry = entry[key]
        entry[keys[-1]] = value
    return setter


FIELDS = [  # path, values, the same change made by hand in the parsed file
    ("links[0].EI", [250.0, 350.0, 300.0], _set_EI),
    ("links[1].tip_mass", [0.0, 0.05, 0.02], _set("links", 1, "tip_mass")),
    ("joints[0].motion[0].duration", [0.25, 0.3, 0.28], _set("joints", 0, "motion", 0,
                                                             "duration")),
    ("sensors[pzt].capacitance", [1e-6, 2e-6, 5e-7], _set("sensors", 2, "capacitance")),
    ("sensors[0].x", [0.8, 1.2, 1.37], _set("sensors", 0, "x")),
]


def by_hand_raw(raw: dict[str, Any], setter: Callable[[dict[str, Any], float], None],
                value: float) -> dict[str, Any]:
    raw = copy.deepcopy(raw)
    setter(raw, value)
    return raw


def by_hand(raw: dict[str, Any], setter: Callable[[dict[str, Any], float], None],
            value: float):
    return scenario_from_dict(by_hand_raw(raw, setter, value), paper_experiment_path().parent)


@pytest.mark.parametrize(("path", "values", "setter"), FIELDS, ids=[f[0] for f in FIELDS])
def test_each_case_equals_its_single_run_for_every_kind_of_field(path, values, setter) -> None:
    raw = short_paper()
    dataset = sweep(raw, grid={path: values}, workers=1,
                    base_dir=paper_experiment_path().parent)
    assert dataset.status.values.tolist() == ["ok"] * len(values)
    for case, value in enumerate(values):
        reference = simulate(by_hand(raw, setter, value))
        for name in reference.names:
            assert np.array_equal(dataset[name].values[case], reference[name]), (case, name)
    # the field did change the results
    assert not all(np.array_equal(dataset[n].values[0], dataset[n].values[1])
                   for n in reference.names)


def test_forked_workers_share_runs_between_sensor_cases_bit_for_bit() -> None:
    raw = short_paper()
    values = [0.5, 0.8, 1.0, 1.2, 1.37, 0.9]
    dataset = sweep(raw, grid={"links[0].EI": [250.0, 350.0], "sensors[0].x": values},
                    workers=2, base_dir=paper_experiment_path().parent)
    assert dataset.status.values.tolist() == ["ok"] * 12
    for case in range(12):
        EI, x = float(dataset["links[0].EI"][case]), float(dataset["sensors[0].x"][case])
        reference = simulate(by_hand(by_hand_raw(raw, _set_EI, EI), _set("sensors", 0, "x"), x))
        for name in reference.names:
            assert np.array_equal(dataset[name].values[case], reference[name]), (case, name)


def test_only_cases_equal_but_for_their_sensors_share_a_run() -> None:
    raw = short_paper()
    runner = CaseRunner()
    first = runner.run(by_hand(raw, _set("sensors", 2, "capacitance"), 1e-6))
    gain = by_hand(raw, _set("sensors", 2, "capacitance"), 2e-6)
    second = runner.run(gain)
    assert not first.shared and second.shared
    # the piezo reads half the voltage with twice the capacitance, from the same motion
    np.testing.assert_allclose(second["pzt"], 0.5 * first["pzt"], rtol=1e-12, atol=0.0)
    reference = simulate(gain)
    assert second.names == reference.names
    for name in reference.names:
        assert np.array_equal(second[name], reference[name]), name
    stiffer = runner.run(by_hand(raw, _set_EI, 400.0))
    assert not stiffer.shared


def test_a_failing_case_leaves_no_run_to_share() -> None:
    raw = short_paper()
    runner = CaseRunner()
    runner.run(by_hand(raw, _set("sensors", 0, "x"), 1.0))
    diverging = copy.deepcopy(raw)  # the paper's model diverges when spun this fast
    diverging["simulation"]["geometric_stiffening"] = False
    diverging["joints"][0]["motion"] = [{"profile": "spinup", "to_rate_deg_s": 3000.0,
                                         "start": 0.0, "duration": 0.1}]
    with pytest.raises(Exception, match="exceeds its length|not finite"):
        runner.run(scenario_from_dict(diverging, paper_experiment_path().parent))
    assert not runner.run(by_hand(raw, _set("sensors", 0, "x"), 1.2)).shared


def test_a_sweep_shows_a_progress_bar_over_its_cases(capfd: pytest.CaptureFixture[str]) -> None:
    sweep(short_paper(), grid={"sensors[pzt].capacitance": [1e-6, 2e-6, 3e-6]}, workers=1,
          progress=True, histories=False, summaries=["peak:pzt"],
          base_dir=paper_experiment_path().parent)
    err = capfd.readouterr().err
    assert "3/3" in err and "case" in err


KEPT = frozenset(["link2_tip_deflection", "joint1_torque", "pzt"])


@pytest.mark.parametrize(("setter", "values"), [
    (_set_EI, [250.0, 350.0]),
    (_set("joints", 0, "motion", 0, "duration"), [0.25, 0.3]),
    (_set("sensors", 2, "capacitance"), [1e-6, 2e-6]),
], ids=["EI", "duration", "capacitance"])
def test_a_case_that_keeps_some_channels_computes_those_alone_as_its_single_run(
        setter, values) -> None:
    raw = short_paper()
    runner = CaseRunner()
    for value in values:
        scenario = by_hand(raw, setter, value)
        case = runner.run(scenario, KEPT)
        assert set(case.names) == KEPT  # nothing else read, nothing missing
        reference = simulate(scenario)
        for name in KEPT:
            assert np.array_equal(case[name], reference[name]), (value, name)


def test_the_lean_run_leaves_out_the_channels_not_kept() -> None:
    from flexlink.simulation import run_scenario

    scenario = by_hand(short_paper(), _set_EI, 300.0)
    run, _ = run_scenario(scenario, shapes=False, channels=KEPT)
    assert set(run.values) == KEPT
    assert "peak_tip_deflection_per_length" in run.metadata  # the divergence check ran


def test_a_summaries_only_sweep_equals_the_metrics_of_single_runs() -> None:
    raw = short_paper()
    texts = ["peak:link2_tip_deflection", "rms:pzt", "peak:joint2_torque"]
    EIs = [250.0, 350.0]
    dataset = sweep(raw, grid={"links[0].EI": EIs}, workers=1, histories=False,
                    summaries=texts, base_dir=paper_experiment_path().parent)
    from flexlink.batch.summaries import parse_summaries

    for case, EI in enumerate(EIs):
        reference = simulate(by_hand(raw, _set_EI, EI))
        for summary in parse_summaries(texts):
            expected = summary.evaluate(reference.time, reference[summary.channel])
            assert float(dataset[summary.name].values[case]) == expected, (case, summary.name)
