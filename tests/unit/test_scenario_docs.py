"""The scenario schema is the one source: the loader accepts exactly its keys, its allowed
values are the model's literals, and docs/scenario.md's key tables are generated from it."""

from __future__ import annotations

import copy
import importlib.util
import re
from pathlib import Path
from typing import Any, get_args

import pytest

from flexlink import model
from flexlink.scenario import ScenarioError, scenario_from_dict
from flexlink.scenario import schema as s
from flexlink.scenario.schema_docs import BLOCK, BLOCKS, markdown_table, regenerate

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs" / "scenario.md"
UNKNOWN = "zzzz"  # close to no key, so the message lists every allowed key

HOLD = [{"profile": "hold", "angle_deg": 0.0}]
STEP = {"profile": "step", "amplitude": 1.0}


def base_scenario(**sections: Any) -> dict[str, Any]:
    """A valid one-link scenario, with ``sections`` added or replaced."""
    return {"simulation": {"t_end": 0.2, "dt_out": 0.01},
            "links": [{"name": "a", "length": 1.0, "mass_per_length": 0.5, "EI": 3.0,
                       "thickness": 0.01}],
            "joints": [{"motion": HOLD}], **copy.deepcopy(sections)}


def allowed_keys(d: dict[str, Any], where: tuple[Any, ...]) -> tuple[str, ...]:
    """The keys the loader lists for an unknown key in the table at ``where``."""
    table = d
    for step in where:
        table = table[step]
    table[UNKNOWN] = 1.0
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    for message in info.value.problems:
        found = re.search(rf"unknown key '{UNKNOWN}' \(allowed: (.*)\)$", message)
        if found:
            return tuple(found.group(1).split(", "))
    raise AssertionError(f"no unknown-key message in {info.value.problems}")


POINT = {"name": "s", "link": "a", "x": 0.5}
PIEZO = {"name": "s", "link": "a", "kind": "piezo", "x_start": 0.1, "x_end": 0.2,
         "width": 0.01, "E_p": 1e9, "d31": 1e-10, "capacitance": 1e-6}
BASE = {"type": "free", "mass": 1.0, "inertia": 1.0}
SERVO = {"drive": "servo", "reference": HOLD}
JOINT = ("joints", 0)
SEGMENT = ("base", "loads", 0, "moment", 0)


PATCH = {"link": "a", "x_start": 0.1, "x_end": 0.2, "width": 0.01, "E_p": 1e9, "d31": 1e-10}
ACTUATOR = {"name": "p", "kind": "piezo", **PATCH}
SISO = {"name": "c", "sensor": "s", "actuator": "p", "gain": 1.0, "sample_rate": 100.0}
LTI = {"name": "c", "kind": "lti", "inputs": ["s"], "outputs": ["p"], "D": [[1.0]],
       "sample_rate": 100.0}


def _controlled(controller: dict[str, Any]) -> dict[str, Any]:
    return base_scenario(sensors=[PIEZO], actuators=[ACTUATOR], controllers=[controller])


def _loaded(segment: dict[str, Any]) -> dict[str, Any]:
    return base_scenario(base={**BASE, "loads": [{"moment": [segment]}]})


# (the table kind, a scenario with such a table, where it is, the keys the schema gives it)
CASES = [
    ("simulation", base_scenario(), ("simulation",), s.SIMULATION.keys),
    ("links", base_scenario(), ("links", 0), s.LINKS.keys),
    ("links.bodies", base_scenario(links=[{"name": "a", "length": 1.0, "mass_per_length": 0.5,
                                           "EI": 3.0, "bodies": [{"mass": 0.1}]}]),
     ("links", 0, "bodies", 0), s.BODIES.keys),
    # base_point is taken out before the rest of a prescribed joint is checked
    ("joints", base_scenario(), JOINT, ("motion",)),
    *[(name, base_scenario(joints=[{"motion": [
        {"profile": name, **{f.key: 0.1 for f in section.fields}}]}]),
       (*JOINT, "motion", 0), ("profile", *section.keys))
      for name, section in s.PROFILES.items()],
    ("measured_angles", base_scenario(joints=[{"csv": "angles.csv"}]), JOINT,
     s.MEASURED_ANGLES.keys),
    # only a strain gauge takes a thickness
    ("sensors", base_scenario(sensors=[{**POINT, "kind": "deflection"}]), ("sensors", 0),
     (*s.SENSORS.keys, "x")),
    ("point_sensors", base_scenario(sensors=[{**POINT, "kind": "strain"}]), ("sensors", 0),
     s.SENSORS.keys + s.POINT_SENSORS.keys),
    ("piezo", base_scenario(sensors=[PIEZO]), ("sensors", 0), s.SENSORS.keys + s.PIEZO.keys),
    ("base", base_scenario(base=BASE), ("base",), s.BASE.keys),
    ("actuators", base_scenario(actuators=[ACTUATOR]), ("actuators", 0), s.ACTUATORS.keys),
    ("controllers", _controlled({**SISO, "kind": "srf"}), ("controllers", 0),
     s.CONTROLLERS.keys + s.CONTROLLER_SISO.keys),
    ("controller_siso", _controlled({**SISO, "kind": "srf"}), ("controllers", 0),
     s.CONTROLLERS.keys + s.CONTROLLER_SISO.keys),
    ("ppf", _controlled({**SISO, "kind": "ppf", "frequency_hz": 2.0, "damping": 0.3}),
     ("controllers", 0), s.CONTROLLERS.keys + s.CONTROLLER_SISO.keys + s.PPF.keys),
    ("lti", _controlled(LTI), ("controllers", 0), s.CONTROLLERS.keys + s.LTI.keys),
    ("base.loads", _loaded(STEP), ("base", "loads", 0), s.LOADS.keys),
    *[(name, _loaded({"profile": name}), SEGMENT, ("profile", *section.keys))
      for name, section in s.HISTORIES.items()],
    ("history_csv", _loaded({"csv": "x.csv", "column": "u"}), SEGMENT, s.HISTORY_CSV.keys),
    ("torque", base_scenario(joints=[{"drive": "torque", "torque": [STEP]}]), JOINT,
     s.TORQUE.keys),
    ("velocity_pid", base_scenario(joints=[{**SERVO, "servo": "velocity_pid"}]), JOINT,
     s.VELOCITY_PID.keys),
    ("position", base_scenario(joints=[{**SERVO, "servo": "position"}]), JOINT,
     s.POSITION.keys),
    # an elastic joint's keys are taken out before the rest (its motor) is checked
    ("elastic", base_scenario(joints=[{"motion": HOLD, "spring_stiffness": 10.0}]), JOINT,
     ("motion",)),
    ("closures", base_scenario(joints=[{"drive": "free"}],
                               closures=[{"name": "c", "link": "a", "ground": [1.0, 0.0]}]),
     ("closures", 0), s.CLOSURES.keys),
]


@pytest.mark.parametrize(("name", "scenario", "where", "keys"), CASES,
                         ids=[case[0] for case in CASES])
def test_the_loader_accepts_exactly_the_schema_keys(name: str, scenario: dict[str, Any],
                                                    where: tuple[Any, ...],
                                                    keys: tuple[str, ...]) -> None:
    assert allowed_keys(copy.deepcopy(scenario), where) == keys


def test_every_table_kind_of_the_schema_is_checked_above() -> None:
    assert {case[0] for case in CASES} == set(s.SECTIONS)


def test_base_point_is_a_key_of_every_joint() -> None:
    d = base_scenario()
    d["joints"][0]["base_point"] = [0.1, 0.0]
    assert scenario_from_dict(d).base is not None
    assert "base_point" in s.JOINTS.keys and "base_point" in s.TORQUE.keys
    assert "base_point" in s.VELOCITY_PID.keys and "base_point" in s.POSITION.keys


def test_allowed_values_are_the_model_literals() -> None:
    assert s.SIMULATION["method"].choices == get_args(model.MethodName) == model.METHODS
    assert s.SIMULATION["model"].choices == get_args(model.ModelName) == model.MODELS
    assert s.LINKS["mode_shapes"].choices == get_args(model.ModeShapes) == model.MODE_SHAPES
    assert s.BASE["type"].choices == get_args(model.BaseKind) == model.BASE_KINDS
    assert s.LOADS["frame"].choices == model.LOAD_FRAMES
    assert s.SENSORS["kind"].choices == (*get_args(model.PointSensorKind), "piezo")


@pytest.mark.parametrize(("where", "key", "literal"), [
    (("simulation",), "method", model.METHODS),
    (("simulation",), "model", model.MODELS),
    (("links", 0), "mode_shapes", model.MODE_SHAPES),
])
def test_the_loader_offers_the_model_literals(where: tuple[Any, ...], key: str,
                                              literal: tuple[str, ...]) -> None:
    d = base_scenario()
    table = d[where[0]] if len(where) == 1 else d[where[0]][where[1]]
    table[key] = "no-such-value"
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    assert f"one of {', '.join(map(repr, literal))}, got 'no-such-value'" \
        in info.value.problems[0]
    for value in literal:  # and accepts each (the nonlinear model takes prescribed joints)
        table[key] = value
        scenario_from_dict(d)


def test_notes_describe_allowed_values_only() -> None:
    for section in s.SECTIONS.values():
        for f in section.fields:
            allowed = ("true", "false") if f.kind == "boolean" else f.choices or ()
            assert set(f.notes) <= set(allowed), (section.name, f.key)


def test_docs_tables_are_generated_from_the_schema() -> None:
    """docs/scenario.md is up to date: run scripts/generate_scenario_docs.py if this fails."""
    text = DOCS.read_text(encoding="utf-8")
    names = [m.group("name") for m in BLOCK.finditer(text)]
    assert sorted(names) == sorted(BLOCKS), "every block once, and no unknown one"
    assert regenerate(text) == text


def test_every_key_is_in_the_docs() -> None:
    text = DOCS.read_text(encoding="utf-8")
    for section in s.SECTIONS.values():
        for key in section.keys:
            assert f"`{key}`" in text, (section.name, key)
    assert all(f"`{c!r}`".replace("'", '"') in markdown_table("simulation")
               for c in model.METHODS)


def test_the_script_checks_and_rewrites(tmp_path: Path) -> None:
    spec = importlib.util.spec_from_file_location(
        "generate_scenario_docs", ROOT / "scripts" / "generate_scenario_docs.py")
    assert spec is not None and spec.loader is not None
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    copy_ = tmp_path / "scenario.md"
    text = DOCS.read_text(encoding="utf-8")
    drifted = text.replace("| `t_end` | s | required |", "| `t_end` | ms | required |")
    assert drifted != text
    copy_.write_text(drifted, encoding="utf-8")
    assert script.main([str(copy_), "--check"]) == 1
    assert copy_.read_text(encoding="utf-8") == drifted
    assert script.main([str(copy_)]) == 0
    assert copy_.read_text(encoding="utf-8") == text
    assert script.main([str(copy_), "--check"]) == 0
