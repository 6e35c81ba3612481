"""Per-case summary metrics of sweeps: the grammar, each metric against a hand computation,
and a sweep's summaries equal to the metric of its own histories (with and without them)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from flexlink.batch import SweepError, sweep
from flexlink.batch.spec import read_sweep_file
from flexlink.batch.summaries import parse_summaries, parse_summary
from flexlink.cli import main
from tests.unit.test_sweep import RATE, spin_file

T = np.linspace(0.0, 2.0, 201)
X = np.where(T < 1.0, np.sin(2 * np.pi * 3 * T), 0.01 * np.exp(-(T - 1.0)) + 0.5)


@pytest.mark.parametrize(("text", "expected"), [
    ("peak:x", np.max(np.abs(X))),
    ("rms:x", np.sqrt(np.mean(X ** 2))),
    ("rms:x:after=1", np.sqrt(np.mean(X[100:] ** 2))),
    ("max:x", X.max()), ("min:x", X.min()), ("mean:x:after=1.5", X[150:].mean()),
    ("final:x", X[-1]),
    ("residual:x:after=1", X[100:].max()),
])
def test_each_metric_is_its_definition(text: str, expected: float) -> None:
    assert parse_summary(text).evaluate(T, X) == pytest.approx(expected, rel=1e-12)


def test_settling_time_is_the_first_time_after_which_the_band_holds() -> None:
    band = 0.5 * 0.01 * (np.exp(-0.2) - np.exp(-1.0))  # crossed between t = 1.2 and t = 2
    settled = parse_summary(f"settling:x:band={band}").evaluate(T, X)
    exact = 1.0 - np.log(band / 0.01 + np.exp(-1.0))  # |x - x_end| = band
    assert exact <= settled <= exact + 0.01  # the first output time after it
    assert parse_summary("settling:x:band=10").evaluate(T, X) == 0.0  # always inside


@pytest.mark.parametrize(("text", "message"), [
    ("peak", "METRIC:CHANNEL"), ("fastest:x", "unknown metric"),
    ("residual:x", "needs after"), ("settling:x", "needs band"),
    ("peak:x:band=1", "takes no option 'band'"), ("peak:x:after=abc", "must be a number"),
    ("settling:x:band=0", "> 0"), ("peak:x:after=-1", ">= 0"), ("peak:x:after=nan", "finite"),
])
def test_bad_summaries_are_refused_naming_the_problem(text: str, message: str) -> None:
    with pytest.raises(SweepError, match=message):
        parse_summary(text)


def test_a_summary_given_twice_is_refused() -> None:
    with pytest.raises(SweepError, match="given twice"):
        parse_summaries(["peak:x", "peak:x"])


def test_sweep_summaries_are_the_metrics_of_its_histories(tmp_path: Path) -> None:
    texts = ["peak:tip", "residual:tip:after=0.5", "rms:joint1_angle", "settling:tip:band=1e-4"]
    rates = [100.0, 200.0, 300.0]
    full = sweep(spin_file(tmp_path), grid={RATE: rates}, summaries=texts, workers=1)
    lean = sweep(spin_file(tmp_path), grid={RATE: rates}, summaries=texts, histories=False,
                 workers=2)
    assert "time" not in lean.dims and "tip" not in lean.data_vars
    for text in texts:
        summary = parse_summary(text)
        by_hand = [summary.evaluate(full.time.values, full[summary.channel].values[i])
                   for i in range(len(rates))]
        np.testing.assert_array_equal(full[summary.name].values, by_hand)
        np.testing.assert_array_equal(lean[summary.name].values, by_hand)
    assert full["peak_tip"].attrs["units"] == full["tip"].attrs["units"]
    assert lean["settling_tip_band_0p0001"].attrs["units"] == "s"
    assert len(set(full["peak_tip"].values)) == len(rates)  # the cases differ


def test_summaries_name_unknown_channels_and_times_past_the_end(tmp_path: Path) -> None:
    with pytest.raises(SweepError, match="unknown channel 'tipp'"):
        sweep(spin_file(tmp_path), grid={RATE: [100.0]}, summaries=["peak:tipp"], workers=1)
    with pytest.raises(SweepError, match="past the end"):
        sweep(spin_file(tmp_path), grid={RATE: [100.0]}, summaries=["residual:tip:after=9"],
              workers=1)
    with pytest.raises(SweepError, match="give summaries"):
        sweep(spin_file(tmp_path), grid={RATE: [100.0]}, histories=False, workers=1)


def test_command_line_and_sweep_file_keep_only_summaries(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "lean.nc"
    status = main(["sweep", str(spin_file(tmp_path)), "--grid", f"{RATE}=100,200",
                   "--summary", "peak:tip", "--no-histories", "--workers", "1", "-o", str(out)])
    assert status == 0
    assert "peak_tip: min" in capsys.readouterr().out
    with xr.open_dataset(out) as written:
        assert set(written.data_vars) >= {"peak_tip", "status"}
        assert "tip" not in written.data_vars and "time" not in written.dims
    spec = tmp_path / "lean.toml"
    spec.write_text(f'base = "spin.toml"\nsummaries = ["peak:tip"]\nhistories = false\n'
                    f'[grid]\n"{RATE}" = [100.0]\n', encoding="utf-8")
    definition = read_sweep_file(spec)
    assert definition["summaries"] == ["peak:tip"] and definition["histories"] is False
    spec.write_text('base = "spin.toml"\nhistories = "no"\n', encoding="utf-8")
    with pytest.raises(SweepError, match="histories: expected true or false"):
        read_sweep_file(spec)


def test_a_summaries_only_file_gets_a_page_and_a_clear_animate_refusal(
        tmp_path: Path, capsys: pytest.CaptureFixture) -> None:
    out = tmp_path / "lean.nc"
    sweep(spin_file(tmp_path), grid={RATE: [100.0]}, summaries=["peak:tip"], histories=False,
          workers=1, output=out)
    assert "peak_tip" in out.with_suffix(".html").read_text(encoding="utf-8")
    assert main(["animate", str(out), "-o", str(tmp_path / "a.gif")]) == 2
    assert "summary metrics only" in capsys.readouterr().err
    assert not (tmp_path / "a.gif").exists()
