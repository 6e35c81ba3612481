"""compare and fit recover what was put into synthetic measurements made by a different model
(geometric stiffening, more modes, noise, quantised angles, a gain error)."""

from __future__ import annotations

import csv
import json
import math
import tomllib

import numpy as np
import pytest
from scipy.io import savemat

from flexlink.cli import main
from flexlink.experiment.comparison import compare
from flexlink.experiment.files import read_columns
from flexlink.experiment.identification import fit
from flexlink.experiment.loading import load_experiment
from flexlink.experiment.measurement import condition, parse_spec
from flexlink.experiment.parameters import parse_parameter
from flexlink.experiment.vibration import dominant_mode
from flexlink.scenario import scenario_from_dict
from flexlink.scenario.fields import ScenarioFile
from flexlink.simulation import simulate

from .synthetic import SINGLE_LINK_MAPPING, single_link_measurement, single_link_text, write_csv

EI_TRUE, ZETA_TRUE = 262.0, 0.03  # the scenario says 308.7 N·m² and 0.02
MAPPING = SINGLE_LINK_MAPPING + """[[measurement.columns]]
column = "strain"
sensor = "strain"
unit = "ustrain"
"""


@pytest.fixture(scope="module")
def measured() -> dict[str, np.ndarray]:
    return single_link_measurement(EI_TRUE, ZETA_TRUE)


@pytest.fixture()
def files(tmp_path, measured):
    write_csv(tmp_path / "measured.csv", measured)
    (tmp_path / "arm.toml").write_text(single_link_text() + MAPPING, encoding="utf-8")
    return tmp_path


def true_frequency(window_start: float) -> float:
    truth = simulate(scenario_from_dict(tomllib.loads(
        single_link_text(EI_TRUE, ZETA_TRUE, 6, True))))
    w = truth.time >= window_start
    return dominant_mode(truth.time[w], truth["acc"][w]).frequency_hz


def test_compare_reports_the_true_frequency(files) -> None:
    experiment = load_experiment(files / "arm.toml")
    result = compare(experiment.scenario, experiment.measurement)
    acc = {m.name: m for m in result.metrics}["acc"]
    f_true = true_frequency(result.free_start)
    assert abs(acc.frequency_measured / f_true - 1) < 0.002  # judged: 1 %
    # the scenario's EI is 308.7 instead of 262: its frequency is ~√(308.7/262) higher
    assert acc.frequency_error == pytest.approx(math.sqrt(308.7 / EI_TRUE) - 1, abs=0.01)
    assert acc.damping_measured == pytest.approx(ZETA_TRUE, rel=0.15)
    assert 0.5 < acc.correlation < 1.0


def test_fit_recovers_stiffness_damping_and_gain(files) -> None:
    experiment = load_experiment(files / "arm.toml")
    units = experiment.measurement.units
    params = [parse_parameter(p, experiment.file, units)
              for p in ("links[0].EI", "links[arm].damping_ratio", "strain:gain")]
    result = fit(experiment.file, experiment.measurement, params)
    ei, zeta, gain = result.estimates
    assert ei.value == pytest.approx(EI_TRUE, rel=0.01)  # judged: 3 %
    assert zeta.value == pytest.approx(ZETA_TRUE, rel=0.10)  # judged: 20 %
    assert gain.value == pytest.approx(0.9, rel=0.02)
    for e in (ei, zeta):  # intervals contain the truth and are not absurdly wide
        truth = EI_TRUE if e is ei else ZETA_TRUE
        assert e.ci_low < truth < e.ci_high or abs(e.value / truth - 1) < 0.005
        assert e.ci_high / e.ci_low < 1.5
    assert result.simulations <= 30
    fitted = {m.name: m for m in result.comparison.metrics}
    assert abs(fitted["acc"].frequency_error) < 0.002


def test_calibration_parameters_carry_the_channel_s_units(files) -> None:
    """parameters.csv's unit column: a gain is 1, an offset in the channel's unit, a drift
    in that unit per second, a delay in s."""
    experiment = load_experiment(files / "arm.toml")
    units = experiment.measurement.units
    got = {p: parse_parameter(p, experiment.file, units).unit
           for p in ("acc:gain", "acc:offset", "acc:drift", "acc:delay", "strain:drift")}
    assert got == {"acc:gain": "1", "acc:offset": "m s-2", "acc:drift": "m s-3",
                   "acc:delay": "s", "strain:drift": "s-1"}


def test_compare_with_its_own_results_is_exact(tmp_path) -> None:
    """A results.csv of `flexlink run` is a valid measurement (default mapping): comparing a
    scenario with its own output gives zero error — the plumbing adds nothing."""
    (tmp_path / "arm.toml").write_text(single_link_text(), encoding="utf-8")
    assert main(["run", str(tmp_path / "arm.toml"), "-o", str(tmp_path / "run"), "-q",
                 "--no-figures"]) == 0
    experiment = load_experiment(tmp_path / "arm.toml", tmp_path / "run" / "results.csv")
    result = compare(experiment.scenario, experiment.measurement)
    for m in result.metrics:
        assert m.nrmse < 1e-3, m.name  # CSV round-off and the re-interpolated angle
        assert m.correlation > 0.99999
        assert abs(m.frequency_error) < 1e-4


def test_cli_compare_and_fit_write_reports(files, measured) -> None:
    savemat(files / "measured.mat", measured)
    out = files / "cmp"
    assert main(["compare", str(files / "arm.toml"), str(files / "measured.mat"), "-o",
                 str(out), "-q"]) == 0
    for name in ("report.md", "metrics.csv", "metrics.json", "simulated.csv",
                 "scenario.resolved.toml", "figures/overlay.png", "figures/spectra.png"):
        assert (out / name).is_file(), name
    metrics = json.loads((out / "metrics.json").read_text())
    assert {m["name"] for m in metrics["metrics"]} == {"acc", "strain"}
    assert "![measured and simulated signals](figures/overlay.png)" in (
        out / "report.md").read_text()
    # units in the header, as a plant's modes.csv (frequency_Hz): a reader of the CSV alone
    # knows the frequencies are in Hz and the errors in percent; metrics.json has the same rows
    with (out / "metrics.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == ["name", "unit", "nrmse", "correlation", "peak_measured",
                             "peak_simulated", "peak_error_pct", "frequency_measured_Hz",
                             "frequency_simulated_Hz", "frequency_error_pct",
                             "damping_ratio_measured", "damping_ratio_simulated"]
    acc = next(row for row in rows if row["name"] == "acc")
    assert acc["unit"] == "m s-2"
    assert [{k: str(v) for k, v in m.items()} for m in metrics["metrics"]] == rows
    f_meas, f_sim = float(acc["frequency_measured_Hz"]), float(acc["frequency_simulated_Hz"])
    assert float(acc["frequency_error_pct"]) == pytest.approx(100 * (f_sim / f_meas - 1))
    assert 1.0 < f_meas < 100.0  # Hz, not rad/s

    out = files / "fit"
    assert main(["fit", str(files / "arm.toml"), "-o", str(out), "-q", "--no-figures",
                 "-p", "links[0].EI=100:1000", "-p", "links[0].damping_ratio",
                 "--channel", "acc"]) == 0
    with (out / "parameters.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert list(rows[0]) == ["path", "unit", "initial", "start", "value", "std", "ci_low",
                             "ci_high", "lower", "upper", "at_bound", "identifiable"]
    assert [(row["path"], row["unit"]) for row in rows] == [("links[0].EI", "N m2"),
                                                            ("links[0].damping_ratio", "1")]
    ei = float(rows[0]["value"])
    assert ei == pytest.approx(EI_TRUE, rel=0.01)
    assert json.loads((out / "fit.json").read_text())["parameters"][0]["unit"] == "N m2"
    fitted = tomllib.loads((out / "scenario.resolved.toml").read_text())
    assert fitted["links"][0]["EI"] == pytest.approx(ei)


@pytest.mark.parametrize(("edit", "message"), [
    (lambda c: c.pop("acc"), "no column 'acc'; available columns: t, angle, strain"),
    (lambda c: c["t"].__setitem__(500, 0.1), "time goes backwards"),
    (lambda c: c["strain"].__setitem__(slice(100, 200), np.nan), "100 missing or non-finite"),
])
def test_cli_bad_measurements_exit_2_without_output(files, measured, capsys, edit,
                                                    message) -> None:
    cols = {k: v.copy() for k, v in measured.items()}
    edit(cols)
    write_csv(files / "bad.csv", cols)
    out = files / "out"
    assert main(["compare", str(files / "arm.toml"), str(files / "bad.csv"), "-o",
                 str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()


def test_cli_warns_about_repairs(files, measured, capsys) -> None:
    cols = {k: v.copy() for k, v in measured.items()}
    cols["acc"][[300, 301]] = np.nan
    write_csv(files / "holes.csv", cols)
    assert main(["compare", str(files / "arm.toml"), str(files / "holes.csv"), "-o",
                 str(files / "out"), "-q", "--no-figures"]) == 0
    assert "warning:" in capsys.readouterr().err
    report = (files / "out" / "report.md").read_text()
    assert "2 missing or non-finite sample(s) filled" in report


def test_bad_parameters_are_clear(files) -> None:
    experiment = load_experiment(files / "arm.toml")
    units = experiment.measurement.units
    for text, message in (
            ("links[3].EI", r"the scenario has 1 entry in links \(indices 0 to 0\)"),
            ("links[0].name", "string 'arm'; only numeric fields"),
            ("links[0].modes", "takes integers"),
            ("links[lnk].EI", r"no entry named 'lnk' \(known names: 'arm'\)"),
            ("links[0].lenght", "give an initial value"),
            ("simulation.dt_out", "cannot be fitted"),
            ("acc:gian", "unknown calibration 'gian'"),
            ("pzt:gain", "not a measured channel"),
            ("EI", r"give a path into one, e\.g\. links\[0\]\.EI"),
            ("links[0]EI", "bad parameter path")):
        with pytest.raises(ValueError, match=message):
            parse_parameter(text, experiment.file, units)


def test_fields_of_a_measured_joint_are_refused(files) -> None:
    """The measured angles replace joint 1's motion: its profile keys would change nothing."""
    experiment = load_experiment(files / "arm.toml")
    param = parse_parameter("joints[0].motion[0].duration", experiment.file, {})
    with pytest.raises(ValueError, match="joint 1 is driven by the measured angles"):
        fit(experiment.file, experiment.measurement, [param])


def test_mapping_also_from_cli(files, measured) -> None:
    spec_only = tomllib.loads(MAPPING)["measurement"]
    scenario = scenario_from_dict(tomllib.loads(single_link_text()))
    m = condition(read_columns(files / "measured.csv"), parse_spec(spec_only, scenario),
                  scenario, "x")
    experiment = load_experiment(files / "arm.toml", files / "measured.csv",
                                 maps=["angle=joint1,unit=deg,lowpass_hz=30", "acc=acc"])
    assert set(experiment.measurement.signals) == {"acc"}
    np.testing.assert_allclose(experiment.measurement.signals["acc"], m.signals["acc"])


def test_fit_section_parameters() -> None:
    from flexlink.experiment.parameters import parse_parameter_option, parse_parameter_table

    scenario = ScenarioFile(tomllib.loads(single_link_text()))
    units = {"acc": "m s-2"}
    p = parse_parameter_table({"path": "links[0].EI", "lower": 100.0, "upper": 500.0,
                               "initial": 250.0}, "fit.parameters[0]", scenario, units)
    assert (p.lower, p.upper, p.initial, p.log) == (100.0, 500.0, 250.0, True)
    q = parse_parameter_option("acc:offset=-1:1", scenario, units)
    assert (q.lower, q.upper, q.log) == (-1.0, 1.0, False)
    for entry, message in (({"path": "links[0].EI", "lower": "1"}, "expected a finite number"),
                           ({"path": "links[0].EI", "lowr": 1}, "unknown key"),
                           ({"path": "links[0].EI", "lower": 0.0}, "must be > 0"),
                           ({"path": "links[0].EI", "lower": 5.0, "upper": 1.0}, "below")):
        with pytest.raises(ValueError, match=message):
            parse_parameter_table(entry, "fit.parameters[0]", scenario, units)


def test_time_objective_with_delay(files) -> None:
    """The time-domain objective (and a fitted sensor delay) on the one-link arm: the model
    differs from the truth only in stiffening and mode count here, so it recovers EI too."""
    experiment = load_experiment(files / "arm.toml")
    units = experiment.measurement.units
    params = [parse_parameter(p, experiment.file, units)
              for p in ("links[0].EI", "links[0].damping_ratio", "acc:delay")]
    result = fit(experiment.file, experiment.measurement, params, channels=["acc"],
                 objective="time", max_simulations=40)
    ei, zeta, delay = result.estimates
    assert ei.value == pytest.approx(EI_TRUE, rel=0.01)
    assert zeta.value == pytest.approx(ZETA_TRUE, rel=0.1)
    assert abs(delay.value) < 2e-3  # s; the truth has none
    with pytest.raises(ValueError, match="delay changes no frequency"):
        fit(experiment.file, experiment.measurement, params, objective="modal")


def test_run_ignores_the_experiment_sections(files) -> None:
    text = (files / "arm.toml").read_text() + '\n[fit]\nobjective = "modal"\n'
    (files / "arm.toml").write_text(text.replace("t_end = 2.0", "t_end = 0.2"))
    assert main(["run", str(files / "arm.toml"), "-o", str(files / "run"), "-q",
                 "--no-figures"]) == 0


def test_the_fit_jacobian_is_scipys_two_point_one_and_is_reused_after_a_tiny_step() -> None:
    """identification._solve on a cheap nonlinear residual: the answer and Jacobian of
    scipy's "2-point" differences with the same relative step, with no more residuals (its
    last Jacobian is reused after a step below a hundredth of its difference steps)."""
    from scipy.optimize import least_squares

    from flexlink.experiment import identification as ident
    from flexlink.experiment.parameters import Parameter

    params = [Parameter("a", "EI", target=("links", 0, "EI"), lower=0.1, upper=10.0, log=True,
                        value=1.0),
              Parameter("b", "damping_ratio", target=("links", 0, "damping_ratio"),
                        lower=-5.0, upper=1.0 + 1e-4, value=1.0)]
    t = np.linspace(0.0, 1.0, 40)
    data = 2.0 * np.exp(-0.7 * t) + 0.3 * t

    calls = []

    def residual(values: list[float]) -> np.ndarray:
        calls.append(tuple(values))
        a, b = values
        return a * np.exp(-b * t) + 0.3 * t - data

    solution, values = ident._solve(residual, params, [0, 1], [1.0, 1.0], [1.0, 1.0], 100)
    assert values == pytest.approx([2.0, 0.7], rel=1e-6)
    ours = len(set(calls))

    def scaled(u: np.ndarray) -> np.ndarray:
        return residual([math.exp(u[0] - 1.0), 1.0 + (u[1] - 1.0)])

    calls.clear()
    lower, upper = np.array([1.0 + math.log(0.1), -5.0]), np.array([1.0 + math.log(10.0),
                                                                     1.0 + 1e-4])
    reference = least_squares(scaled, np.array([1.0, 1.0 - 1e-9]), bounds=(lower, upper),
                              method="trf", diff_step=ident.DIFF_STEP, x_scale=1.0, xtol=1e-5,
                              ftol=1e-8, gtol=1e-8, max_nfev=100)
    assert solution.x == pytest.approx(reference.x, rel=1e-9)
    # equal but where the last Jacobian was reused: then within the differences' own error
    np.testing.assert_allclose(solution.jac, reference.jac, rtol=1e-3)
    assert ours <= len(set(calls))
