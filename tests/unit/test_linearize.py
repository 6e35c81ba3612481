"""LinearPlant (names, selection, FRF, files, python-control) and linearize's input checks."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from scipy.io import loadmat

import flexlink
from flexlink.cli import main
from flexlink.control import LinearPlant, linearize
from flexlink.model import Base, Chain, Link, PiezoActuator, Scenario, TorqueDrive, VelocityServo
from flexlink.model.histories import ZERO, Step
from tests.helpers import SmoothStep

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _servo_arm() -> Scenario:
    return flexlink.load_scenario(EXAMPLES / "paper_servo.toml")


def _with_patch(scenario: Scenario) -> Scenario:
    patch = PiezoActuator("patch", 1, 0.01, 0.04, 0.025, 30.33e9, 265e-12, 0.001)
    return dataclasses.replace(scenario, actuators=(patch,))


def test_names_and_units_of_a_servo_arm_plant() -> None:
    plant = linearize(_with_patch(_servo_arm()), at={"joint2": 45})
    assert plant.input_names == ("joint1_reference", "joint1_reference_rate",
                                 "joint2_reference", "patch_voltage")
    assert plant.input_units == ("rad", "rad s-1", "rad", "V")
    assert plant.output_names[:2] == ("link1_tip_acceleration", "link2_tip_deflection")
    assert "joint2_rate" in plant.output_names and "link2_tip_Y" in plant.output_names
    units = dict(zip(plant.output_names, plant.output_units))
    assert units["link1_tip_acceleration"] == "m s-2" and units["joint1_rate"] == "rad s-1"
    assert plant.state_names[:3] == ("joint1_angle", "joint2_angle", "link1_q1")
    assert plant.equilibrium and plant.operating_point["joint2_deg"] == pytest.approx(45)
    assert np.all(plant.poles().real < 0)  # the servo loops hold the arm


def test_prescribed_plant_has_elastic_states_and_voltage_inputs() -> None:
    plant = linearize(_with_patch(flexlink.load_paper_experiment()), at=[0.0, 90.0])
    assert plant.input_names == ("patch_voltage",)
    assert plant.state_names[0] == "link1_q1" and len(plant.state_names) == 16
    assert not linearize(flexlink.load_paper_experiment(), at=1.0).equilibrium
    assert linearize(flexlink.load_paper_experiment(), at=0.2).equilibrium  # still at rest


def test_accelerometer_rows_read_the_state_acceleration() -> None:
    """y_acc = Y_a ẋ-dot: the accelerometer's response to a voltage has a feedthrough and
    is the second derivative of the deflection response at high frequency sign-wise."""
    plant = linearize(_with_patch(flexlink.load_paper_experiment()), at=[0.0, 90.0])
    sub = plant.select(["patch_voltage"], ["link1_tip_acceleration"])
    assert sub.D.shape == (1, 1)
    G = sub.frequency_response([1e5])[0, 0, 0]
    assert G == pytest.approx(sub.D[0, 0], rel=1e-2)  # the high-frequency limit


def test_frequency_response_equals_python_control() -> None:
    control = pytest.importorskip("control")
    plant = linearize(_servo_arm(), at={"joint2": 30})
    f = np.array([0.5, 2.0, 13.0])
    ours = plant.frequency_response(f)
    sys = plant.to_statespace()
    theirs = control.frequency_response(sys, 2 * np.pi * f)
    response = np.asarray(theirs.complex).reshape(ours.shape)
    np.testing.assert_allclose(ours, response, rtol=1e-10, atol=0)
    assert list(sys.input_labels) == list(plant.input_names)
    assert list(sys.output_labels) == list(plant.output_names)
    assert list(sys.state_labels) == list(plant.state_names)


def test_npz_and_mat_round_trip(tmp_path: Path) -> None:
    plant = linearize(_servo_arm(), at=0.3)
    back = LinearPlant.from_npz(plant.to_npz(tmp_path / "p.npz"))
    for name in ("A", "B", "C", "D"):
        np.testing.assert_array_equal(getattr(back, name), getattr(plant, name))
    assert back.input_names == plant.input_names and back.output_units == plant.output_units
    assert back.operating_point == plant.operating_point
    assert back.equilibrium == plant.equilibrium
    mat = loadmat(plant.to_mat(tmp_path / "p.mat"))
    np.testing.assert_array_equal(mat["A"], plant.A)
    assert [str(c[0]) for c in mat["input_names"][:, 0]] == list(plant.input_names)
    assert [str(c[0]) for c in mat["state_names"][:, 0]] == list(plant.state_names)


def test_select_keeps_the_named_rows_and_columns() -> None:
    plant = linearize(_servo_arm(), at=[0, 0])
    sub = plant.select(["joint2_reference"], ["joint2_angle", "link2_tip_deflection"])
    i, j = plant.input_names.index("joint2_reference"), plant.output_names.index("joint2_angle")
    np.testing.assert_array_equal(sub.C[0], plant.C[j])
    np.testing.assert_array_equal(sub.B[:, 0], plant.B[:, i])
    with pytest.raises(ValueError, match="unknown input.*'jointX'.*joint1_reference"):
        plant.select(["jointX"])
    with pytest.raises(ValueError, match="unknown output"):
        linearize(_servo_arm(), at=0.0, outputs=["nope"])


@pytest.mark.parametrize("at, message", [
    ({"joint3": 10}, "unknown key 'joint3'; use joint1, joint2"),
    ({"joint1": "ten"}, "joint1 = 'ten' is not a number"),
    ([1.0], "1 joint angles given, the chain has 2 joints"),
    (9.0, r"at = 9.0 s is outside the run \[0, 3.0\] s"),
    ({"base_x": 1.0}, "'base_x' is not a coordinate of a fixed base"),
])
def test_bad_operating_points_name_the_field(at, message) -> None:
    with pytest.raises(ValueError, match=message):
        linearize(_servo_arm(), at=at)


def test_a_saturated_servo_is_refused() -> None:
    servo = VelocityServo(SmoothStep(0.0, 2.0, 0.0, 0.2), P=50.0, I=0.0, D=0.0, saturation=1.0)
    sc = Scenario(Chain((Link("beam", 1.0, 1.0, 50.0, modes=2),), (servo,)))
    with pytest.raises(ValueError, match="joint 1's servo is saturated"):
        linearize(sc, at=0.1)


def test_pinned_base_plant_inputs_and_rigid_mode() -> None:
    sc = Scenario(Chain((Link("beam", 1.0, 1.0, 50.0, modes=3),), (TorqueDrive(Step(0.0)),)),
                  base=Base("pinned", inertia=0.4))
    plant = linearize(sc, at={"joint1": 10, "base_attitude": 30})
    assert plant.input_names == ("joint1_torque", "base_moment")
    assert plant.state_names[:2] == ("base_attitude", "joint1_angle")
    assert np.sum(np.abs(plant.poles()) < 1e-8) == 4  # two free rigid coordinates
    assert plant.operating_point["base_attitude_deg"] == pytest.approx(30)


def test_python_control_missing_says_how_to_install(monkeypatch) -> None:
    import builtins

    real = builtins.__import__

    def no_control(name, *args, **kwargs):
        if name == "control":
            raise ImportError("no")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_control)
    with pytest.raises(ImportError, match=r"pip install flexlink\[control\]"):
        linearize(_servo_arm(), at=0.0).to_statespace()


def test_linearize_command_writes_the_folder(tmp_path: Path, capsys) -> None:
    out = tmp_path / "plant"
    status = main(["linearize", str(EXAMPLES / "paper_servo.toml"), "--at", "joint2=45",
                   "--bode", "joint2_reference:link2_tip_deflection", "-o", str(out)])
    assert status == 0
    assert {p.name for p in out.iterdir()} >= {"plant.npz", "plant.mat", "modes.csv",
                                               "bode.png", "scenario.resolved.toml"}
    plant = LinearPlant.from_npz(out / "plant.npz")
    assert plant.operating_point["joint2_deg"] == pytest.approx(45)
    assert main(["linearize", str(EXAMPLES / "paper_servo.toml"), "-o", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["linearize", str(EXAMPLES / "paper_servo.toml"), "-o", str(out),
                 "--overwrite", "--at", "0.5", "--no-figures", "-q"]) == 0
    assert not (out / "bode.png").exists()


@pytest.mark.parametrize("args, message", [
    (["--at", "joint9=1"], "unknown key 'joint9'"),
    (["--at", "soon"], "a time in s or jointK=DEG"),
    (["--inputs", "nope"], "unknown input"),
    (["--bode", "joint1_reference"], "is not INPUT:OUTPUT"),
])
def test_linearize_command_input_errors(tmp_path: Path, capsys, args, message) -> None:
    out = tmp_path / "x"
    assert main(["linearize", str(EXAMPLES / "paper_servo.toml"), *args, "-o", str(out)]) == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def _oscillator_plant() -> LinearPlant:
    """x'' + 0.2 x' + 100 x = u; outputs: x, a row of round-off, a row of zeros, u itself."""
    A = np.array([[0.0, 1.0], [-100.0, -0.2]])
    C = np.array([[1.0, 0.0], [1e-33, 3e-34], [0.0, 0.0], [0.0, 0.0]])
    D = np.array([[0.0], [0.0], [0.0], [1.0]])
    return LinearPlant(A, np.array([[0.0], [1.0]]), C, D, ("x", "v"), ("u",),
                       ("x", "noise", "none", "feedthrough"), ("N",), ("m", "m", "m", "N"))


def test_zero_transfers_are_found_and_left_out_of_the_bode_plot(tmp_path: Path) -> None:
    """A closed loop's dependent joint held by its prescribed crank has C rows of round-off:
    the Bode plot drew it at −6000 dB (and its rate at −650 dB), crushing the real curves;
    a flat response was drawn on an axis of 1e-11 dB with an offset."""
    import unittest.mock

    from matplotlib.figure import Figure

    from flexlink.control.command import _pairs
    from flexlink.control.figures import MIN_SPAN_DB, bode_figure

    plant = _oscillator_plant()
    assert plant.zero_transfers(np.logspace(-1, 2, 50))[:, 0].tolist() == [False, True, True,
                                                                           False]
    assert _pairs(None, plant) == [("u", "x"), ("u", "feedthrough")]
    drawn: list[Figure] = []
    with unittest.mock.patch.object(Figure, "savefig", lambda self, *a, **k: drawn.append(self)):
        bode_figure(plant, [("u", "noise"), ("u", "feedthrough")], tmp_path / "b.png")
    magnitude = drawn[0].axes[0]
    assert [line.get_label() for line in magnitude.get_lines() if line.get_xdata().size] \
        == ["u → feedthrough [N/N]"]
    assert "u → noise: zero" in [t.get_text() for t in drawn[0].legends[0].get_texts()]
    low, high = magnitude.get_ylim()
    assert high - low >= MIN_SPAN_DB and low < 0.0 < high  # 0 dB in the middle


def test_a_free_base_s_default_bode_pairs_are_its_actuator_to_the_sensors(
        tmp_path: Path, monkeypatch) -> None:
    """satellite_slew turns its free hub with a moment: the default Bode plot showed
    base_force_x → base_x (a rigid translation, which nothing applies) and the tips' X; the
    moment to the arrays' sensors and the attitude is the plant a user controls."""
    import flexlink.control.figures as control_figures

    drawn: list[list[tuple[str, str]]] = []
    monkeypatch.setattr(control_figures, "bode_figure",
                        lambda plant, pairs, path, *a, **k: drawn.append(list(pairs)))
    assert main(["linearize", str(EXAMPLES / "satellite_slew.toml"), "-q", "-o",
                 str(tmp_path / "sat")]) == 0
    assert drawn == [[("base_moment", "right_root_strain"),
                      ("base_moment", "right_tip_deflection"),
                      ("base_moment", "base_attitude"), ("base_moment", "joint1_torque")]]

    # a force the loads apply comes first; sensors still before the base's pose and the tips
    scenario = flexlink.load_scenario(EXAMPLES / "satellite_slew.toml")
    pushed = dataclasses.replace(scenario, base=dataclasses.replace(
        scenario.base, loads=(dataclasses.replace(scenario.base.loads[0],
                                                  moment=ZERO, force_y=Step(1.0)),)))
    pairs = control_figures.default_pairs(linearize(pushed), pushed)
    assert {u for u, _ in pairs} == {"base_force_y"}
    assert [y for _, y in pairs][:2] == ["right_root_strain", "right_tip_deflection"]


def test_the_linearize_command_names_a_failed_run_and_raises_a_defect(
        tmp_path: Path, capsys, monkeypatch) -> None:
    """A run up to --at that fails is reported (status 1); any other exception is a defect,
    raised rather than printed as a failed linearisation."""
    from flexlink.control import linearization
    from flexlink.errors import SimulationError

    def failing(error: Exception):  # type: ignore[no-untyped-def]
        def linearize(*_: object, **__: object) -> None:
            raise error
        return linearize

    args = ["linearize", str(EXAMPLES / "paper_servo.toml"), "-q", "-o", str(tmp_path / "p")]
    monkeypatch.setattr(linearization, "linearize", failing(SimulationError("it stalled")))
    assert main(args) == 1
    assert capsys.readouterr().err == "linearisation failed: it stalled\n"
    monkeypatch.setattr(linearization, "linearize", failing(IndexError("out of range")))
    with pytest.raises(IndexError, match="out of range"):
        main(args)
    # a TypeError inside was printed as bad input ("error: …", status 2); the command's own
    # input never raises one
    monkeypatch.setattr(linearization, "linearize", failing(TypeError("a defect")))
    with pytest.raises(TypeError, match="a defect"):
        main(args)
