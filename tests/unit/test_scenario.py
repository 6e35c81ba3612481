"""Scenario files: parsing, defaults, every validation rule, the built-in paper scenario."""

from __future__ import annotations

import copy
import math
import tomllib
from pathlib import Path
from typing import Any

import pytest

from flexlink.model import PiezoSensor, PointSensor
from flexlink.motion import Cycloidal, Hold, MeasuredMotion, Sequence, Spinup
from flexlink.scenario import (
    ScenarioError,
    load_paper_experiment,
    load_scenario,
    paper_experiment_path,
    resolve_scenario_dict,
    scenario_from_dict,
)
from flexlink.scenario.toml_writer import dump_toml


def minimal() -> dict[str, Any]:
    """A valid two-link scenario as tomllib would return it."""
    return {
        "simulation": {"t_end": 0.2, "dt_out": 0.01},
        "links": [
            {"name": "a", "length": 1.0, "mass_per_length": 0.5, "EI": 300.0},
            {"name": "b", "length": 0.5, "mass_per_length": 0.1, "EI": 1.0, "thickness": 0.002},
        ],
        "joints": [
            {"motion": [{"profile": "hold", "angle_deg": 0.0}]},
            {"motion": [{"profile": "cycloidal", "from_deg": 0.0, "to_deg": 45.0,
                         "start": 0.0, "duration": 0.1}]},
        ],
        "sensors": [{"name": "tip", "kind": "deflection", "link": "b", "x": 0.5}],
    }


def problems(d: dict[str, Any], base_dir: Path = Path(".")) -> list[str]:
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d, base_dir=base_dir)
    return info.value.problems


def only_problem(d: dict[str, Any]) -> str:
    found = problems(d)
    assert len(found) == 1, found
    return found[0]


def test_minimal_scenario_fills_defaults() -> None:
    scenario = scenario_from_dict(minimal())
    a, b = scenario.chain.links
    assert (a.tip_mass, a.tip_inertia, a.damping_ratio, a.modes) == (0.0, 0.0, 0.0, 4)
    # mode_shapes "auto": a carries b, b carries nothing (docs/modes.md, "The default basis")
    assert (a.mode_shapes, b.mode_shapes) == ("outboard_loaded", "clamped_free")
    assert a.thickness is None and b.thickness == 0.002
    assert scenario.settings.rtol == 1e-6 and scenario.settings.atol == 1e-12
    assert scenario.settings.method == "lawson"
    assert scenario.settings.geometric_stiffening is True  # the consistent linearisation
    assert scenario.name == "scenario"
    assert scenario.chain.joints[0] == Hold(0.0)
    assert scenario.sensors == (PointSensor("tip", "deflection", link=1, x=0.5),)


def test_E_width_thickness_give_EI() -> None:
    d = minimal()
    d["links"][0] = {"name": "a", "length": 1.0, "mass_per_length": 0.5, "E": 70e9,
                     "width": 0.028, "thickness": 0.001}
    link = scenario_from_dict(d).chain.links[0]
    assert pytest.approx(70e9 * 0.028 * 0.001**3 / 12, rel=1e-15) == link.EI
    assert link.thickness == 0.001


def test_all_problems_are_reported_at_once() -> None:
    d = minimal()
    d["simulation"]["t_end"] = "5"
    d["links"][0]["lenght"] = 1.0
    d["links"][1]["EI"] = -3.0
    d["joints"][1]["motion"][0]["profile"] = "sine"
    d["sensors"][0]["link"] = "c"
    d["sensorz"] = []
    found = problems(d)
    expected = [
        "simulation.t_end: expected a number, got string '5'",
        "links[0]: unknown key 'lenght' (did you mean 'length'?)",
        "links[1].EI must be > 0 N·m², got -3.0",
        "unknown section 'sensorz' (did you mean 'sensors'?)",
    ]
    for message in expected:
        assert message in found
    assert any("joints[1].motion[0].profile" in m and "'cycloidal', 'quintic', 'spinup', "
               "'hold'" in m for m in found)
    assert any("sensors[0].link: unknown link 'c' (known links: 'a', 'b')" in m for m in found)
    assert len(found) == 6
    assert all(f"  - {m}" in str(ScenarioError(found)) for m in found)


@pytest.mark.parametrize(
    ("section", "key", "value", "expected"),
    [
        ("simulation", "t_end", 0.0, "simulation.t_end must be > 0 s, got 0.0"),
        ("simulation", "dt_out", True, "simulation.dt_out: expected a number, got boolean true"),
        ("simulation", "dt_out", 1.0, "simulation.dt_out must be <= simulation.t_end"),
        ("simulation", "rtol", 0.1, "simulation.rtol must be in (0, 0.01], got 0.1"),
        ("simulation", "atol", -1.0, "simulation.atol must be > 0, got -1.0"),
        ("simulation", "t_end", math.inf, "simulation.t_end must be finite, got inf"),
        ("simulation", "t_end", math.nan, "simulation.t_end must be finite, got nan"),
        ("simulation", "geometric_stiffening", "no",
         "simulation.geometric_stiffening: expected true or false, got string 'no'"),
        ("simulation", "method", "rk4", ("simulation.method must be one of 'magnus', 'lawson', 'DOP853', "
         "'RK45', 'Radau', 'LSODA', got 'rk4'")),
        ("links", "length", -1, "links[0].length must be > 0 m, got -1.0"),
        ("links", "tip_mass", -0.1, "links[0].tip_mass must be >= 0 kg, got -0.1"),
        ("links", "tip_inertia", -1.0, "links[0].tip_inertia must be >= 0 kg·m², got -1.0"),
        ("links", "damping_ratio", 1.0, "links[0].damping_ratio must be in [0, 1), got 1.0"),
        ("links", "modes", 21, "links[0].modes must be an integer from 1 to 20, got 21"),
        ("links", "modes", 4.0, "links[0].modes: expected an integer, got number 4.0"),
        ("links", "mode_shapes", "clamped", ("links[0].mode_shapes must be one of 'auto', "
         "'clamped_free', 'tip_loaded', 'outboard_loaded', 'hub_loaded', 'pinned_pinned', "
         "'pinned_loaded', got 'clamped' "
         "(did you mean 'clamped_free'?)")),
        ("links", "name", "", "links[0].name must not be empty"),
        ("links", "name", "b", "links[1].name: duplicate name 'b' (names must be unique)"),
        ("links", "name", "has space", "links[0].name must be 1-64 letters"),
        ("links", "E", 1e9, "links[0]: give either EI (N·m²) or E (Pa)"),
    ],
)
def test_one_rule(section: str, key: str, value: Any, expected: str) -> None:
    d = minimal()
    table = d[section] if section == "simulation" else d[section][0]
    table[key] = value
    assert only_problem(d).startswith(expected)


def test_missing_things_are_reported() -> None:
    d = minimal()
    del d["links"][0]["EI"], d["links"][1]["length"], d["simulation"]["dt_out"]
    del d["joints"]
    found = problems(d)
    assert "links[0]: missing bending stiffness: give EI (N·m²), or E (Pa) with width and " \
           "thickness (m)" in found
    assert "links[1]: missing required key 'length' (a number > 0 m)" in found
    assert "simulation: missing required key 'dt_out' (a number > 0 s)" in found
    assert "missing section [[joints]] (at least one table)" in found


def test_E_needs_width_and_thickness() -> None:
    d = minimal()
    del d["links"][0]["EI"]
    d["links"][0]["E"] = 70e9
    assert problems(d) == [
        "links[0]: missing required key 'width' (m, > 0; needed with E)",
        "links[0]: missing required key 'thickness' (m, > 0; needed with E)",
    ]


def test_joint_count_and_shapes() -> None:
    d = minimal()
    d["joints"].pop()
    assert only_problem(d) == "joints: expected one [[joints]] table per link (2), got 1"
    d = minimal()
    d["joints"][0] = {"motion": {"profile": "hold", "angle_deg": 0.0}}
    assert only_problem(d).startswith("joints[0].motion: expected a non-empty array")
    d = minimal()
    d["joints"][0] = {}
    assert only_problem(d).startswith("joints[0]: missing 'motion'")
    d = minimal()
    d["links"] = {"name": "a"}
    assert "links: expected an array of tables [[links]], got a table" in problems(d)


def test_motion_errors_carry_their_path() -> None:
    d = minimal()
    seg = d["joints"][1]["motion"][0]
    seg["duration"] = -1.0
    assert only_problem(d).startswith("joints[1].motion[0].duration must be > 0 s")
    seg.update(duration=0.1, start="0")
    assert only_problem(d) == "joints[1].motion[0].start: expected a number, got string '0'"
    del seg["start"]
    seg["stat"] = 0.0
    assert set(problems(d)) == {
        "joints[1].motion[0]: unknown key 'stat' (did you mean 'start'?)",
        "joints[1].motion[0]: missing required key 'start' (a number)",
    }


def test_sequence_of_segments_and_its_errors() -> None:
    d = minimal()
    d["joints"][0]["motion"] = [
        {"profile": "cycloidal", "from_deg": 0.0, "to_deg": 10.0, "start": 0.0, "duration": 0.1},
        {"profile": "spinup", "to_rate_deg_s": 90.0, "start": 0.1, "duration": 0.05,
         "from_deg": 10.0},
    ]
    joint = scenario_from_dict(d).chain.joints[0]
    assert joint == Sequence((Cycloidal(0.0, 10.0, 0.0, 0.1), Spinup(90.0, 0.1, 0.05, 10.0)))
    d["joints"][0]["motion"][1]["from_deg"] = 20.0
    assert only_problem(d).startswith("joints[0].motion[1].from_deg = 20 does not continue")


def test_spinup_from_deg_defaults_to_zero() -> None:
    d = minimal()
    d["joints"][0]["motion"] = [{"profile": "spinup", "to_rate_deg_s": 90.0, "start": 0.0,
                                 "duration": 0.1}]
    assert scenario_from_dict(d).chain.joints[0] == Spinup(90.0, 0.0, 0.1, 0.0)
    assert resolve_scenario_dict(d)["joints"][0]["motion"][0]["from_deg"] == 0.0


def test_sensor_rules() -> None:
    d = minimal()
    d["sensors"] = [
        {"name": "s1", "kind": "deflection", "link": "a", "x": 1.5},
        {"name": "s2", "kind": "strain", "link": "a", "x": 0.0},
        {"name": "s2", "kind": "velocity", "link": "a", "x": 0.0},
        {"name": "joint1_angle", "kind": "slope", "link": "b", "x": 0.1},
        {"name": "b_tip_X", "kind": "slope", "link": "b", "x": 0.1, "thickness": 0.1},
        {"name": "p", "kind": "piezo", "link": "b", "x_start": 0.3, "x_end": 0.2, "width": 0.0,
         "E_p": 1e9, "d31": 0.0, "capacitance": 1e-6},
    ]
    found = problems(d)
    assert found == [
        "sensors[0].x must be <= 1.0 m (the length of link 'a'), got 1.5",
        ("sensors[1]: missing required key 'thickness' (m, > 0; link 'a' gives no thickness "
        "to default to)"),
        ("sensors[2].kind must be one of 'deflection', 'slope', 'strain', 'acceleration', "
        "'piezo', got 'velocity'"),
        ("sensors[3].name 'joint1_angle' clashes with an automatic output channel (t, time, "
        "joint<k>_angle, joint<k>_torque, <link>_tip_X, <link>_tip_Y); choose another"),
        ("sensors[4].name 'b_tip_X' clashes with an automatic output channel (t, time, "
        "joint<k>_angle, joint<k>_torque, <link>_tip_X, <link>_tip_Y); choose another"),
        "sensors[4]: unknown key 'thickness' (allowed: name, kind, link, x)",
        "sensors[5].width must be > 0 m, got 0.0",
        "sensors[5].d31 must be non-zero m/V, got 0.0",
        "sensors[5]: x_start must be < x_end, got x_start = 0.3 m, x_end = 0.2 m",
        "sensors[2].name: duplicate name 's2' (names must be unique)",
    ]


def test_piezo_and_strain_thickness_default_to_the_link() -> None:
    d = minimal()
    d["sensors"] = [
        {"name": "g", "kind": "strain", "link": "b", "x": 0.0},
        {"name": "p", "kind": "piezo", "link": "b", "x_start": 0.01, "x_end": 0.04,
         "width": 0.025, "E_p": 30.33e9, "d31": -265e-12, "capacitance": 1e-6},
    ]
    g, p = scenario_from_dict(d).sensors
    assert g == PointSensor("g", "strain", link=1, x=0.0, thickness=0.002)
    assert p == PiezoSensor("p", 1, 0.01, 0.04, 0.025, 30.33e9, -265e-12, 0.002, 1e-6)


def test_files_missing_file_and_syntax_error(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match="file not found"):
        load_scenario(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[simulation]\nt_end = 1.0\ndt_out = = 0.1\n")
    with pytest.raises(ScenarioError, match=r"TOML syntax error: .*line 3"):
        load_scenario(bad)


def test_file_name_is_the_default_name(tmp_path: Path) -> None:
    path = tmp_path / "my_arm.toml"
    path.write_text(dump_toml(minimal()))
    assert load_scenario(path).name == "my_arm"


def test_measured_angles_from_csv(tmp_path: Path) -> None:
    (tmp_path / "data").mkdir()
    rows = "\n".join(f"{0.01 * i:.2f},{2.0 * i}" for i in range(31))
    (tmp_path / "data" / "angles.csv").write_text("time,beta1\n" + rows + "\n")
    d = minimal()
    d["joints"][0] = {"csv": "data/angles.csv", "time_column": "time", "angle_column": "beta1"}
    joint = scenario_from_dict(d, base_dir=tmp_path).chain.joints[0]
    assert isinstance(joint, MeasuredMotion) and joint.time_range == (0.0, 0.3)
    resolved = resolve_scenario_dict(d, base_dir=tmp_path)["joints"][0]
    assert resolved == {"csv": str((tmp_path / "data" / "angles.csv").resolve()),
                        "time_column": "time", "angle_column": "beta1"}
    d["joints"][0]["angle_column"] = "beta2"
    assert only_problem_in(d, tmp_path).startswith("joints[0].csv: ")
    d["joints"][0].update(angle_column="beta1", csv="missing.csv", motion=[])
    assert "joints[0]: give either 'motion' (profiles) or 'csv' (measured angles), not both" \
        in problems(d, tmp_path)
    del d["joints"][0]["motion"]
    assert only_problem_in(d, tmp_path).startswith("joints[0].csv: file not found: ")
    d["simulation"]["t_end"] = 0.5
    d["joints"][0]["csv"] = "data/angles.csv"
    assert only_problem_in(d, tmp_path) == ("joints[0].csv: the measured angles cover 0 s to "
                                            "0.3 s; the simulation needs 0 s to "
                                            "simulation.t_end = 0.5 s")


def only_problem_in(d: dict[str, Any], base_dir: Path) -> str:
    found = problems(d, base_dir)
    assert len(found) == 1, found
    return found[0]


def test_resolved_dict_round_trips(tmp_path: Path) -> None:
    d = minimal()
    d["links"][0] = {"name": "a", "length": 1.0, "mass_per_length": 0.5, "E": 30e9,
                     "width": 0.045, "thickness": 0.014, "tip_mass": 0.1}
    resolved = resolve_scenario_dict(d)
    assert resolved["flexlink_version"]
    assert resolved["links"][0]["EI"] == pytest.approx(308.7)
    assert "E" not in resolved["links"][0]
    original = scenario_from_dict(d)
    assert scenario_from_dict(copy.deepcopy(resolved)) == original
    path = tmp_path / "resolved.toml"
    path.write_text(dump_toml(resolved))
    assert tomllib.loads(path.read_text()) == resolved
    assert load_scenario(path) == original


def test_paper_scenario_has_the_documented_values() -> None:
    scenario = load_paper_experiment()
    link1, link2 = scenario.chain.links
    assert scenario.name == "paper-experiment"
    assert (link1.length, link1.mass_per_length, link1.tip_mass) == (1.37, 0.5292, 0.129)
    assert pytest.approx(30e9 * 0.045 * 0.014**3 / 12) == link1.EI
    assert (link1.thickness, link1.damping_ratio, link1.modes) == (0.014, 0.02, 4)
    assert (link2.length, link2.mass_per_length, link2.damping_ratio) == (0.6, 0.0636, 0.01)
    assert pytest.approx(70e9 * 0.028 * 0.001**3 / 12) == link2.EI
    assert scenario.chain.joints == (Cycloidal(0.0, 90.0, 0.5, 1.0),
                                     Cycloidal(90.0, 170.0, 0.5, 1.0))
    assert (scenario.settings.t_end, scenario.settings.dt_out) == (5.0, 0.001)
    assert scenario.settings.geometric_stiffening is False  # the paper's model, explicitly
    names = [s.name for s in scenario.sensors]
    assert names == ["link1_tip_acceleration", "link2_tip_deflection", "pzt", "link2_root_strain"]
    pzt = scenario.sensors[2]
    assert pzt == PiezoSensor("pzt", 1, 0.01, 0.04, 0.025, 30.33e9, 265e-12, 0.001, 1e-6)
    assert load_scenario(paper_experiment_path()) == scenario


def test_docs_examples_are_valid(tmp_path: Path) -> None:
    """The full example in docs/scenario.md loads, and its joints block parses."""
    docs = Path(__file__).parents[2] / "docs" / "scenario.md"
    blocks = docs.read_text(encoding="utf-8").split("```toml\n")[1:]
    full = blocks[-1].split("```")[0]
    path = tmp_path / "example.toml"
    path.write_text(full, encoding="utf-8")
    scenario = load_scenario(path)
    assert scenario.name == "two-link-demo" and len(scenario.sensors) == 4
    sequence = tomllib.loads(blocks[0].split("```")[0])["joints"][0]
    d = minimal()
    d["joints"][0] = sequence
    assert isinstance(scenario_from_dict(d).chain.joints[0], Sequence)
