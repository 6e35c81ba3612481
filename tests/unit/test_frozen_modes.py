"""frozen_modes: its grid and time axes, shapes, dataset, errors, and the modes command."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import flexlink
from flexlink.cli import main
from flexlink.control import frozen_modes, linearize

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_angle_grid_matches_single_linearisations() -> None:
    sc = flexlink.load_paper_experiment()
    modes = frozen_modes(sc, angles={"joint2": [0.0, 45.0, 90.0]}, count=5)
    assert modes.coordinate == "joint2" and modes.frequency_hz.shape == (3, 5)
    np.testing.assert_allclose(modes.configurations[:, 1], [0, 45, 90])
    single = linearize(sc, at={"joint2": 45.0}).modes()
    np.testing.assert_allclose(modes.frequency_hz[1], single[0][:5], rtol=1e-12)
    np.testing.assert_allclose(modes.damping_ratio[1], single[1][:5], rtol=1e-12)
    assert np.all(np.diff(modes.frequency_hz, axis=1) > 0)
    # shapes: real, largest |w| one; the first mode of the paper arm is link 2's
    assert np.allclose(np.abs(modes.shapes).max(axis=(2, 3)), 1.0)
    assert np.abs(modes.shapes[0, 0, 1]).max() == 1.0


def test_shape_is_the_eigenvector_deflection() -> None:
    """A single clamped link: mode j's shape is the j-th cantilever mode itself."""
    from flexlink.model import Chain, Link, Scenario
    from flexlink.modes import modal_data
    from tests.helpers import SmoothStep

    link = Link("beam", 1.3, 2.7, 45.0, modes=4)
    sc = Scenario(Chain((link,), (SmoothStep(0.0, 0.0, 0.0, 1.0),)))
    modes = frozen_modes(sc, angles={"joint1": [0.0]})
    phi = modal_data(link).shapes.evaluate(modes.x[0], 0)
    for j in range(4):
        exact = phi[:, j] / phi[np.argmax(np.abs(phi[:, j])), j]
        np.testing.assert_allclose(modes.shapes[0, j, 0], exact, atol=1e-9)


def test_times_of_a_forward_run_come_from_one_run() -> None:
    sc = flexlink.load_scenario(EXAMPLES / "paper_servo.toml")
    modes = frozen_modes(sc, times=[0.0, 1.0, 2.5], count=4)
    assert modes.coordinate == "time" and modes.unit == "s"
    assert modes.configurations[2, 0] == pytest.approx(90.0, abs=1.0)  # after the move
    again = linearize(sc, at=1.0).modes()[0][:4]
    np.testing.assert_allclose(modes.frequency_hz[1], again, rtol=1e-6)
    ds = modes.to_dataset()
    assert ds["frequency"].dims == ("time", "mode") and ds["frequency"].attrs["units"] == "Hz"


def test_bad_requests() -> None:
    sc = flexlink.load_paper_experiment()
    with pytest.raises(ValueError, match="times or angles, not both"):
        frozen_modes(sc, times=[0.0], angles={"joint2": [0.0]})
    with pytest.raises(ValueError, match="same, non-zero length"):
        frozen_modes(sc, angles={"joint1": [0.0], "joint2": [0.0, 1.0]})
    with pytest.raises(ValueError, match="unknown key 'joint5'"):
        frozen_modes(sc, angles={"joint5": [0.0]})
    with pytest.raises(ValueError, match="outside the run"):
        frozen_modes(sc, times=[0.0, 99.0])


def test_modes_command(tmp_path: Path, capsys) -> None:
    out = tmp_path / "m"
    assert main(["modes", "--grid", "joint2=0:90:30", "-o", str(out)]) == 0
    assert {p.name for p in out.iterdir()} >= {"frequencies.csv", "modes.npz",
                                               "frequencies.png", "shapes.png"}
    table = np.loadtxt(out / "frequencies.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], [0, 30, 60, 90])
    assert (out / "frequencies.csv").read_text().startswith("joint2_deg,f1_Hz")
    with np.load(out / "modes.npz") as data:
        assert data["shapes"].shape[:2] == (4, 8)
        # every array's dimensions named and its unit given, as a results.mat's variables
        variables = json.loads(str(data["variables"]))
        arrays = {name: data[name] for name in variables}
    assert variables["shapes"]["dims"] == ["joint2", "mode", "link", "point"]
    assert variables["frequency_hz"]["dims"] == ["joint2", "mode"]
    assert variables["frequency_hz"]["units"] == "Hz"
    assert variables["x"]["units"] == "m" and variables["values"]["units"] == "deg"
    sizes = {d: n for name, meta in variables.items()
             for d, n in zip(meta["dims"], arrays[name].shape, strict=True)}
    for name, meta in variables.items():  # one size per dimension name
        assert [sizes[d] for d in meta["dims"]] == list(arrays[name].shape), name
    assert main(["modes", "--times", "0:1:0.5", "--no-figures", "-o", str(tmp_path / "t")]) == 0
    assert main(["modes", "--grid", "joint2=0:90", "-o", str(tmp_path / "bad")]) == 2
    assert "START:STOP:STEP" in capsys.readouterr().err
    assert main(["modes", "--times", "1", "--grid", "joint2=0", "-o", str(tmp_path / "b")]) == 2


def test_a_grid_over_a_closed_loop_s_dependent_joint_is_refused() -> None:
    """--grid joint2=0:90:30 on the four-bar: joint2 follows from the crank, each grid value
    only a guess the loop closes from; the command wrote four identical rows labelled
    0, 30, 60, 90°. The crank's own grid is a grid of configurations."""
    scenario = flexlink.load_scenario(EXAMPLES / "four_bar.toml")
    with pytest.raises(ValueError, match=r"joint2 is a dependent joint of the closed loop, "
                                         r"whose angles follow from joint1: .* grid joint1"):
        frozen_modes(scenario, angles={"joint2": [0.0, 30.0]})
    modes = frozen_modes(scenario, angles={"joint1": [60.0, 120.0]})
    np.testing.assert_allclose(modes.configurations[:, 0], [60.0, 120.0])
    guessed = frozen_modes(scenario, angles={"joint1": [60.0, 120.0], "joint2": [0.0, 0.0]})
    np.testing.assert_allclose(guessed.configurations[:, 0], [60.0, 120.0])
