"""Measurement files: reading, mapping, and what happens to bad data (errors or warned repairs)."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from scipy.io import savemat

from flexlink.experiment.files import MeasurementError, read_columns
from flexlink.experiment.measurement import (
    ConstantChannelWarning,
    MeasurementSpec,
    MeasurementWarning,
    NoisyAngleWarning,
    condition,
    parse_map_option,
    parse_spec,
)
from flexlink.scenario import load_paper_experiment

SCENARIO = load_paper_experiment()
MAPPING = tomllib.loads("""
[measurement]
time_column = "time_ms"
time_unit = "ms"
[[measurement.columns]]
column = "b1"
joint = 1
unit = "deg"
[[measurement.columns]]
column = "acc_g"
sensor = "link1_tip_acceleration"
unit = "g"
[[measurement.columns]]
column = "pzt_mv"
sensor = "pzt"
unit = "mV"
scale = 2.0
offset = -1.0
""")["measurement"]


def write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


def live(n: int, start: float = 0.0) -> np.ndarray:
    """A sensor column that changes (a constant one is warned as a dead channel)."""
    return start + np.linspace(0.0, 0.1, n)


def table(n: int = 50, dt_ms: float = 1.0) -> dict[str, np.ndarray]:
    t = np.arange(n) * dt_ms
    return {"time_ms": t, "b1": np.linspace(0.0, 9.0, n), "acc_g": live(n, 0.5),
            "pzt_mv": live(n, 3.0)}


def spec() -> MeasurementSpec:
    return parse_spec(MAPPING, SCENARIO)


def test_units_scale_and_offset() -> None:
    m = condition(table(), spec(), SCENARIO, "x")
    assert m.time[1] == pytest.approx(1e-3)
    assert m.angles[0][-1] == pytest.approx(math.radians(9.0))
    assert m.signals["link1_tip_acceleration"][0] == pytest.approx(0.5 * 9.80665)
    assert m.signals["pzt"][0] == pytest.approx((2.0 * 3.0 - 1.0) * 1e-3)  # V
    assert m.units == {"joint1_angle": "rad", "link1_tip_acceleration": "m s-2", "pzt": "V"}


def test_csv_and_mat_read_alike(tmp_path) -> None:
    cols = table()
    names = list(cols)
    np.savetxt(tmp_path / "m.csv", np.column_stack([cols[n] for n in names]), delimiter=";",
               header=";".join(names), comments="# logged by a test\n")
    savemat(tmp_path / "m.mat", {"time_ms": cols["time_ms"], "b1": cols["b1"][:, None],
                                 "logger": {"acc_g": cols["acc_g"], "pzt_mv": cols["pzt_mv"]}})
    from_csv = read_columns(tmp_path / "m.csv")
    from_mat = read_columns(tmp_path / "m.mat")
    assert set(from_csv) == set(names)
    assert set(from_mat) == {"time_ms", "b1", "logger.acc_g", "logger.pzt_mv"}
    np.testing.assert_array_equal(from_csv["b1"], from_mat["b1"])


def test_dspace_style_struct(tmp_path) -> None:
    t = np.arange(20) * 1e-3
    rec = {"X": {"Data": t, "Name": "Time"},
           "Y": np.array([{"Name": "beta1", "Data": t * 2}, {"Name": "acc", "Data": t * 3}],
                         dtype=object)}
    savemat(tmp_path / "d.mat", {"run1": rec})
    cols = read_columns(tmp_path / "d.mat")
    assert {"Time", "beta1", "acc"} <= set(cols)
    np.testing.assert_allclose(cols["acc"], t * 3)


def test_matlab_v73_is_refused_clearly(tmp_path) -> None:
    header = b"MATLAB 7.3 MAT-file, Platform: GLNXA64, Created on: Mon Nov 23 2026 HDF5 schema"
    path = tmp_path / "big.mat"
    path.write_bytes(header.ljust(116, b" ") + b"\0" * 8 + b"\x00\x02IM" + b"\0" * 512)
    with pytest.raises(MeasurementError, match="v7.3.*-v7"):
        read_columns(path)


@pytest.mark.parametrize(("text", "message"), [
    ("", "empty file"),
    ("1,2\n3,4\n", "header row"),
    ("t,a\n0,1\n1\n", "line 3 has 1 fields"),
    ("t,a\n0,1\n1,x\n", "line 3, column 'a': cannot read 'x'"),
    ("t,t\n0,1\n", "duplicate column"),
])
def test_bad_csv(tmp_path, text, message) -> None:
    with pytest.raises(MeasurementError, match=message):
        read_columns(write(tmp_path / "bad.csv", text))


def test_missing_file_and_column(tmp_path) -> None:
    with pytest.raises(MeasurementError, match="not found"):
        read_columns(tmp_path / "nope.csv")
    cols = table()
    del cols["acc_g"]
    with pytest.raises(MeasurementError, match="no column 'acc_g'; available columns: time_ms"):
        condition(cols, spec(), SCENARIO, "x")


def test_time_running_backwards_is_an_error() -> None:
    cols = table()
    cols["time_ms"][20] = 5.0
    with pytest.raises(MeasurementError, match="time goes backwards at data row 21"):
        condition(cols, spec(), SCENARIO, "x")


def test_duplicated_time_is_dropped_with_a_warning() -> None:
    cols = {k: np.insert(v, 10, v[10]) for k, v in table().items()}
    with pytest.warns(MeasurementWarning, match="1 duplicated time stamp"):
        m = condition(cols, spec(), SCENARIO, "x")
    assert m.time.size == 50


def test_short_nan_runs_filled_long_ones_refused() -> None:
    cols = table()
    cols["b1"][[5, 6, 30]] = np.nan
    with pytest.warns(MeasurementWarning,
                      match="3 missing or non-finite sample.*linear interpolation"):
        m = condition(cols, spec(), SCENARIO, "x")
    assert m.angles[0][6] == pytest.approx(math.radians(9.0 * 6 / 49))
    cols = table()
    cols["acc_g"][10:25] = np.nan
    with pytest.raises(MeasurementError,
                       match="15 missing or non-finite .NaN, inf. samples in a row"):
        condition(cols, spec(), SCENARIO, "x")
    cols = table()
    cols["time_ms"][3] = np.nan
    with pytest.raises(MeasurementError, match="time column 'time_ms' has 1 missing"):
        condition(cols, spec(), SCENARIO, "x")


def test_gaps_bridged_or_refused() -> None:
    cols = {k: np.delete(v, [20, 21, 22]) for k, v in table().items()}
    with pytest.warns(MeasurementWarning, match="gap.*bridged"):
        m = condition(cols, spec(), SCENARIO, "x")
    assert np.allclose(np.diff(m.time), 1e-3)
    assert m.angles[0][21] == pytest.approx(math.radians(9.0 * 21 / 49))  # linear data: exact
    cols = {k: np.delete(v, range(10, 30)) for k, v in table().items()}
    with pytest.raises(MeasurementError, match="gap of 0.021 s"):
        condition(cols, spec(), SCENARIO, "x")


def test_unequal_lengths_and_late_start() -> None:
    cols = table()
    cols["b1"] = cols["b1"][:-1]
    with pytest.raises(MeasurementError, match="column 'b1' has 49 samples but time"):
        condition(cols, spec(), SCENARIO, "x")
    cols = table()
    cols["time_ms"] = cols["time_ms"] + 100.0
    with pytest.raises(MeasurementError, match="time_offset = -0.1"):
        condition(cols, spec(), SCENARIO, "x")


def test_lowpass_removes_noise_and_checks_nyquist() -> None:
    n = 2000
    t = np.arange(n) * 1.0
    rng = np.random.default_rng(0)
    cols = {"time_ms": t, "b1": 10 * np.sin(2 * np.pi * t / 1000) + rng.normal(0, 0.2, n),
            "acc_g": live(n), "pzt_mv": live(n)}
    raw = dict(MAPPING)
    raw["columns"] = [dict(MAPPING["columns"][0], lowpass_hz=30.0)]
    m = condition(cols, parse_spec(raw, SCENARIO), SCENARIO, "x")
    clean = np.radians(10 * np.sin(2 * np.pi * t / 1000))
    inner = slice(100, -100)  # away from the filter's end transients
    assert np.std((m.angles[0] - clean)[inner]) < 0.3 * math.radians(0.2)
    raw["columns"] = [dict(MAPPING["columns"][0], lowpass_hz=600.0)]
    with pytest.raises(MeasurementError, match="below the Nyquist frequency 500 Hz"):
        condition(cols, parse_spec(raw, SCENARIO), SCENARIO, "x")


def test_mapping_problems_reported_together() -> None:
    bad = {"time_column": "t", "colums": [],
           "columns": [{"column": "a", "joint": 3}, {"column": "b", "sensor": "acc"},
                       {"column": "c", "sensor": "pzt", "unit": "deg"},
                       {"column": "d"}]}
    with pytest.raises(MeasurementError) as info:
        parse_spec(bad, SCENARIO)
    text = str(info.value)
    assert "unknown key 'colums' (did you mean 'columns'?)" in text
    assert "measurement.columns[0].joint must be an integer from 1 to 2, got 3" in text
    assert "no sensor or channel 'acc'" in text
    assert "unit 'deg' does not fit 'pzt' (V); allowed: 'V', 'mV'" in text
    assert "give exactly one of 'joint'" in text


def test_map_option() -> None:
    c = parse_map_option("beta2=joint2,unit=deg,lowpass_hz=30", SCENARIO)
    assert (c.column, c.joint, c.unit, c.lowpass_hz) == ("beta2", 1, "deg", 30.0)
    assert parse_map_option("v=pzt,scale=-1", SCENARIO).scale == -1.0
    with pytest.raises(MeasurementError, match="expected COLUMN=TARGET"):
        parse_map_option("beta2", SCENARIO)
    with pytest.raises(MeasurementError, match="scale must be a number"):
        parse_map_option("v=pzt,scale=big", SCENARIO)


def test_default_mapping_reads_a_results_csv_layout() -> None:
    n = 20
    cols = {"t": np.arange(n) * 1e-3, "joint1_angle": np.zeros(n), "pzt": live(n, 1.0),
            "other": np.ones(n), "link1_tip_X": np.ones(n)}
    m = condition(cols, MeasurementSpec(), SCENARIO, "x")
    assert set(m.angles) == {0} and set(m.signals) == {"pzt"}
    with pytest.raises(MeasurementError, match="no column is mapped"):
        condition({"t": cols["t"], "x": cols["pzt"]}, MeasurementSpec(), SCENARIO, "x")


def test_a_dead_sensor_channel_is_warned_naming_its_column() -> None:
    """A constant measured sensor column gave infinite metrics and a correlation of 0.0
    without a word."""
    cols = table()
    cols["pzt_mv"] = np.full(50, 3.0)
    with pytest.warns(ConstantChannelWarning, match="sensor column 'pzt_mv' \\(pzt\\) is "
                                                    "constant"):
        m = condition(cols, spec(), SCENARIO, "x")
    assert any("'pzt_mv'" in note for note in m.notes)
    assert not any("acc_g" in note for note in m.notes)


def test_unfiltered_quantised_angle_is_warned() -> None:
    n = 400
    cols = {"time_ms": np.arange(n) * 1.0, "b1": np.round(np.linspace(0, 2.0, n) / 0.05) * 0.05,
            "acc_g": live(n), "pzt_mv": live(n)}
    with pytest.warns(MeasurementWarning, match="steps of 0.05 deg.*Set lowpass_hz"):
        condition(cols, spec(), SCENARIO, "x")
    raw = dict(MAPPING)
    raw["columns"] = [dict(MAPPING["columns"][0], lowpass_hz=30.0)]
    condition(cols, parse_spec(raw, SCENARIO), SCENARIO, "x")  # filtered: no warning


def test_joint_angles_held_before_and_after_the_manoeuvre() -> None:
    from flexlink.experiment.comparison import HOLD_RAMP, held_angles

    n = 3000
    t_ms = np.arange(n) * 1.0
    tau = np.clip((t_ms / 1000 - 0.5) / 1.0, 0, 1)
    clean = 9.0 * (tau - np.sin(2 * np.pi * tau) / (2 * np.pi))
    rng = np.random.default_rng(2)
    cols = {"time_ms": t_ms, "b1": clean + rng.normal(0, 0.005, n), "acc_g": live(n),
            "pzt_mv": live(n)}
    with pytest.warns(NoisyAngleWarning):  # unfiltered noise: warned (see below)
        m = condition(cols, spec(), SCENARIO, "x")
    held = held_angles(m)[0]
    after = m.time > 1.7 + HOLD_RAMP
    assert np.ptp(held[after]) == 0.0  # the noise is gone after the move …
    assert held[after][0] == pytest.approx(math.radians(9.0), abs=math.radians(0.002))
    before = m.time < 0.3
    assert np.ptp(held[before]) == 0.0  # … and before it (the arm is at rest there too) …
    assert held[0] == pytest.approx(0.0, abs=math.radians(0.002))
    during = (m.time > 0.5) & (m.time < 1.5)
    np.testing.assert_array_equal(held[during], m.angles[0][during])  # … the move is untouched
    assert any("held at their final values" in note for note in m.notes)
    assert any("held at their initial values" in note for note in m.notes)
    with pytest.warns(NoisyAngleWarning):
        off = condition(cols, MeasurementSpec(**{**spec().__dict__,
                                                 "hold_after_manoeuvre": False}), SCENARIO, "x")
    np.testing.assert_array_equal(held_angles(off)[0], off.angles[0])


def noisy_move(noise_deg: float, seed: int = 0, n: int = 4000) -> dict[str, np.ndarray]:
    """A 1.5 s cycloidal move of 80° from 0.5 s, white angle noise, 2 s of rest after."""
    t_ms = np.arange(n) * 1.0
    tau = np.clip((t_ms / 1000 - 0.5) / 1.5, 0, 1)
    clean = 80.0 * (tau - np.sin(2 * np.pi * tau) / (2 * np.pi))
    rng = np.random.default_rng(seed)
    return {"time_ms": t_ms, "b1": clean + rng.normal(0, noise_deg, n), "acc_g": live(n),
            "pzt_mv": live(n)}


def test_noisy_unfiltered_angle_is_warned_with_a_cutoff() -> None:
    """Issue 15: 0.2° of noise, unfiltered, made the spline's joint accelerations noise and
    the run stop with a misleading large-deflection message."""
    with pytest.warns(NoisyAngleWarning, match=r"column 'b1'.*Set lowpass_hz = (\d+)") as got:
        m = condition(noisy_move(0.2), spec(), SCENARIO, "x")
    cutoff = float(__import__("re").search(r"lowpass_hz = (\d+)", str(got[0].message))[1])
    assert 3.0 <= cutoff <= 30.0
    assert "b1" in m.noisy_angles[0]
    raw = dict(MAPPING)
    raw["columns"] = [dict(MAPPING["columns"][0], lowpass_hz=cutoff)]
    with __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("error")  # the suggested cut-off is enough
        condition(noisy_move(0.2), parse_spec(raw, SCENARIO), SCENARIO, "x")
    condition(noisy_move(0.0), spec(), SCENARIO, "x")  # a clean angle: no warning


def test_failed_run_names_the_noisy_column(monkeypatch) -> None:
    import flexlink.simulation
    from flexlink.errors import SimulationError
    from flexlink.experiment.comparison import simulate_driven

    def fails(scenario, progress=False):
        raise SimulationError("the tip deflection of link2 exceeds its length")

    monkeypatch.setattr(flexlink.simulation, "simulate", fails)
    with pytest.warns(NoisyAngleWarning):
        m = condition(noisy_move(0.2), spec(), SCENARIO, "x")
    with pytest.raises(SimulationError, match=r"(?s)exceeds its length.*Likely cause.*'b1'"):
        simulate_driven(SCENARIO, m)
    clean = condition(noisy_move(0.0), spec(), SCENARIO, "x")
    with pytest.raises(SimulationError) as err:
        simulate_driven(SCENARIO, clean)
    assert "Likely cause" not in str(err.value)


def test_an_infinite_sample_is_named_as_such() -> None:
    """±inf was filled and reported as "missing/NaN", hiding an overflow or a saturation."""
    cols = table()
    cols["acc_g"][[7, 8]] = [np.inf, np.nan]
    with pytest.warns(MeasurementWarning, match=r"2 missing or non-finite sample\(s\) \(1 of "
                                                r"them ±inf: an overflow or a saturated"):
        condition(cols, spec(), SCENARIO, "x")


def test_data_mostly_outside_the_run_are_refused_and_data_past_it_noted() -> None:
    """Times in ms read as s (here: time_unit left at "s") put all but a few samples past
    t_end; the comparison ran on those few samples without a word (NRMSE 1, no frequency),
    and data going on past t_end were silently left out."""
    import dataclasses

    from flexlink.experiment.comparison import measured_inputs

    seconds = dataclasses.replace(spec(), time_unit="s")
    m = condition(table(), seconds, SCENARIO, "x")  # 0 to 49 "s"
    short = dataclasses.replace(SCENARIO, settings=dataclasses.replace(SCENARIO.settings,
                                                                        t_end=2.0))
    with pytest.raises(MeasurementError, match=r"only 3 of the 50 samples lie within the run, "
                                               r"0 to simulation.t_end = 2 s .*time_unit"):
        measured_inputs(short, m)
    m = condition(table(), spec(), SCENARIO, "x")  # 0 to 0.049 s
    brief = dataclasses.replace(SCENARIO, settings=dataclasses.replace(SCENARIO.settings,
                                                                        t_end=0.02))
    with pytest.warns(MeasurementWarning, match="the data go on to t = 0.049 s, past "
                                                "simulation.t_end = 0.02 s; compared up to"):
        measured_inputs(brief, m)
    assert any("the data go on to 0.049 s" in note for note in m.notes)
