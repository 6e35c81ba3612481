"""Run folders: contents, atomic writing, refusal to clobber, figures."""

from __future__ import annotations

import csv
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

from flexlink.results import plotting
from flexlink.results import writers
from flexlink.results.writers import OutputFolderError, write_run
from flexlink.scenario.toml_writer import dump_toml
from flexlink.channels import Channel, ChannelKind
from flexlink.results import Results
from flexlink.scenario import load_scenario, resolve_scenario_dict, scenario_from_dict


def scenario_dict() -> dict[str, Any]:
    return {
        "simulation": {"name": "unit", "t_end": 0.1, "dt_out": 0.01},
        "links": [{"name": "arm", "length": 0.6, "mass_per_length": 0.06, "EI": 0.16}],
        "joints": [{"motion": [{"profile": "cycloidal", "from_deg": 0.0, "to_deg": 30.0,
                                "start": 0.0, "duration": 0.1}]}],
        "sensors": [{"name": "tip", "kind": "deflection", "link": "arm", "x": 0.6},
                    {"name": "root", "kind": "strain", "link": "arm", "x": 0.0,
                     "thickness": 0.001}],
    }


def fake_results() -> Results:
    """Results shaped like simulate()'s, with simple known values."""
    t = np.linspace(0.0, 0.1, 11)
    beta = np.radians(30.0) * t / 0.1
    results = Results(time=t, metadata={"scenario": "unit"})
    sensor, joint, tip = ChannelKind.SENSOR, ChannelKind.JOINT, ChannelKind.TIP
    results.add(Channel("tip", sensor, "m", "deflection at x = 0.6 m", "deflection", "arm"),
                1e-3 * np.sin(40 * t) + 1.0 / 3.0)
    results.add(Channel("root", sensor, "1", "strain at x = 0.0 m", "strain", "arm"),
                1e-5 * np.cos(40 * t))
    results.add(Channel("joint1_angle", joint, "rad", "joint 1 angle", "angle", "joint1"), beta)
    results.add(Channel("arm_tip_X", tip, "m", "X of the tip of arm", "X", "arm"),
                0.6 * np.cos(beta))
    results.add(Channel("arm_tip_Y", tip, "m", "Y of the tip of arm", "Y", "arm"),
                0.6 * np.sin(beta))
    return results


@pytest.fixture
def resolved() -> dict[str, Any]:
    return resolve_scenario_dict(scenario_dict())


def test_run_folder_contents(tmp_path: Path, resolved: dict[str, Any]) -> None:
    results = fake_results()
    out = write_run(results, tmp_path / "run", resolved)
    assert sorted(p.name for p in out.iterdir()) == [
        "channels.csv", "figures", "results.csv", "results.nc", "scenario.resolved.toml"]
    assert sorted(p.name for p in (out / "figures").iterdir()) == [
        "joint_angles.png", "sensors.png", "tip_paths.png"]
    lines = (out / "results.csv").read_text().splitlines()
    assert lines[0] == "t,tip,root,joint1_angle,arm_tip_X,arm_tip_Y"
    table = np.loadtxt(out / "results.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], results.time, rtol=0, atol=1e-12)
    np.testing.assert_allclose(table[:, 1], results["tip"], rtol=1e-9)
    assert lines[1].split(",")[1] == "0.3333333333"  # '%.10g'
    with (out / "channels.csv").open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["name", "unit", "description"] and rows[1] == ["t", "s", "time"]
    assert rows[2] == ["tip", "m", "deflection at x = 0.6 m"]
    with xr.open_dataset(out / "results.nc", engine="scipy") as ds:
        assert ds["root"].attrs["units"] == "1"
        np.testing.assert_array_equal(ds["tip"].values, results["tip"])
    assert not list(tmp_path.glob(".run.*"))


def test_resolved_scenario_round_trips(tmp_path: Path, resolved: dict[str, Any]) -> None:
    out = write_run(fake_results(), tmp_path / "run", resolved, figures=False)
    saved = out / "scenario.resolved.toml"
    assert tomllib.loads(saved.read_text())["flexlink_version"] == resolved["flexlink_version"]
    assert load_scenario(saved) == scenario_from_dict(scenario_dict())
    assert not (out / "figures").exists()


def test_refuses_a_non_empty_folder(tmp_path: Path, resolved: dict[str, Any]) -> None:
    out = tmp_path / "run"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    with pytest.raises(OutputFolderError, match="already exists and is not empty"):
        write_run(fake_results(), out, resolved)
    with pytest.raises(OutputFolderError, match="does not look like a flexlink results folder"):
        write_run(fake_results(), out, resolved, overwrite=True)
    assert (out / "notes.txt").read_text() == "mine"
    empty = tmp_path / "empty"
    empty.mkdir()
    write_run(fake_results(), empty, resolved, figures=False)
    assert (empty / "results.csv").is_file()


def test_overwrite_replaces_an_earlier_run(tmp_path: Path, resolved: dict[str, Any]) -> None:
    out = write_run(fake_results(), tmp_path / "run", resolved, figures=False)
    (out / "stale.txt").write_text("old")
    write_run(fake_results(), out, resolved, figures=False, overwrite=True)
    assert not (out / "stale.txt").exists() and (out / "results.csv").is_file()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_failure_leaves_no_folder(tmp_path: Path, resolved: dict[str, Any],
                                  monkeypatch: pytest.MonkeyPatch) -> None:
    def broken(*args: object) -> None:
        raise RuntimeError("disk on fire")

    monkeypatch.setattr(writers, "write_figures", broken)
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_run(fake_results(), tmp_path / "run", resolved)
    assert list(tmp_path.iterdir()) == []


def test_netcdf_file_opens_as_the_results_dataset(tmp_path: Path,
                                                  resolved: dict[str, Any]) -> None:
    results = fake_results()
    out = write_run(results, tmp_path / "run", resolved, figures=False)
    with xr.open_dataset(out / "results.nc", engine="scipy") as ds:
        xr.testing.assert_identical(ds.load(), results.to_xarray())


def test_dump_toml_escapes_and_skips_none() -> None:
    data = {"s": 'a "quoted" \\ path\n\x7f', "n": None, "x": [1, 2.5, True],
            "t": {"k y": 1e-10, "none": None}, "arr": [{"a": 1}, {"a": 2}]}
    assert tomllib.loads(dump_toml(data)) == {
        "s": 'a "quoted" \\ path\n\x7f', "x": [1, 2.5, True], "t": {"k y": 1e-10},
        "arr": [{"a": 1}, {"a": 2}]}


def test_figures_are_labelled() -> None:
    results = fake_results()
    angles = plotting.plot_joint_angles(results).axes[0]
    assert angles.get_xlabel() == "time t [s]" and angles.get_ylabel() == "joint angle [deg]"
    assert angles.get_lines()[0].get_ydata()[-1] == pytest.approx(30.0)
    sensors = plotting.plot_sensors(results).axes
    assert [ax.get_ylabel() for ax in sensors] == ["deflection [mm]", "strain [µstrain]"]
    paths = plotting.plot_tip_paths(results).axes[0]
    assert (paths.get_xlabel(), paths.get_ylabel()) == ("X [m]", "Y [m]")
    assert paths.get_aspect() == 1.0
    with pytest.raises(ValueError, match="no sensor channels"):
        plotting.plot_sensors(results, [])
