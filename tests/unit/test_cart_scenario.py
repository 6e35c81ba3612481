"""The scenario keys of a cart ([base] type = "cart", [base.cart]): read, built, resolved,
and bad input refused before anything runs, naming the field."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from flexlink.model import PositionServo, TorqueDrive, VelocityServo
from flexlink.scenario import ScenarioError, load_scenario, scenario_from_dict
from flexlink.scenario.load import resolve_scenario_dict

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "cart_beam.toml"


def _dict(cart: dict, **base) -> dict:
    return {"simulation": {"t_end": 2.0, "dt_out": 0.01},
            "links": [{"name": "beam", "length": 1.0, "mass_per_length": 1.0, "EI": 10.0}],
            "joints": [{"motion": [{"profile": "hold", "angle_deg": -90.0}]}],
            "base": {"type": "cart", "mass": 2.0, **base, "cart": cart}}


def test_the_example_reads() -> None:
    scenario = load_scenario(EXAMPLE)
    cart = scenario.base.cart
    assert scenario.base.kind == "cart" and cart.travel == (-0.5, 0.5)
    assert isinstance(cart.drive, TorqueDrive)
    assert cart.drive.torque.value(np.array([0.25, 0.75])) == pytest.approx([4.0, -4.0])


def test_prescribed_travel_in_metres() -> None:
    d = _dict({"drive": "prescribed", "rail_angle_deg": 30.0, "motion": [
        {"profile": "cycloidal", "from": 0.1, "to": 0.4, "start": 0.5, "duration": 1.0}]})
    cart = scenario_from_dict(d).base.cart
    assert cart.rail_angle == pytest.approx(math.radians(30.0))
    s, v, _ = cart.drive.evaluate(np.array([0.0, 1.0, 2.0]))
    np.testing.assert_allclose(s, [0.1, 0.25, 0.4], atol=1e-14)
    assert v[1] == pytest.approx(0.6)  # the cycloid's peak rate 2Δ/T
    resolved = resolve_scenario_dict(d)
    assert resolved["base"]["cart"]["motion"][0]["to"] == 0.4
    assert "travel" not in resolved["base"]["cart"]  # unlimited: absent, as every unset key


@pytest.mark.parametrize("servo, cls", [("position", PositionServo),
                                        ("velocity_pid", VelocityServo)])
def test_servo_carts(servo: str, cls: type) -> None:
    own = ({"bandwidth": 20.0, "rate_limit": 0.5} if servo == "position"
           else {"P": 30.0, "D": 1.0, "rate_per_volt": 0.1})
    d = _dict({"drive": "servo", "servo": servo, "loop_gain": 50.0, "force_limit": 20.0,
               "reference": [{"profile": "hold", "position": 0.2}], **own})
    drive = scenario_from_dict(d).base.cart.drive
    assert isinstance(drive, cls) and drive.torque_limit == 20.0
    assert drive.reference.evaluate(np.array([1.0]))[0][0] == pytest.approx(0.2)


@pytest.mark.parametrize("cart, base, message", [
    ({"drive": "prescribed", "travel": [-0.2, 0.2], "motion": [
        {"profile": "cycloidal", "from": 0.0, "to": 0.3, "start": 0.5, "duration": 1.0}]}, {},
     r"base\.cart\.motion: .*base\.cart\.travel.*reaches s = 0\.3 m"),
    ({"drive": "force", "initial_position": 0.5, "travel": [-0.2, 0.2],
      "force": [{"profile": "step", "amplitude": 1.0}]}, {}, r"starts at s = 0\.5 m"),
    ({"drive": "servo", "servo": "position", "bandwidth": 20.0, "rate_limit": 0.5,
      "loop_gain": 50.0, "travel": [-0.2, 0.2], "reference": [
          {"profile": "quintic", "from": 0.0, "to": -0.25, "start": 0.1, "duration": 0.5}]}, {},
     r"base\.cart\.reference: the cart servo's reference leaves .* reaches s = -0\.25 m"),
    ({"travel": [0.2, -0.2]}, {}, r"base\.cart\.travel: need lower < upper"),
    ({"drive": "force"}, {}, r"base\.cart: drive = \"force\" needs 'force'"),
    ({"drive": "prescribed"}, {}, r"base\.cart: drive = 'prescribed' needs 'motion'"),
    ({"drive": "servo", "servo": "position", "reference": [{"profile": "hold", "position": 0}],
      "loop_gain": 5.0}, {}, r"base\.cart.*bandwidth"),
    ({"drive": "free", "force": [{"profile": "step", "amplitude": 1.0}]}, {},
     r"base\.cart.*unknown key 'force'"),
    ({"drive": "sideways"}, {}, r"base\.cart\.drive"),
    ({}, {"velocity": [1.0, 0.0]}, r"base: a cart moves along its rail only"),
    ({}, {"inertia": 1.0}, r"base: a cart moves along its rail only"),
])
def test_bad_input_is_refused_naming_the_field(cart: dict, base: dict, message: str) -> None:
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(_dict(cart, **base))


def test_a_cart_needs_its_table_and_its_mass() -> None:
    d = _dict({})
    del d["base"]["cart"], d["base"]["mass"]
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    text = str(info.value)
    assert "[base.cart]" in text and "missing required key 'mass'" in text
    d = _dict({})
    d["base"]["type"] = "free"
    d["base"]["inertia"] = 1.0
    with pytest.raises(ScenarioError, match="only a base with type = \"cart\""):
        scenario_from_dict(d)


def test_sweep_and_fit_paths_reach_the_cart_keys() -> None:
    """Field paths address the cart's keys like any other (sweeps, fits): its force, its
    mass, its rail angle."""
    from flexlink.scenario.fields import ScenarioFile, parse, resolve

    file = ScenarioFile.read(EXAMPLE)
    values = {resolve(file.raw, parse(text)): value for text, value in (
        ("base.cart.force[0].amplitude", 6.0), ("base.mass", 3.0),
        ("base.cart.rail_angle_deg", 10.0))}
    scenario = file.build(values)
    assert scenario.base.mass == 3.0
    assert scenario.base.cart.rail_angle == pytest.approx(math.radians(10.0))
    assert scenario.base.cart.drive.torque.value(np.array([0.1]))[0] == pytest.approx(6.0)


_FORCE = ('drive = "force"\nforce = [{ profile = "bang_bang", amplitude = 4.0, start = 0.0, '
          'duration = 1.0 }]')
_TOO_FAR = ('drive = "prescribed"\nmotion = [{ profile = "cycloidal", from = 0.0, to = 0.8, '
            'start = 0.0, duration = 1.0 }]')


@pytest.mark.parametrize("edit, status, expected", [
    # refused when read: nothing runs, nothing is written
    ((_FORCE, _TOO_FAR), 2,
     "base.cart.motion: the prescribed cart travel leaves its travel [-0.5, 0.5] m"),
    # a driven run that leaves its travel: an error naming the time, no results folder
    (("amplitude = 4.0", "amplitude = 40.0"), 1, "the cart left its travel [-0.5, 0.5] m"),
])
def test_the_command_refuses_a_cart_outside_its_travel(
        edit: tuple[str, str], status: int, expected: str, tmp_path: Path,
        capsys: pytest.CaptureFixture[str]) -> None:
    from flexlink.cli import main

    text = EXAMPLE.read_text().replace(*edit)
    assert text != EXAMPLE.read_text()
    scenario = tmp_path / "cart.toml"
    scenario.write_text(text)
    out = tmp_path / "out"
    code = main(["run", str(scenario), "-o", str(out), "-q", "--no-figures"])
    err = capsys.readouterr().err
    assert code == status, err
    assert expected in err and "Traceback" not in err
    assert not out.exists() or list(out.iterdir()) == []


def test_an_elastic_joint_on_a_cart_is_read() -> None:
    """The motor is one more rigid coordinate after the cart's travel
    (tests/validation/test_cart_elastic_joints.py checks the physics)."""
    from flexlink.model import ElasticJoint

    d = _dict({"drive": "free"})
    d["joints"] = [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.1}],
                    "motor_inertia": 1e-3, "spring_stiffness": 50.0}]
    scenario = scenario_from_dict(d)
    assert isinstance(scenario.chain.joints[0], ElasticJoint)
    assert scenario.base is not None and scenario.base.kind == "cart"


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_a_run_with_nothing_to_integrate_runs(model: str) -> None:
    """A prescribed cart carrying a rigid link: every coordinate is known (the integrator
    once divided by zero on the empty state). The rail's force is then the whole mass times
    the cart's acceleration."""
    from flexlink import simulate

    d = _dict({"drive": "prescribed", "motion": [
        {"profile": "cycloidal", "from": 0.0, "to": 0.3, "start": 0.2, "duration": 1.0}]})
    d["simulation"]["model"] = model
    d["links"] = [{"name": "beam", "length": 1.0, "mass_per_length": 1.0, "rigid": True,
                   "tip_mass": 0.5}]
    scenario = scenario_from_dict(d)
    results = simulate(scenario, shapes=False)
    t = results.time
    _, _, acceleration = scenario.base.cart.drive.evaluate(t)
    force = results["cart_force"]
    total = 2.0 + 1.0 + 0.5  # cart, link, tip mass (kg)
    np.testing.assert_allclose(force, total * acceleration, atol=1e-9 * np.abs(force).max())
