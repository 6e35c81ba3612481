"""Field paths (flexlink.scenario.fields): one grammar for sweeps and fits, reaching every
numeric field of a scenario file, by index or by name."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from flexlink.batch import SweepError
from flexlink.batch.cases import case_scenarios, load_base
from flexlink.batch.parameters import case_table, grid_values
from flexlink.experiment.files import MeasurementError
from flexlink.experiment.parameters import model_values, parse_parameter
from flexlink.scenario import paper_experiment_path
from flexlink.scenario.fields import (
    FieldPath,
    FieldPathError,
    Name,
    ScenarioFile,
    format_path,
    get,
    is_number,
    locate,
    parse,
    with_values,
)

EXAMPLES = Path(__file__).parents[2] / "examples"
PAPER = ScenarioFile.read(paper_experiment_path())


def test_parse_keys_indices_and_names() -> None:
    assert parse("links[0].EI") == ("links", 0, "EI")
    assert parse("links[link1].E") == ("links", Name("link1"), "E")
    assert parse("base.loads[0].moment[0].amplitude") == (
        "base", "loads", 0, "moment", 0, "amplitude")
    assert parse("sensors[my.gauge-2].x") == ("sensors", Name("my.gauge-2"), "x")
    assert parse("joints[0].base_point[1]") == ("joints", 0, "base_point", 1)
    for text in ("links[link1].E", "joints[1].motion[0].to_deg", "simulation.rtol"):
        assert format_path(parse(text)) == text


@pytest.mark.parametrize("bad", ["", "links[0]..EI", "links[-1].EI", "links[a b].EI", ".EI",
                                 "links[0].E I", "links[0]EI", "links[].EI", "links[[0]].EI"])
def test_malformed_paths_name_an_example(bad: str) -> None:
    with pytest.raises(FieldPathError, match="links\\[link1\\].E") as excinfo:
        parse(bad)
    assert repr(bad) in str(excinfo.value)


def test_a_name_index_finds_the_entry_with_that_name() -> None:
    assert PAPER.locate("links[link2].E").path == ("links", 1, "E")
    assert PAPER.locate("sensors[pzt].capacitance").path == ("sensors", 2, "capacitance")
    assert PAPER.locate("sensors[pzt].capacitance").value == 1e-6


@pytest.mark.parametrize(("text", "message"), [
    ("links[lnk2].E", ("links[lnk2].E: links has no entry named 'lnk2' (did you mean "
                       "'link2'? known names: 'link1', 'link2')")),
    ("sensors[strain].x", ("known names: 'link1_tip_acceleration', 'link2_tip_deflection', "
                           "'pzt', 'link2_root_strain'")),
    ("joints[first].motion[0].start", ("the entries of joints have no names; give an index "
                                       "from 0 to 1")),
    ("links[2].EI", "the scenario has 2 entries in links (indices 0 to 1)"),
    ("sensor[0].x", "the scenario has no sensor (did you mean 'sensors'?)"),
    ("joints[0].duration", ("profile keys sit in its motion array, e.g. "
                            "joints[0].motion[0].duration")),
    ("links[0].mode_shapes", "string 'clamped_free'; only numeric fields"),
    ("links[0]", "links[0] is not a key of a table"),
    ("simulation", "the top level holds sections"),
])
def test_unknown_names_and_fields_are_explained(text: str, message: str) -> None:
    with pytest.raises(FieldPathError) as excinfo:
        PAPER.locate(text)
    assert message in str(excinfo.value)


def test_values_come_from_the_file_else_its_defaults() -> None:
    assert PAPER.locate("links[0].E").value == 30e9  # as written (the resolved file has EI)
    assert PAPER.locate("links[0].EI").value == pytest.approx(308.7)  # derived from E
    assert PAPER.locate("links[1].tip_mass").value == 0.0  # left at its default
    assert PAPER.locate("links[0].modes").integer
    assert not PAPER.locate("links[0].damping_ratio").integer
    unset = PAPER.locate("simulation.step")  # optional, no default
    assert unset.value is None and unset.key == "step"


def test_get_and_set_copy_only_the_path_and_keep_E_or_EI() -> None:
    raw = PAPER.raw
    out = with_values(raw, {("links", 0, "EI"): 250.0, ("sensors", 0, "x"): 1.0})
    assert get(out, ("links", 0, "EI")) == 250.0 and "E" not in out["links"][0]
    assert get(out, ("sensors", 0, "x")) == 1.0
    assert raw["links"][0]["E"] == 30e9 and "EI" not in raw["links"][0]  # never modified
    assert raw["sensors"][0]["x"] == 1.37
    assert out["joints"] is raw["joints"]  # untouched branches are shared
    back = with_values(out, {("links", 0, "E"): 20e9})
    assert "EI" not in back["links"][0]


def numeric_leaves(node: Any, path: FieldPath = ()) -> Iterator[tuple[FieldPath, Any]]:
    """Every number in a parsed scenario, with its path."""
    if isinstance(node, dict):
        for key, value in node.items():
            yield from numeric_leaves(value, (*path, key))
    elif isinstance(node, list):
        for i, value in enumerate(node):
            yield from numeric_leaves(value, (*path, i))
    elif is_number(node):
        yield path, node


@pytest.mark.parametrize("file", [paper_experiment_path(), EXAMPLES / "satellite_slew.toml",
                                  EXAMPLES / "paper_servo.toml"], ids=lambda p: p.stem)
def test_every_numeric_field_of_a_scenario_is_reachable(file: Path) -> None:
    """Every number the file writes, and every default the resolved scenario fills in, is
    reached by its path, with its value; named entries by name too."""
    scenario = ScenarioFile.read(file)
    raw, resolved = scenario.raw, scenario.resolved()
    leaves = dict(numeric_leaves(resolved))
    leaves.update(numeric_leaves(raw))  # the file's own values win (E, not the derived EI)
    assert len(leaves) > 30
    for path, value in leaves.items():
        text = format_path(path)
        target = locate(text, raw, resolved)
        assert (target.path, target.value) == (path, value), text
        if path[0] in ("links", "sensors") and len(path) > 2:
            name = raw[path[0]][path[1]]["name"]
            named = format_path((path[0], Name(name), *path[2:]))
            assert locate(named, raw, resolved).path == path, named


def test_base_loads_servo_gains_and_pairs() -> None:
    satellite = ScenarioFile.read(EXAMPLES / "satellite_slew.toml")
    assert satellite.locate("base.mass").value == 100.0
    assert satellite.locate("base.loads[0].moment[0].amplitude").value == 1.21
    assert satellite.locate("joints[1].base_point[0]").value == -0.5
    moved = satellite.build({("base", "mass"): 50.0, ("joints", 0, "base_point", 0): 0.75})
    assert moved.base.mass == 50.0 and moved.base.attachments[0] == (0, (0.75, 0.0))
    drifting = satellite.build({("base", "velocity", 0): 0.1})  # a pair left at its default
    assert drifting.base.velocity == (0.1, 0.0) and "velocity" not in satellite.raw["base"]
    servo = ScenarioFile.read(EXAMPLES / "paper_servo.toml")
    assert servo.locate("joints[0].P").value == 5.0
    assert servo.build({("joints", 0, "P"): 7.0}).chain.joints[0].P == 7.0


def test_a_sweep_takes_name_indices_and_refuses_one_field_twice() -> None:
    base = load_base(paper_experiment_path())
    cases = case_scenarios(base, case_table([grid_values("links[link2].EI", [0.2, 0.3])]))
    assert [c.chain.links[1].EI for c in cases] == [0.2, 0.3]
    table = case_table([grid_values("links[0].E", [2e10]), grid_values("links[link1].E", [3e10])])
    with pytest.raises(SweepError, match="links\\[0\\].E and links\\[link1\\].E name the same"):
        case_scenarios(base, table)


def test_a_fit_and_a_sweep_accept_the_same_path_with_the_same_meaning() -> None:
    """links[link1].E: a sweep case and a fitted value set it alike, and EI follows from E."""
    path, modulus = "links[link1].E", 20e9
    swept = case_scenarios(load_base(paper_experiment_path()),
                           case_table([grid_values(path, [modulus])]))[0]
    param = parse_parameter(path, PAPER, {"pzt": "V"})
    assert (param.value, param.log, param.lower, param.upper) == (30e9, True, 3e9, 3e11)
    fitted = PAPER.build(model_values([param], [modulus]))
    assert fitted.chain.links[0].EI == swept.chain.links[0].EI == pytest.approx(
        modulus * 0.045 * 0.014**3 / 12, rel=1e-15)


def test_a_fit_accepts_any_real_field_and_keeps_default_bounds_valid() -> None:
    at_tip = parse_parameter("sensors[0].x", PAPER, {})  # 1.37 m: the tip of link 1
    assert at_tip.lower == pytest.approx(0.137) and 1.36 < at_tip.upper <= 1.37
    mass = parse_parameter("links[1].mass_per_length", PAPER, {})
    assert (mass.lower, mass.upper) == pytest.approx((0.00636, 0.636))
    zeta = parse_parameter("links[link2].damping_ratio", PAPER, {})
    assert (zeta.lower, zeta.upper, zeta.log) == (1e-4, 0.5, True)
    with pytest.raises(MeasurementError, match="at the bound value 2 the scenario is invalid"):
        parse_parameter("sensors[0].x", PAPER, {}, bounds=(1.0, 2.0))
    with pytest.raises(MeasurementError, match="is 0 in the scenario: give both bounds"):
        parse_parameter("links[1].tip_mass", PAPER, {})
    tip = parse_parameter("links[1].tip_mass", PAPER, {}, bounds=(0.0, 0.1))
    assert (tip.value, tip.log) == (0.0, False)
    np.testing.assert_equal(PAPER.build(model_values([tip], [0.05])).chain.links[1].tip_mass,
                            0.05)
