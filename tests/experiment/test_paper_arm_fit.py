"""The paper's arm: hidden-truth measurement sets (stiffened 6-mode model, unknown modulus and
damping, instrument errors) written as CSV and .mat, then `flexlink compare` and `flexlink fit`
as a user would run them. Slow: the fit takes some 20 simulations of 5 s of the arm."""

from __future__ import annotations

import csv
import json

import pytest
from scipy.io import savemat

from flexlink.cli import main
from flexlink.experiment.vibration import dominant_mode
from flexlink.scenario import paper_experiment_path

from .synthetic import MAPPING, Truth, measured_columns, write_csv


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["csv", "mat"])
def test_paper_arm_compare_and_fit(tmp_path, fmt) -> None:
    truth = Truth(seed=3 if fmt == "csv" else 4)
    columns, clean = measured_columns(truth)
    if fmt == "csv":
        write_csv(tmp_path / "measured.csv", columns)
    else:
        savemat(tmp_path / "measured.mat", columns)
    text = paper_experiment_path().read_text(encoding="utf-8")
    mapping = MAPPING.replace("measured.csv", f"measured.{fmt}")
    (tmp_path / "arm.toml").write_text(text + mapping, encoding="utf-8")

    assert main(["compare", str(tmp_path / "arm.toml"), "-o", str(tmp_path / "cmp"),
                 "-q"]) == 0
    report = json.loads((tmp_path / "cmp" / "metrics.json").read_text())
    start = report["free_vibration_start_s"]
    window = clean.time >= start
    for m in report["metrics"]:
        true_f = dominant_mode(clean.time[window], clean[m["name"]][window]).frequency_hz
        assert abs(m["frequency_measured_Hz"] / true_f - 1) < 0.01, m["name"]  # judged: 1 %

    assert main(["fit", str(tmp_path / "arm.toml"), "-o", str(tmp_path / "fit"), "-q",
                 "-p", "links[0].EI", "-p", "links[0].damping_ratio",
                 "-p", "links[1].damping_ratio", "-p", "pzt:gain", "-p", "pzt:offset",
                 "-p", "pzt:drift"]) == 0
    with (tmp_path / "fit" / "parameters.csv").open() as fh:
        got = {row["path"]: float(row["value"]) for row in csv.DictReader(fh)}
    assert got["links[0].EI"] == pytest.approx(truth.EI1, rel=0.03)  # judged: 3 %
    assert got["links[0].damping_ratio"] == pytest.approx(truth.zeta1, rel=0.2)  # judged: 20 %
    assert got["links[1].damping_ratio"] == pytest.approx(truth.zeta2, rel=0.2)
