"""Variants that share a discretisation advanced together (solvers/lawson_batch.py,
batch/grouped.py): each equals its single run bit for bit, from the batched loop's first
pass to a sweep's channels, for stiffness, masses, damping, a sensor's gain and a motion's
amplitude; variants that do not share it run alone."""

from __future__ import annotations

import copy
from typing import Any

import numpy as np
import pytest

from flexlink.batch import sweep
from flexlink.batch.worker import Kept, run_chunk
from flexlink.scenario import paper_experiment_path, scenario_from_dict
from flexlink.simulation import simulate
from flexlink.simulation.common import output_times
from flexlink.simulation.prescribed import prescribed_system
from flexlink.solvers import lawson, lawson_batch

from .test_sweep import short_paper

CASES = 26  # one group, filled up to a call's 32 variants


def variants(count: int, seed: int = 3, durations: bool = False) -> list[dict[str, Any]]:
    """The short paper arm with link 1's EI, link 2's tip mass, both damping ratios, the
    piezo's capacitance (its gain) and joint 1's end angle drawn at random."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(count):
        raw = copy.deepcopy(short_paper())
        link1, link2 = raw["links"]
        del link1["E"]
        link1["EI"] = rng.uniform(250.0, 350.0)
        link2["tip_mass"] = rng.uniform(0.0, 0.03)
        link1["damping_ratio"] = rng.uniform(0.01, 0.03)
        link2["damping_ratio"] = rng.uniform(0.005, 0.02)
        raw["sensors"][2]["capacitance"] = rng.uniform(0.5e-6, 2e-6)
        raw["joints"][0]["motion"][0]["to_deg"] = rng.uniform(15.0, 25.0)
        if durations:
            raw["joints"][0]["motion"][0]["duration"] = rng.uniform(0.2, 0.35)
        out.append(raw)
    return out


def scenario(raw: dict[str, Any]):
    return scenario_from_dict(raw, paper_experiment_path().parent)


def starts(raws: list[dict[str, Any]]) -> list[lawson.Start]:
    out = []
    for raw in raws:
        case = scenario(raw)
        t = output_times(case.settings.t_end, case.settings.dt_out)
        out.append(lawson.prepare(prescribed_system(case, t), t, case.settings.rtol,
                                  case.settings.atol))
    return out


def count_batched_calls(monkeypatch) -> list[int]:
    """The sizes of the batched first passes made while the test runs, in call order."""
    calls: list[int] = []
    first_passes = lawson_batch.first_passes

    def counted(runs):
        calls.append(len(runs))
        return first_passes(runs)

    monkeypatch.setattr(lawson_batch, "first_passes", counted)
    return calls


def assert_case_equals_single_run(raw: dict[str, Any], dataset, case: int) -> None:
    """Case `case` of a sweep of `raw` equals, bit for bit, the single run of its drawn values."""
    raw_case = copy.deepcopy(raw)
    link1 = raw_case["links"][0]
    del link1["E"]
    link1["EI"] = float(dataset["links[0].EI"][case])
    raw_case["links"][1]["tip_mass"] = float(dataset["links[1].tip_mass"][case])
    raw_case["joints"][0]["motion"][0]["to_deg"] = float(
        dataset["joints[0].motion[0].to_deg"][case])
    if "links[0].damping_ratio" in dataset:
        link1["damping_ratio"] = float(dataset["links[0].damping_ratio"][case])
    if "sensors[pzt].capacitance" in dataset:
        raw_case["sensors"][2]["capacitance"] = float(dataset["sensors[pzt].capacitance"][case])
    reference = simulate(scenario(raw_case))
    for name in reference.names:
        assert np.array_equal(dataset[name].values[case], reference[name]), (case, name)


def assert_same_first_pass(batched, single) -> None:
    """States, z̈, the running maxima and the reach of the tips over every step, bit for bit."""
    for a, b in zip(batched[:4], single[:4]):
        assert np.array_equal(a, b)
    assert np.array_equal(batched[4].peak, single[4].peak)
    assert np.array_equal(batched[4].beyond, single[4].beyond)


def test_the_batched_first_pass_equals_each_single_first_pass_bit_for_bit() -> None:
    runs = starts(variants(CASES))
    assert lawson_batch.groups(runs) == [list(range(CASES))]  # one discretisation
    assert not any(np.array_equal(runs[0].ET, run.ET) for run in runs[1:])
    together = lawson_batch.first_passes(runs)
    for start, batched in zip(runs, together):
        assert batched is not None
        assert_same_first_pass(batched, lawson.first_pass(start))
    # the variants differ
    assert not np.array_equal(together[0][0], together[1][0])


def test_variants_on_their_own_tables_advance_together_bit_for_bit() -> None:
    """Other move durations: other blocks, static phases and pieces around the move's end
    in every run, the same output times and steps; one call, each run its own."""
    runs = starts(variants(CASES, seed=8, durations=True))
    assert len({(r.table.first.tobytes(), r.table.lower.tobytes()) for r in runs}) == CASES
    assert any(np.diff(r.table.pieces).max() > 1 for r in runs)  # a block of several pieces
    assert all(r.table.static.any() and not r.table.static.all() for r in runs)
    assert lawson_batch.groups(runs) == [list(range(CASES))]
    together = lawson_batch.first_passes(runs)
    for start, batched in zip(runs, together):
        assert batched is not None
        assert_same_first_pass(batched, lawson.first_pass(start))


def test_the_batched_first_pass_reads_every_tip_at_every_step_as_its_single_run() -> None:
    """The moves 1.6 times as large: 16 of the 26 variants' tips pass their link's length.
    Each lane's reach of its tips over every step (the largest |w(L)|/L and the end of the
    first step beyond it) is its single run's, bit for bit: a sweep refuses the cases their
    single runs refuse, between output samples too."""
    raws = variants(CASES, seed=5, durations=True)
    for raw in raws:
        raw["joints"][0]["motion"][0]["to_deg"] *= 1.6
    runs = starts(raws)
    assert lawson_batch.groups(runs) == [list(range(CASES))]
    together = lawson_batch.first_passes(runs)
    beyond = 0
    for start, batched in zip(runs, together):
        assert batched is not None
        assert_same_first_pass(batched, lawson.first_pass(start))
        beyond += bool(np.isfinite(batched[4].beyond).any())
    assert 0 < beyond < CASES


def test_the_block_exponentials_of_many_runs_equal_each_runs_own_bit_for_bit() -> None:
    from flexlink.solvers.batched_expm import _balancing, pade_degree
    from flexlink.solvers.lawson import propagator_stacks

    raws = variants(3) + variants(2, seed=7, durations=True)
    coarse = variants(1)[0]
    coarse["simulation"]["dt_out"] = 0.02
    raws.append(coarse)
    bare, own = [], []
    for raw in raws:
        case = scenario(raw)
        t = output_times(case.settings.t_end, case.settings.dt_out)
        system = prescribed_system(case, t)
        own.append(lawson.prepare(system, t, case.settings.rtol, case.settings.atol))
        bare.append(lawson.prepare(system, t, case.settings.rtol, case.settings.atol,
                                   propagators=False))
    degrees = {pade_degree(omega * _balancing(omega.shape[-1], n, scale))
               for run in bare for where, (omega, n, scale) in
               propagator_stacks(run.table, run.n, run.t_out, run.substeps) if where.any()}
    assert len(degrees) > 1  # stacks of several Padé degrees, each its own call
    for together, alone in zip(lawson_batch.with_propagators(bare), own):
        assert np.array_equal(together.ET, alone.ET)


def test_runs_on_different_discretisations_are_not_advanced_together() -> None:
    runs = starts(variants(2))
    other = starts([{**variants(1)[0], "simulation": {
        **short_paper()["simulation"], "dt_out": 0.02}}])
    with pytest.raises(ValueError, match="must share their output times"):
        lawson_batch.first_passes([runs[0], other[0]])
    assert lawson_batch.groups(runs * 12 + other) == [list(range(24))]
    assert lawson_batch.groups(runs * 11) == []  # too few to pay


def test_a_chunk_of_variants_runs_together_and_equals_single_runs(monkeypatch) -> None:
    calls = count_batched_calls(monkeypatch)
    # Three with other move durations (their own tables) join them; one with other output
    # times (other steps) runs alone.
    alone = variants(1, seed=6)[0]
    alone["simulation"] = {**alone["simulation"], "dt_out": 0.02}
    raws = variants(CASES) + variants(3, seed=5, durations=True) + [alone]
    cases = [scenario(raw) for raw in raws]
    result = run_chunk(list(enumerate(cases)), Kept(), runner=None)
    assert calls == [CASES + 3]
    assert result.done == list(range(len(cases))) and not result.failed
    for values, case in zip(result.values, cases):
        reference = simulate(case)
        assert values is not None
        for k, channel in enumerate(result.channels):
            assert np.array_equal(values[k], reference[channel.name]), channel.name


def test_a_forked_sweep_of_variants_equals_single_runs(monkeypatch) -> None:
    from flexlink.batch import executors

    monkeypatch.setattr(executors, "CHUNKS_PER_WORKER", 1)  # chunks of 26: one group each
    raw = short_paper()
    random = {"links[0].EI": "uniform:250:350", "links[1].tip_mass": "uniform:0:0.03",
              "links[0].damping_ratio": "uniform:0.01:0.03",
              "sensors[pzt].capacitance": "uniform:0.5e-6:2e-6",
              "joints[0].motion[0].to_deg": "uniform:15:25"}
    dataset = sweep(raw, random=random, samples=2 * CASES, seed=2, workers=2,
                    base_dir=paper_experiment_path().parent)
    assert dataset.status.values.tolist() == ["ok"] * 2 * CASES
    for case in range(0, 2 * CASES, 5):
        assert_case_equals_single_run(raw, dataset, case)


def test_an_in_process_sweep_of_variants_advances_them_together_and_equals_single_runs(
        monkeypatch) -> None:
    from flexlink.batch import executors

    monkeypatch.setattr(executors, "CHUNKS_PER_WORKER", 2)  # chunks of 26: one group each
    assert executors.BATCH_CHUNK == lawson_batch.MIN_GROUP
    calls = count_batched_calls(monkeypatch)
    raw = short_paper()
    random = {"links[0].EI": "uniform:250:350", "links[1].tip_mass": "uniform:0:0.03",
              "joints[0].motion[0].to_deg": "uniform:15:25"}
    dataset = sweep(raw, random=random, samples=2 * CASES, seed=4, workers=1,
                    base_dir=paper_experiment_path().parent)
    assert calls == [CASES, CASES]  # two chunks of 26, each one call
    assert dataset.status.values.tolist() == ["ok"] * 2 * CASES
    for case in (0, 27, 2 * CASES - 1):
        assert_case_equals_single_run(raw, dataset, case)
