"""Scenario keys of the forward dynamics: [base], driven joints, histories, the examples."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import flexlink
from flexlink.model import BangBang, PositionServo, Sum, Table, TorqueDrive, VelocityServo
from flexlink.scenario import ScenarioError, scenario_from_dict
from flexlink.scenario.load import resolve_scenario_dict

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
LINK = {"name": "arm", "length": 1.0, "mass_per_length": 1.0, "EI": 10.0, "modes": 2}


def _scenario(**extra):
    d = {"simulation": {"t_end": 0.2, "dt_out": 0.01}, "links": [dict(LINK)],
         "joints": [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 1.0}]}]}
    d.update(extra)
    return d


def test_torque_drive_and_free_base_are_built() -> None:
    d = _scenario(base={"type": "free", "mass": 10.0, "inertia": 2.0, "rate_deg_s": 90.0,
                        "loads": [{"moment": [{"profile": "bang_bang", "amplitude": 2.0,
                                               "duration": 4.0},
                                              {"profile": "table", "t": [0, 1],
                                               "values": [0, 1]}],
                                   "force_x": [{"profile": "step", "amplitude": 1.0}],
                                   "point": [0.1, 0.0], "frame": "body"}]})
    sc = scenario_from_dict(d)
    assert isinstance(sc.chain.joints[0], TorqueDrive)
    assert sc.base is not None and sc.base.kind == "free"
    assert math.isclose(sc.base.rate, math.pi / 2)
    load = sc.base.loads[0]
    assert isinstance(load.moment, Sum) and isinstance(load.moment.parts[0], BangBang)
    np.testing.assert_allclose(load.moment.value(np.array([0.5, 3.0])), [2.5, -1.0])


def test_servo_keys() -> None:
    ref = [{"profile": "cycloidal", "from_deg": 0, "to_deg": 90, "start": 0, "duration": 1}]
    d = _scenario(joints=[{"drive": "servo", "servo": "velocity_pid", "P": 5.0, "D": 0.005,
                           "rate_per_volt_deg_s": 180.0, "reference": ref}])
    joint = scenario_from_dict(d).chain.joints[0]
    assert isinstance(joint, VelocityServo)
    assert (joint.P, joint.I, joint.D, joint.saturation) == (5.0, 0.0, 0.005, 10.0)
    assert math.isclose(joint.rate_per_volt, math.pi)
    d = _scenario(joints=[{"drive": "servo", "servo": "position", "bandwidth": 30.0,
                           "rate_limit_deg_s": 500.0, "reference": ref}])
    assert isinstance(scenario_from_dict(d).chain.joints[0], PositionServo)


@pytest.mark.parametrize("change, message", [
    ({"base": {"type": "free", "inertia": 1.0}}, "base: missing required key 'mass'"),
    ({"base": {"type": "flying", "mass": 1.0}}, "base.type must be one of"),
    ({"base": {"type": "pinned", "inertia": 1.0, "velocity": [1, 0]}}, "pinned base"),
    ({"base": {"type": "free", "mass": 1.0, "inertia": 1.0, "loads": [{"point": [0, 0]}]}},
     "give at least one of force_x"),
    ({"base": {"type": "free", "mass": 1.0, "inertia": 1.0,
               "loads": [{"moment": [{"profile": "bang_bang", "amplitude": 1.0}]}]}},
     "base.loads[0].moment[0]: missing required key 'duration'"),
    ({"joints": [{"drive": "torque"}]}, "needs 'torque'"),
    ({"joints": [{"drive": "servo", "servo": "velocity_pid", "P": 5.0,
                  "reference": [{"profile": "hold", "angle_deg": 0}]}]},
     "missing required key 'rate_per_volt_deg_s'"),
    ({"joints": [{"drive": "servo", "servo": "position", "bandwidth": 3.0,
                  "rate_limit_deg_s": 10.0}]}, "needs 'reference'"),
    ({"joints": [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 1.0}],
                  "P": 1.0}]}, "unknown key 'P'"),
    ({"joints": [{"drive": "motor"}]}, "joints[0].drive must be one of"),
    ({"joints": [{"drive": "torque", "torque": [{"csv": "nope.csv", "column": "x"}]}]},
     "file not found"),
    ({"joints": [{"motion": [{"profile": "hold", "angle_deg": 0}], "base_point": [1]}]},
     "base_point: expected two numbers"),
])
def test_bad_keys_are_reported_with_the_field(change, message) -> None:
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(_scenario(**change))
    assert message in str(info.value)


def test_torque_history_from_a_results_csv(tmp_path: Path) -> None:
    (tmp_path / "results.csv").write_text("t,joint1_torque\n0,0\n1,2\n")
    d = _scenario(joints=[{"drive": "torque", "torque": [
        {"csv": "results.csv", "column": "joint1_torque"}]}])
    joint = scenario_from_dict(d, base_dir=tmp_path).chain.joints[0]
    assert isinstance(joint.torque, Table)
    np.testing.assert_allclose(joint.torque.value(np.array([0.5, 3.0])), [1.0, 2.0])


@pytest.mark.parametrize("name", ["satellite_slew.toml", "paper_servo.toml",
                                  "vertical_arm.toml", "flexible_joint_arm.toml"])
def test_example_resolves_round_trips_and_runs_shortened(name: str) -> None:
    """The shipped examples load, their resolved form loads to the same model, and a
    shortened run gives finite output with the forward channels."""
    resolved = resolve_scenario_dict(EXAMPLES / name)
    from flexlink.scenario.toml_writer import dump_toml

    again = scenario_from_dict(tomllib.loads(dump_toml(resolved)))
    scenario = flexlink.load_scenario(EXAMPLES / name)
    assert again.base == scenario.base
    raw = tomllib.loads((EXAMPLES / name).read_text())
    raw["simulation"].update(t_end=2.0 if "slew" in name else 0.6)
    results = flexlink.simulate(scenario_from_dict(raw, base_dir=EXAMPLES))
    frame = results.to_pandas()
    assert np.isfinite(frame.to_numpy()).all()
    if "vertical" in name:  # starts in equilibrium: at rest, its weight's moment held
        link = scenario.chain.links[0]
        moment = (link.mass_per_length * link.length**2 / 2 + link.tip_mass * link.length) * 9.81
        assert frame["joint1_torque"].iloc[0] == pytest.approx(moment, rel=1e-9)
        assert frame["arm_tip_Y"].iloc[0] < 0.0 and frame["joint1_angle"].iloc[-1] > 0.0
    elif "flexible_joint" in name:  # the servo turns the motor, the spring the link
        assert {"joint1_motor_angle", "joint1_motor_rate", "joint1_spring_torque",
                "joint1_command"} <= set(frame.columns)
        assert frame["joint1_motor_angle"].iloc[-1] > 0.0 and frame["joint1_angle"].iloc[-1] > 0.0
    elif "servo" in name:
        assert {"joint1_command", "joint1_reference", "joint2_rate"} <= set(frame.columns)
        assert frame["joint1_angle"].iloc[-1] > 0.0  # the arm has started to move
    else:
        assert {"base_attitude", "base_x", "angular_momentum"} <= set(frame.columns)
        assert frame["base_attitude"].iloc[-1] > 0.0  # the slew has started


def test_simulate_runs_the_nonlinear_model_with_a_driven_joint() -> None:
    """Regression: simulate() used to branch to the first-order forward dynamics and ignore
    model = "nonlinear" silently; it now takes the nonlinear forward path (Gauss)."""
    d = _scenario()
    d["simulation"]["model"] = "nonlinear"
    results = flexlink.simulate(scenario_from_dict(d))
    assert results.metadata["method"] == "gauss"
    assert results["joint1_angle"][-1] > 0.0  # the step torque turned the joint


def test_a_free_base_of_zero_mass_is_the_first_link_itself() -> None:
    d = _scenario(base={"type": "free", "mass": 0.0, "inertia": 0.0})
    d["joints"] = [{"motion": [{"profile": "hold", "angle_deg": 0.0}]}]
    base = scenario_from_dict(d).base
    assert base is not None and (base.mass, base.inertia) == (0.0, 0.0)
    d["base"]["mass"] = -1.0
    with pytest.raises(ScenarioError, match="base.mass"):
        scenario_from_dict(d)
