"""The fit's exact Jacobians: the slopes of a damped-sinusoid fit against refits, and both
objectives' Jacobians (run sensitivities, analytic calibration columns) against central
differences of their residuals over runs."""

from __future__ import annotations

import math
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

from flexlink.experiment import identification as ident
from flexlink.experiment import vibration
from flexlink.experiment.loading import load_experiment
from flexlink.experiment.parameters import parse_parameter
from flexlink.experiment.vibration import damped_mode_slopes, damped_modes

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
CHANNELS = ("pzt", "link1_tip_acceleration")


def signal(t: np.ndarray, p: float) -> np.ndarray:
    """Two damped modes moved by p, a weak third one the fit leaves out (its residual is not
    zero), an offset and a drift."""
    return (np.exp(-0.6 * p * t) * np.cos(2 * math.pi * 5 * p * t)
            + 0.3 * np.exp(-0.9 * t) * np.sin(2 * math.pi * 13.2 * t + p)
            + 0.02 * np.exp(-3 * t) * np.cos(2 * math.pi * 40 * t) + 0.05 * p * t
            + 0.01 * np.sin(2 * math.pi * 0.3 * t))


def test_damped_mode_slopes_are_the_derivatives_of_the_refit() -> None:
    t = np.arange(0.0, 2.5, 1e-3)
    guesses = [5.0, 13.2]
    h = 1e-6
    dy = np.column_stack([(signal(t, 1 + h) - signal(t, 1 - h)) / (2 * h),
                          3.0 * (signal(t, 1 + h) - signal(t, 1 - h)) / (2 * h)])
    modes, d_freq, d_zeta = damped_mode_slopes(t, signal(t, 1.0), dy, guesses)
    assert [m.frequency_hz for m in modes] == [m.frequency_hz for m in
                                               damped_modes(t, signal(t, 1.0),
                                                            guesses=guesses)]
    # refits converge to ~1e-11 in ζ: central differences over ±2e-4 are good to ~5e-5
    step = 2e-4
    up, down = (damped_modes(t, signal(t, 1 + s), guesses=guesses) for s in (step, -step))
    for k in range(2):
        f = (up[k].frequency_hz - down[k].frequency_hz) / (2 * step)
        z = (up[k].damping_ratio - down[k].damping_ratio) / (2 * step)
        assert d_freq[k, 0] == pytest.approx(f, rel=2e-4)
        assert d_zeta[k, 0] == pytest.approx(z, rel=2e-4)
        # linear in y': equal up to the least-squares solves' round-off, which depends on
        # the processor's BLAS kernels (1.6e-12 seen)
        np.testing.assert_allclose([d_freq[k, 1], d_zeta[k, 1]],
                                   [3 * d_freq[k, 0], 3 * d_zeta[k, 0]], rtol=1e-11)
    # the residual's second-order term in H matters: Gauss–Newton's θ' = J⁺ y' gives even
    # the sign of the first component's damping slope wrong here
    fitted = vibration._fit_components(t, signal(t, 1.0), 2, guesses)
    _, jac = fitted.projected(fitted.theta)
    gauss_newton = np.linalg.lstsq(jac, dy[:, 0] / fitted.scale, rcond=None)[0]
    sigma, omega = fitted.theta[:2], fitted.theta[2:]
    z_gn = (omega**2 * gauss_newton[:2] - sigma * omega * gauss_newton[2:]) / np.hypot(
        sigma, omega) ** 3
    assert z_gn[0] * d_zeta[0, 0] < 0


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    """The lab record of the examples, its runs at rtol 1e-9 (differences of runs then hold
    to ~1e-6 of the slopes)."""
    folder = tmp_path_factory.mktemp("jacobian")
    text = (EXAMPLES / "lab_arm.toml").read_text(encoding="utf-8")
    (folder / "lab_arm.toml").write_text(text.replace("dt_out = 0.001", "dt_out = 0.001\n"
                                                      "rtol = 1e-9"), encoding="utf-8")
    shutil.copy(EXAMPLES / "lab_run3.csv", folder / "lab_run3.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the record's repairs
        return load_experiment(folder / "lab_arm.toml")


def differences(residual, values: list[float], chosen: list[int], rel: float) -> np.ndarray:
    columns = []
    for i in chosen:
        h = rel * max(abs(values[i]), 1e-3)
        up, down = list(values), list(values)
        up[i] += h
        down[i] -= h
        columns.append((residual(up) - residual(down)) / (2 * h))
    return np.column_stack(columns)


def test_modal_jacobian_is_the_derivative_of_the_modal_residual(experiment) -> None:
    params = [parse_parameter(p, experiment.file, experiment.measurement.units)
              for p in ("links[0].EI", "links[0].damping_ratio", "links[1].damping_ratio")]
    model = ident._Model(experiment.file, params, experiment.measurement, None)
    values = [270.0, 0.024, 0.013]
    results = model.results(values)
    t = results.time
    measured = ident.on_grid(experiment.measurement, t)
    mask = t >= 1.9
    features = ident._measured_features({c: damped_modes(t[mask], measured[c][mask])
                                         for c in CHANNELS})
    slopes = model.slopes_at(values)
    assert slopes is not None and model.exact_reason == ""
    r, jac = ident._modal_residual(t[mask], model.results(values), features, mask, slopes)
    np.testing.assert_array_equal(r, ident._modal_residual(t[mask], results, features,
                                                           mask)[0])

    def residual(v: list[float]) -> np.ndarray:
        return ident._modal_residual(t[mask], model.results(v), features, mask)[0]

    reference = differences(residual, values, [0, 1, 2], 1e-4)
    assert jac.shape == reference.shape == (2 * sum(len(m) for m in features.values()), 3)
    scale = np.abs(reference).max(axis=0)
    np.testing.assert_allclose(jac / scale, reference / scale, atol=2e-4)


def test_time_jacobian_with_calibration_and_delay(experiment) -> None:
    units = experiment.measurement.units
    paths = ("links[0].EI", "links[1].damping_ratio", "pzt:gain", "pzt:offset", "pzt:drift",
             "pzt:delay", "link1_tip_acceleration:gain")
    params = [parse_parameter(p, experiment.file, units) for p in paths]
    model = ident._Model(experiment.file, params, experiment.measurement, None)
    values = [270.0, 0.013, 1.1, 0.05, -0.01, 0.4e-3, 0.9]
    results = model.results(values)
    t = results.time
    measured = ident.on_grid(experiment.measurement, t)
    mask = t >= 0.3
    norm = {c: float(np.std(measured[c][mask])) for c in CHANNELS}

    def residual(v: list[float]) -> np.ndarray:
        res = model.results(v)
        return np.concatenate([(ident.calibrated(res, c, params, v)[mask] - measured[c][mask])
                               / norm[c] for c in CHANNELS])

    jac = ident._time_jacobian(results, model.slopes_at(values), params, values,
                               list(CHANNELS), mask, norm)
    # the delay's step (1e-7 s) stays within one segment of the linear interpolation
    reference = differences(residual, values, list(range(len(params))), 1e-4)
    scale = np.abs(reference).max(axis=0)
    np.testing.assert_allclose(jac / scale, reference / scale, atol=2e-4)
    assert not np.any(jac[mask.sum():, 2:6])  # pzt's calibration leaves the other alone


def test_the_fit_uses_the_exact_jacobian_where_the_runs_take_sensitivities(experiment,
                                                                         monkeypatch) -> None:
    """The lab record's runs are tabulated Lawson runs: the fit's Jacobians are exact, and
    its answer is the one of differences (today's Jacobian) to well within its interval."""
    params = [parse_parameter(p, experiment.file, experiment.measurement.units)
              for p in ("links[0].EI", "links[1].damping_ratio", "pzt:gain")]
    exact = ident.fit(experiment.file, experiment.measurement, params)
    assert exact.info["jacobian"] == "exact"

    def no_sensitivities(self, values):  # the path of a run that takes none
        self.exact_reason = "none here"

    monkeypatch.setattr(ident._Model, "_run_with_slopes", no_sensitivities)
    differenced = ident.fit(experiment.file, experiment.measurement, params)
    assert differenced.info["jacobian"] == "differences (none here)"
    assert differenced.simulations > exact.simulations
    for a, b in zip(exact.estimates, differenced.estimates, strict=True):
        assert abs(a.value - b.value) < 0.05 * a.std, a.path
        assert a.std == pytest.approx(b.std, rel=0.01), a.path


def test_a_driven_run_with_sensitivities_is_the_driven_run(experiment) -> None:
    """simulate_with_derivatives(drive=…) runs the scenario the fit's plain runs run (the
    measured angles in place of the file's profiles, to the end of the data), and gives plain
    arrays, one column per field."""
    from flexlink.experiment.comparison import measured_inputs
    from flexlink.simulation import simulate
    from flexlink.simulation.sensitivities import simulate_with_derivatives

    inputs = measured_inputs(experiment.file.build(), experiment.measurement)
    plain = simulate(inputs.drive(experiment.file.build()), shapes=False)
    with_slopes, slopes = simulate_with_derivatives(
        experiment.file, ["links[0].EI", "sensors[pzt].capacitance"], shapes=False,
        drive=inputs.drive)
    assert plain.time[-1] == pytest.approx(float(experiment.measurement.time[-1]))
    for name in plain.names:
        np.testing.assert_array_equal(with_slopes[name], plain[name])
        assert slopes[name].shape == (plain.time.size, 2)
    # the PZT's voltage goes as 1/C: its slope in C is −v/C
    c = float(experiment.file.locate("sensors[pzt].capacitance").value)
    np.testing.assert_allclose(slopes["pzt"][:, 1], -plain["pzt"] / c,
                               rtol=1e-6, atol=1e-9 * np.abs(plain["pzt"]).max() / c)
