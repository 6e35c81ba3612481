"""Sweep definitions: parameter paths, grid and random specs, the case table, and the scenario
of each case — every mistake reported before anything runs, naming the path."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.batch import SweepError
from flexlink.batch.cases import case_scenarios, load_base
from flexlink.batch.parameters import (
    case_table,
    grid_values,
    parse_grid_option,
    parse_path,
    parse_random_option,
    random_distribution,
)
from flexlink.scenario import paper_experiment_path
from flexlink.scenario.load import read_toml


def problems(excinfo: pytest.ExceptionInfo[SweepError]) -> str:
    return "\n".join(excinfo.value.problems)


def test_paths_parse_into_keys_and_indices() -> None:
    assert parse_path("links[0].EI") == ("links", 0, "EI")
    assert parse_path("joints[1].motion[2].duration") == ("joints", 1, "motion", 2, "duration")
    assert parse_path("simulation.rtol") == ("simulation", "rtol")


# links[a].EI was malformed before entries could be named; links[a b] is still malformed
@pytest.mark.parametrize("bad", ["", "links[0]..EI", "links[-1].EI", "links[a b].EI", ".EI",
                                 "links[0].E I", "links[0]EI"])
def test_malformed_paths_are_rejected_with_an_example(bad: str) -> None:
    with pytest.raises(SweepError) as excinfo:
        parse_path(bad)
    assert repr(bad) in problems(excinfo) and "links[0].EI" in problems(excinfo)


def test_grid_values_lists_and_rules() -> None:
    assert grid_values("links[0].EI", "1,2.5,3e2").values == (1, 2.5, 300.0)
    assert grid_values("links[0].modes", "2,4").values == (2, 4)  # integers stay integers
    assert isinstance(grid_values("links[0].modes", "2,4").values[0], int)
    assert grid_values("x.y", "linspace:1:2:3").values == (1.0, 1.5, 2.0)
    np.testing.assert_allclose(grid_values("x.y", "geomspace:1:100:3").values, [1, 10, 100])
    assert grid_values("x.y", [0.5, 2]).values == (0.5, 2)


@pytest.mark.parametrize(("spec", "expected"), [
    ("1,abc", "expected a number, got 'abc'"),
    ("1,nan", "finite"),
    ("linspace:1:2", "linspace:start:stop:count"),
    ("linspace:1:2:0", "integer >= 1"),
    ("geomspace:0:2:3", "start and stop > 0"),
    ("logspace:1:2:3", "unknown rule 'logspace'"),
])
def test_bad_grid_values_name_the_path(spec: str, expected: str) -> None:
    with pytest.raises(SweepError) as excinfo:
        grid_values("links[0].EI", spec)
    assert "grid links[0].EI" in problems(excinfo) and expected in problems(excinfo)


@pytest.mark.parametrize(("spec", "expected"), [
    ("uniform:2:1", "low < high"),
    ("loguniform:0:1", "low > 0"),
    ("normal:1:-1", "std > 0"),
    ("gauss:1:2", "uniform:low:high"),
    ("uniform:1", "uniform:low:high"),
    ("uniform:1:x", "expected a number"),
])
def test_bad_distributions_name_the_path(spec: str, expected: str) -> None:
    with pytest.raises(SweepError) as excinfo:
        random_distribution("joints[0].motion[0].duration", spec)
    text = problems(excinfo)
    assert "random joints[0].motion[0].duration" in text and expected in text


def test_command_line_forms() -> None:
    assert parse_grid_option("links[0].EI=1,2").values == (1, 2)
    spec = parse_random_option("joints[0].motion[0].duration = uniform:0.8:1.2")
    assert (spec.path, spec.distribution, spec.a, spec.b) == (
        "joints[0].motion[0].duration", "uniform", 0.8, 1.2)
    with pytest.raises(SweepError, match="expected PATH="):
        parse_grid_option("links[0].EI")


def test_grid_is_a_cartesian_product_with_the_last_parameter_fastest() -> None:
    table = case_table([grid_values("a.x", [1, 2]), grid_values("a.y", [10, 20, 30])])
    assert table.count == 6
    assert table.values["a.x"].tolist() == [1, 1, 1, 2, 2, 2]
    assert table.values["a.y"].tolist() == [10, 20, 30, 10, 20, 30]
    assert table.seed is None


def test_every_grid_point_gets_the_same_random_draws() -> None:
    table = case_table([grid_values("a.x", [1, 2, 3])],
                       [random_distribution("a.u", "uniform:5:6")], samples=4, seed=7)
    draws = table.values["a.u"].reshape(3, 4)
    assert table.values["a.x"].tolist() == [1] * 4 + [2] * 4 + [3] * 4
    assert np.array_equal(draws[0], draws[1]) and np.array_equal(draws[0], draws[2])
    assert np.unique(draws[0]).size == 4


def test_random_draws_are_reproducible_and_a_missing_seed_is_recorded() -> None:
    spec = [random_distribution("a.u", "uniform:0:1")]
    first, second = (case_table([], spec, samples=5, seed=3) for _ in range(2))
    assert np.array_equal(first.values["a.u"], second.values["a.u"])
    unseeded = case_table([], spec, samples=5)
    again = case_table([], spec, samples=5, seed=unseeded.seed)
    assert np.array_equal(unseeded.values["a.u"], again.values["a.u"])


def test_distributions_have_their_documented_laws() -> None:
    n = 20000
    table = case_table([], [random_distribution("a.u", "uniform:2:4"),
                            random_distribution("a.l", "loguniform:1:100"),
                            random_distribution("a.n", "normal:3:0.5")], samples=n, seed=11)
    u, log, normal = table.values["a.u"], table.values["a.l"], table.values["a.n"]
    assert 2 <= u.min() and u.max() < 4
    # log-uniform: log10 is uniform on [0, 2], so half the draws lie below 10
    assert 1 <= log.min() and log.max() < 100
    assert abs(np.mean(log < 10) - 0.5) < 5 * 0.5 / np.sqrt(n)
    assert abs(normal.mean() - 3) < 5 * 0.5 / np.sqrt(n)
    assert abs(normal.std() - 0.5) < 5 * 0.5 / np.sqrt(2 * n)


def test_latin_hypercube_puts_one_draw_in_each_stratum() -> None:
    n = 50
    table = case_table([], [random_distribution("a.u", "uniform:0:1"),
                            random_distribution("a.v", "uniform:10:20")],
                       samples=n, seed=1, sampler="lhs")
    for column, low, high in ((table.values["a.u"], 0, 1), (table.values["a.v"], 10, 20)):
        strata = np.floor((column - low) / (high - low) * n).astype(int)
        assert sorted(strata) == list(range(n))


@pytest.mark.parametrize(("kwargs", "expected"), [
    ({}, "nothing to sweep"),
    ({"random": [random_distribution("a.u", "uniform:0:1")]}, "samples = an integer >= 1"),
    ({"grid": [grid_values("a.x", [1])], "samples": 3}, "no random parameter"),
    ({"grid": [grid_values("a.x", [1]), grid_values("a.x", [2])]}, "a.x is given twice"),
    ({"grid": [grid_values("a.x", [1])], "sampler": "sobol"}, "sampler must be"),
])
def test_inconsistent_sweeps_are_rejected(kwargs: dict, expected: str) -> None:
    with pytest.raises(SweepError) as excinfo:
        case_table(kwargs.get("grid", []), kwargs.get("random", []), kwargs.get("samples"),
                   sampler=kwargs.get("sampler", "random"))
    assert expected in problems(excinfo)


def paper_cases(**grid: list[float]) -> list:
    """Scenarios of a grid over the paper experiment ('links_1__EI' → 'links[1].EI')."""
    specs = [grid_values(k.replace("__", "].").replace("_", "[", 1), v)
             for k, v in grid.items()]
    return case_scenarios(load_base(paper_experiment_path()), case_table(specs))


def test_a_case_sets_exactly_its_field() -> None:
    cases = paper_cases(sensors_0__x=[0.5, 1.0])
    assert [c.sensors[0].x for c in cases] == [0.5, 1.0]
    base = load_base(paper_experiment_path())
    assert base.raw["sensors"][0]["x"] == 1.37  # the base is never modified


def test_EI_replaces_E_and_a_section_size_changes_EI_through_E() -> None:
    raw = read_toml(paper_experiment_path())
    modulus, width = raw["links"][1]["E"], raw["links"][1]["width"]
    by_EI = paper_cases(links_1__EI=[0.2, 0.3])
    assert [c.chain.links[1].EI for c in by_EI] == [0.2, 0.3]
    by_thickness = paper_cases(links_1__thickness=[0.001, 0.002])
    expected = [modulus * width * t**3 / 12 for t in (0.001, 0.002)]
    np.testing.assert_allclose([c.chain.links[1].EI for c in by_thickness], expected, rtol=1e-15)


def test_path_problems_are_all_reported_before_anything_runs() -> None:
    table = case_table([grid_values(p, [1.0]) for p in (
        "simulation.t_end", "links[0].name", "links[5].EI", "joints[0].duration", "link.EI",
        "links[0]")])
    with pytest.raises(SweepError) as excinfo:
        case_scenarios(load_base(paper_experiment_path()), table)
    text = problems(excinfo)
    assert len(excinfo.value.problems) == 6
    assert "simulation.t_end cannot be swept" in text
    assert "links[0].name is string 'link1'; only numeric fields" in text
    assert "links[5].EI: the scenario has 2 entries in links (indices 0 to 1)" in text
    assert "e.g. joints[0].motion[0].duration" in text
    assert "link.EI: the scenario has no link" in text
    assert "links[0] is not a key of a table" in text


def test_invalid_values_name_the_field_value_and_cases() -> None:
    table = case_table([grid_values("links[0].EI", [300.0, -1.0, -2.0]),
                        grid_values("sensors[0].x", [1.0, 2.0])])
    with pytest.raises(SweepError) as excinfo:
        case_scenarios(load_base(paper_experiment_path()), table)
    assert excinfo.value.problems == [  # one line per kind of problem, with its first case
        ("sensors[0].x must be <= 1.37 m (the length of link 'link1'), got 2.0 "
         "(case 1: links[0].EI = 300, sensors[0].x = 2; 2 more cases like it)"),
        ("links[0].EI must be > 0 N·m², got -1.0 "
         "(case 2: links[0].EI = -1, sensors[0].x = 1; 3 more cases like it)"),
    ]


def test_an_unknown_key_is_caught_by_the_scenario_checks() -> None:
    table = case_table([grid_values("links[0].lenght", [1.0])])
    with pytest.raises(SweepError, match="did you mean 'length'"):
        case_scenarios(load_base(paper_experiment_path()), table)
