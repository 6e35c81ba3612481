"""Run folders: contents, atomic writing, refusal to clobber, figures."""

from __future__ import annotations

import csv
import tomllib
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

from flexlink.channels import Channel, ChannelKind
from flexlink.results import Results, plotting, writers
from flexlink.results.folder import WRITTEN_NAMES
from flexlink.results.writers import OutputFolderError, write_run
from flexlink.scenario import load_scenario, resolve_scenario_dict, scenario_from_dict
from flexlink.scenario.toml_writer import dump_toml


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
    results = Results(time=t, metadata={"scenario": "unit", "flexlink_version": "9.9",
                                        "model": "first_order", "geometric_stiffening": True,
                                        "table_blocks": 3, "wall_time_s": 0.125})
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
        "channels.csv", "figures", "report.html", "results.csv", "results.mat", "results.nc",
        "scenario.resolved.toml"]
    assert sorted(p.name for p in (out / "figures").iterdir()) == [
        "joint_angles.png", "sensors.png", "tip_paths.png"]
    page = (out / "report.html").read_text(encoding="utf-8")
    # regression: the page named the hidden folder it was written in (.run.partial-…)
    assert "<td>run</td>" in page and "partial" not in page
    lines = (out / "results.csv").read_text().splitlines()
    assert lines[0] == "t,tip,root,joint1_angle,arm_tip_X,arm_tip_Y"
    table = np.loadtxt(out / "results.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(table[:, 0], results.time, rtol=0, atol=1e-12)
    np.testing.assert_allclose(table[:, 1], results["tip"], rtol=1e-9)
    assert lines[1].split(",")[1] == "0.3333333333"  # '%.10g'
    with (out / "channels.csv").open() as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["name", "unit", "kind", "quantity", "subject", "description"]
    assert rows[1] == ["t", "s", "", "", "", "time"]
    assert rows[2] == ["tip", "m", "sensor", "deflection", "arm", "deflection at x = 0.6 m"]
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
    out = write_run(fake_results(), tmp_path / "run", resolved, report=False)
    (out / "results.csv").write_text("old")
    (out / "figures" / "Thumbs.db").write_text("a file browser's")
    (out / "animation.mp4").write_text("flexlink animate's video of the run")
    write_run(fake_results(), out, resolved, figures=False, overwrite=True)
    assert (out / "results.csv").read_text() != "old" and not (out / "figures").exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


@pytest.mark.parametrize("mine", ["notes.txt", "figures/sketch.jpg", "data/raw.csv"])
def test_overwrite_refuses_a_run_folder_holding_a_file_of_the_user(
        tmp_path: Path, resolved: dict[str, Any], mine: str) -> None:
    """--overwrite deleted every file in an earlier run folder, the user's own included; it
    now replaces only a folder holding nothing but what flexlink writes, and names the rest."""
    out = write_run(fake_results(), tmp_path / "run", resolved)
    (out / mine).parent.mkdir(exist_ok=True)
    (out / mine).write_text("mine")
    with pytest.raises(OutputFolderError, match=f"did not write \\({mine.split('/')[0]}"):
        write_run(fake_results(), out, resolved, figures=False, overwrite=True)
    assert (out / mine).read_text() == "mine" and (out / "figures").is_dir()


def test_every_file_a_command_writes_is_known_to_overwrite() -> None:
    from flexlink.control import command

    names = [command.PLANT_NPZ, command.PLANT_MAT, command.BODE_PNG, command.POLES_CSV,
             command.MODES_CSV, command.MODES_NPZ, command.FREQUENCY_PNG, command.SHAPES_PNG]
    assert set(names) <= WRITTEN_NAMES


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


def forward_results() -> Results:
    """`fake_results` with the channels of a forward run: base pose, joint rate, momentum."""
    results = fake_results()
    t = results.time
    base, joint = ChannelKind.BASE, ChannelKind.JOINT
    results.add(Channel("base_x", base, "m", "base x", "x", "base"), 0.1 * t)
    results.add(Channel("joint1_rate", joint, "rad s-1", "rate of joint 1", "rate", "joint1"),
                np.ones_like(t))
    results.add(Channel("angular_momentum", ChannelKind.MOMENTUM, "N m s", "angular momentum",
                        "angular_momentum", "system"), np.zeros_like(t))
    return results


def test_the_sensor_figure_shows_channels_of_kind_sensor_only(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    drawn: list[list[str]] = []
    plot_channels = plotting.plot_channels

    def spy(results: Results, names: list[str]):
        drawn.append(list(names))
        return plot_channels(results, names)

    monkeypatch.setattr(plotting, "plot_channels", spy)
    paths = writers.write_figures(forward_results(), tmp_path / "figures")
    assert [p.name for p in paths] == ["joint_angles.png", "sensors.png", "tip_paths.png",
                                       "base.png"]
    # sensors.png: no base_x, joint1_rate, angular_momentum; base.png: the base's pose only
    assert drawn == [["tip", "root"], ["base_x"]]
    titles = [ax.get_title(loc="left") for ax in forward_results().plot().axes]
    assert [t.split(" — ")[0] for t in titles] == ["tip", "root"]


def test_results_plot_repr_and_html() -> None:
    results = forward_results()
    base = results.plot("base").axes
    assert [ax.get_title(loc="left").split(" — ")[0] for ax in base] == ["base_x"]
    assert base[0].get_ylabel() == "x [mm]"
    assert results.plot("joint").axes[0].get_ylabel() == "joint angle [deg]"
    assert results.plot(ChannelKind.TIP).axes[0].get_xlabel() == "X [m]"
    with pytest.raises(ValueError, match="no channels of kind 'controller'"):
        results.plot("controller")
    with pytest.raises(ValueError, match="unknown channel kind 'sensors'; kinds: 'sensor'"):
        results.plot("sensors")
    assert repr(results) == ("<Results 'unit' first_order: t = 0 … 0.1 s, 11 samples; "
                             "sensor 2, joint 2, tip 2, base 1, momentum 1>")
    html = results._repr_html_()
    assert html.count("<tr>") == 1 + len(results.names)
    assert "<td>root</td><td>sensor</td><td>1</td><td>1e-05</td>" in html
    assert repr(Results(time=np.zeros(0))) == "<Results no samples; no channels>"


def test_netcdf_layout_attributes(tmp_path: Path, resolved: dict[str, Any]) -> None:
    results = fake_results()
    out = write_run(results, tmp_path / "run", resolved, figures=False)
    with xr.open_dataset(out / "results.nc", engine="scipy") as ds:
        attrs = ds.attrs
        assert attrs["Conventions"] == "CF-1.8" and attrs["source"] == "flexlink 9.9"
        assert "Choi and M. K. Kwak (2016)" in attrs["references"]
        assert attrs["history"].startswith(f"{results.created} flexlink 9.9: simulate")
        assert attrs["date_created"] == results.created
        # numbers stay numbers; netCDF-3 has no bool: 1/0, named in boolean_attributes
        assert attrs["table_blocks"] == 3 and attrs["wall_time_s"] == 0.125
        assert attrs["geometric_stiffening"] == 1
        assert attrs["boolean_attributes"] == "geometric_stiffening"
        assert ds.time.attrs["units"] == "s"
        assert ds.tip.attrs == {"units": "m", "long_name": "deflection at x = 0.6 m",
                                "kind": "sensor", "quantity": "deflection", "subject": "arm"}
        assert "_FillValue" not in ds.tip.encoding  # a run's values all exist


def test_mat_file_holds_values_units_and_kinds(tmp_path: Path,
                                               resolved: dict[str, Any]) -> None:
    from scipy.io import loadmat

    results = fake_results()
    out = write_run(results, tmp_path / "run", resolved, figures=False)
    mat = loadmat(out / "results.mat", simplify_cells=True)
    np.testing.assert_array_equal(mat["t"], results.time)
    for name in results.names:
        np.testing.assert_array_equal(mat[name], results[name])
    table = {v["name"]: v for v in mat["variables"]}
    assert table["time"]["matlab_name"] == "t" and table["time"]["units"] == "s"
    assert (table["root"]["units"], table["root"]["kind"]) == ("1", "sensor")
    assert table["joint1_angle"]["long_name"] == "joint 1 angle"
    assert mat["attributes"]["geometric_stiffening"] == 1
    assert mat["attributes"]["Conventions"] == "CF-1.8"


def test_matlab_names_are_valid_unique_and_recorded() -> None:
    from flexlink.results.matlab import matlab_names

    names = matlab_names(["links[0].EI", "1st", "end", "a-b", "a_b", "x" * 70, "tip"],
                         taken=["t"])
    assert names == {"links[0].EI": "links_0_EI", "1st": "x1st", "end": "end_", "a-b": "a_b",
                     "a_b": "a_b_2", "x" * 70: "x" * 63, "tip": "tip"}
    assert matlab_names(["t"], taken=["t"]) == {"t": "t_2"}


def test_read_run_from_netcdf_and_from_csv(tmp_path: Path, resolved: dict[str, Any]) -> None:
    from flexlink.results import read_run

    results = forward_results()
    out = write_run(results, tmp_path / "run", resolved, figures=False)
    read = read_run(out)
    assert read.channels == results.channels and read.metadata == results.metadata
    assert read.metadata["geometric_stiffening"] is True and read.created == results.created
    for name in results.names:
        np.testing.assert_array_equal(read[name], results[name])
    (out / "results.nc").unlink()
    from_csv = read_run(out)  # CSV + channels.csv: 10 significant digits, no metadata
    assert from_csv.channels == results.channels and from_csv.metadata == {}
    for name in results.names:
        np.testing.assert_allclose(from_csv[name], results[name], rtol=1e-9, atol=1e-15)


def test_read_run_names_the_folder_and_the_missing_files(tmp_path: Path) -> None:
    from flexlink.results import read_run
    from flexlink.results.reading import NotARunFolderError

    with pytest.raises(NotARunFolderError, match=r"nowhere is not a flexlink run folder: no "
                                                 "such folder"):
        read_run(tmp_path / "nowhere")
    (tmp_path / "results.csv").write_text("t\n0\n")
    with pytest.raises(NotARunFolderError, match=rf"{tmp_path} is not a flexlink run folder: "
                                                 "it has no results.nc and no channels.csv"):
        read_run(tmp_path)
    assert issubclass(NotARunFolderError, FileNotFoundError)


def test_figures_name_scenario_model_and_link() -> None:
    results = forward_results()
    results.metadata.update(scenario="unit", model="first_order", geometric_stiffening=True,
                            path="forward", method="DOP853")
    fig = results.plot()
    assert [t.get_text() for t in fig.texts] == [
        "scenario 'unit' · first-order, stiffened model · forward dynamics · DOP853"]
    assert fig.axes[0].get_title(loc="left") == "tip — deflection at x = 0.6 m (on arm)"


def test_torques_of_different_size_get_panels_of_their_own() -> None:
    t = np.linspace(0.0, 1.0, 11)
    results = Results(time=t)
    for k, scale in ((1, 8.0), (2, 0.1)):
        results.add(Channel(f"joint{k}_angle", ChannelKind.JOINT, "rad", "", "angle",
                            f"joint{k}"), t)
        results.add(Channel(f"joint{k}_torque", ChannelKind.JOINT, "N m", "", "torque",
                            f"joint{k}"), scale * np.sin(t))
    assert len(results.plot("joint").axes) == 3  # angles, τ1, τ2
    alike = Results(time=t)
    for k in (1, 2):
        alike.add(results.channels[f"joint{k}_angle"], t)
        alike.add(results.channels[f"joint{k}_torque"], np.sin(t))
    axes = alike.plot("joint").axes
    assert len(axes) == 2  # one shared torque panel, the equal curves in different styles
    assert [ln.get_linestyle() for ln in axes[1].get_lines()] == ["-", "--"]


def test_results_csv_is_what_savetxt_writes(tmp_path: Path) -> None:
    """Byte for byte np.savetxt's text, over several chunks, values of many magnitudes."""
    results = fake_results()
    t = np.linspace(0.0, 1.0, 2 * writers.CSV_ROWS_PER_CHUNK + 7)
    wide = Results(time=t)
    for k, channel in enumerate(results.channels.values()):
        values = np.sin((k + 1) * 7.0 * t) * 10.0 ** (3 * k - 6)
        values[k] = (0.0, -0.0, 1e300, -5e-324, 123456789012.0)[k % 5]
        wide.add(channel, values)
    writers.write_results_csv(wide, tmp_path / "fast.csv")
    table = np.column_stack([t, *(wide[n] for n in wide.names)])
    np.savetxt(tmp_path / "savetxt.csv", table, fmt=writers.CSV_FORMAT, delimiter=",",
               header=",".join(["t", *wide.names]), comments="")
    assert (tmp_path / "fast.csv").read_bytes() == (tmp_path / "savetxt.csv").read_bytes()


def test_the_streaming_netcdf_writer_writes_the_bytes_scipy_writes(tmp_path: Path) -> None:
    """Each variable is written from the caller's array in big-endian slices (no copy of a
    sweep's channels held until the file closes); the file is byte for byte what scipy's
    own writer makes of the same variables, a slice boundary inside a variable included."""
    from scipy.io import netcdf_file

    from flexlink.results import netcdf
    from flexlink.results.variables import Layout, Variable

    rng = np.random.default_rng(3)
    layout = Layout(
        {"case": Variable(("case",), np.arange(3, dtype=np.int32), {"units": "1"}),
         "time": Variable(("time",), np.linspace(0.0, 1.0, 7), {"units": "s"})},
        {"tip": Variable(("case", "time"), rng.normal(size=(3, 7)), {"units": "m"},
                         missing=True),
         "shape": Variable(("case",), np.float32([1.5, 2.5, -3.0]), {}),
         "status": Variable(("case",), np.array(["ok", "failed", "ok"]), {"long_name": "é"})},
        {"title": "t", "count": 3, "scale": 0.5})
    streamed = tmp_path / "streamed.nc"
    reference = tmp_path / "reference.nc"
    original_slice = netcdf._WRITE_SLICE
    netcdf._WRITE_SLICE = 40  # 5 float64 values a slice: the channel crosses slices
    try:
        netcdf.write_netcdf(layout, streamed)
    finally:
        netcdf._WRITE_SLICE = original_slice
    stored = {name: netcdf._stored(v) for name, v in layout.variables.items()}
    coordinates = netcdf._coordinates_attribute(layout)
    with netcdf_file(reference, "w", version=2) as nc:
        for key, value in layout.attrs.items():
            setattr(nc, key, netcdf._attribute(value))
        for name, (dims, values) in stored.items():
            netcdf._create_dimensions(nc, name, dims, values.shape)
        for name, (dims, values) in stored.items():
            var = nc.createVariable(name, values.dtype, dims)
            var[...] = values
            attrs = dict(layout.variables[name].attrs)
            if layout.variables[name].missing:
                attrs["_FillValue"] = np.float64(np.nan)
            if values.dtype.kind == "S":
                attrs["_Encoding"] = "utf-8"
            if name in coordinates:
                attrs["coordinates"] = coordinates[name]
            for key, value in attrs.items():
                setattr(var, key, netcdf._attribute(value))
    assert streamed.read_bytes() == reference.read_bytes()
    with xr.open_dataset(streamed) as dataset:
        np.testing.assert_array_equal(dataset.tip.values, layout.data["tip"].values)


def test_the_joint_figure_leaves_free_joints_torques_out() -> None:
    """A free joint's torque channel is its equation's round-off (no motor acts): the joint
    figure shows the driven crank's torque alone, on one panel, not three panels of which
    two are noise."""
    from flexlink import simulate
    from flexlink.channels.catalogue import joint_channels

    rigid = {"mass_per_length": 1.0, "rigid": True}
    scenario = scenario_from_dict({
        "simulation": {"name": "free-pins", "t_end": 0.02, "dt_out": 1e-3},
        "links": [{"name": "crank", "length": 0.1, **rigid},
                  {"name": "coupler", "length": 0.3, **rigid},
                  {"name": "rocker", "length": 0.25, **rigid}],
        "joints": [{"motion": [{"profile": "spinup", "to_rate_deg_s": 720.0, "start": 0.0,
                                "duration": 0.5, "from_deg": 90.0}]},
                   {"drive": "free", "initial_angle_deg": -60.0},
                   {"drive": "free", "base_point": [0.3, 0.0], "initial_angle_deg": 100.0}],
        "closures": [{"name": "pin", "link": "coupler", "to_link": "rocker"}]})
    quantities = [c.quantity for c in joint_channels(scenario, "first_order")
                  if c.name.endswith("_torque")]
    assert quantities == ["torque", "free_torque", "free_torque"]
    results = simulate(scenario)
    assert np.abs(results["joint3_torque"]).max() < 1e-9  # round-off, still written
    fig = plotting.plot_joint_angles(results)
    assert len(fig.axes) == 2
    assert [t.get_text() for t in fig.axes[1].get_legend().get_texts()] == ["τ₁"]
