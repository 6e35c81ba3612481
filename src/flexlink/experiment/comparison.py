"""Run a scenario with measured joint angles as inputs and compare its sensors with the
measured ones: normalised RMS error, correlation, peak error, and the dominant frequency and
damping of the free vibration after the manoeuvre, measured against simulated.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..channels import ChannelKind
from ..channels.catalogue import joint_name
from ..model import Scenario
from ..motion import MeasuredMotion
from ..results import Results
from .files import MeasurementError
from .measurement import MIN_SAMPLES, Measurement, MeasurementWarning
from .vibration import Manoeuvre, detect_manoeuvre, dominant_mode


@dataclass(frozen=True)
class SignalMetrics:
    """Measured vs simulated for one channel (SI units; frequencies Hz; errors relative)."""

    name: str
    unit: str
    nrmse: float  # RMS(sim − meas) / RMS(meas), whole run
    correlation: float  # Pearson, whole run
    peak_measured: float  # max |meas|
    peak_simulated: float  # max |sim|
    peak_error: float  # (peak_sim − peak_meas) / peak_meas
    frequency_measured: float | None  # Hz, dominant free-vibration component
    frequency_simulated: float | None
    frequency_error: float | None  # f_sim / f_meas − 1
    damping_measured: float | None  # damping ratio of that component
    damping_simulated: float | None

    def as_dict(self) -> dict[str, Any]:
        return dataclasses.asdict(self)

    def row(self) -> dict[str, Any]:
        """The row of metrics.csv and metrics.json (`METRIC_COLUMNS`)."""
        row = {}
        for column, name in METRIC_COLUMNS.items():
            value = getattr(self, name)
            percent = column.endswith("_pct") and value is not None
            row[column] = 100.0 * value if percent else value
        return row


# The columns of metrics.csv (keys of metrics.json's rows) → `SignalMetrics` fields. A fixed
# unit ends the name (as frequency_Hz of a plant's modes.csv, free_vibration_start_s):
# frequencies in Hz, relative errors in percent; the peaks are in the row's `unit` (the
# channel's); NRMSE, correlation and damping ratios are ratios.
METRIC_COLUMNS = {"name": "name", "unit": "unit", "nrmse": "nrmse",
                  "correlation": "correlation", "peak_measured": "peak_measured",
                  "peak_simulated": "peak_simulated", "peak_error_pct": "peak_error",
                  "frequency_measured_Hz": "frequency_measured",
                  "frequency_simulated_Hz": "frequency_simulated",
                  "frequency_error_pct": "frequency_error",
                  "damping_ratio_measured": "damping_measured",
                  "damping_ratio_simulated": "damping_simulated"}


@dataclass
class Comparison:
    """Simulation driven by a measurement, and the metrics of every compared channel."""

    results: Results
    measurement: Measurement
    measured: dict[str, np.ndarray]  # on results.time
    metrics: list[SignalMetrics]
    free_start: float | None  # s, start of the free-vibration window (None: none)


@dataclass(frozen=True)
class MeasuredInputs:
    """The measured joint angles as joint motions (spline fits, made once) and the end of the
    data (s): what drives a scenario in compare and in every simulation of a fit."""

    joints: dict[int, MeasuredMotion]  # joint index (0-based) → its measured motion
    t_last: float  # s

    def drive(self, scenario: Scenario) -> Scenario:
        """``scenario`` with the measured joints replaced, ending where the data do."""
        joints = list(scenario.chain.joints)
        for k, motion in self.joints.items():
            joints[k] = motion
        settings = scenario.settings
        if self.t_last < settings.t_end - 1e-9:
            settings = dataclasses.replace(settings, t_end=self.t_last)
        chain = dataclasses.replace(scenario.chain, joints=tuple(joints))
        return dataclasses.replace(scenario, chain=chain, settings=settings)


def measured_inputs(scenario: Scenario, measurement: Measurement) -> MeasuredInputs:
    """The measured joint motions of ``measurement`` (held once at rest, see `held_angles`);
    warns when the data end before ``scenario``'s t_end."""
    joints = {k: MeasuredMotion.from_arrays(measurement.time, np.degrees(angle),
                                            name=f"{joint_name(k, 'angle')} ({measurement.source})")
              for k, angle in held_angles(measurement).items()}
    t_last = float(measurement.time[-1])
    t_end = scenario.settings.t_end
    _check_overlap(measurement, t_end)
    if t_last < t_end - 1e-9:
        warnings.warn(f"{measurement.source}: the data end at t = {t_last:g} s, before "
                      f"simulation.t_end = {t_end:g} s; simulating up to {t_last:g} s",
                      MeasurementWarning, stacklevel=2)
        measurement.notes.append(f"simulated up to the end of the data, t = {t_last:g} s")
    return MeasuredInputs(joints, t_last)


def _check_overlap(measurement: Measurement, t_end: float) -> None:
    """Refuse data with too few samples within the run, 0 to ``t_end`` (s), most likely a
    time column in other units; warn where the data go on past it (not compared)."""
    t = measurement.time
    inside = int(np.count_nonzero(t <= t_end + 1e-9 * max(1.0, t_end)))
    if inside < MIN_SAMPLES:
        raise MeasurementError(
            f"{measurement.source}: only {inside} of the {t.size} samples lie within the run, "
            f"0 to simulation.t_end = {t_end:g} s (the data span {t[0]:g} to {t[-1]:g} s "
            f"every {t[1] - t[0]:g} s); if the time column is not in seconds set time_unit "
            "(\"ms\", \"us\", \"min\") in [measurement], else raise simulation.t_end")
    step = float(t[1] - t[0])
    if t[-1] > t_end + 0.5 * step:
        warnings.warn(f"{measurement.source}: the data go on to t = {t[-1]:g} s, past "
                      f"simulation.t_end = {t_end:g} s; compared up to {t_end:g} s (raise "
                      "simulation.t_end to use the rest)", MeasurementWarning, stacklevel=3)
        note = f"compared up to simulation.t_end = {t_end:g} s; the data go on to {t[-1]:g} s"
        if note not in measurement.notes:
            measurement.notes.append(note)


def driven_scenario(scenario: Scenario, measurement: Measurement) -> Scenario:
    """``scenario`` with the measured joint angles as joint motions, ending where the data do."""
    return measured_inputs(scenario, measurement).drive(scenario)


HOLD_RAMP = 0.05  # s, blend between the measured and the held angle


def manoeuvre(measurement: Measurement, results: Results | None = None) -> Manoeuvre:
    """The joints' manoeuvre in the measured angles (and in the simulated angles of joints
    the measurement does not drive), with ``free_vibration_start`` of the spec if given."""
    t = measurement.time
    angles = {joint_name(k, "angle"): a for k, a in measurement.angles.items()}
    if results is not None:
        for name in results.names_of(ChannelKind.JOINT):
            if results.channels[name].quantity == "angle" and name not in angles:
                angles[name] = np.interp(t, results.time, results[name])
    found = detect_manoeuvre(t, angles)
    given = measurement.spec.free_vibration_start
    if given is not None:
        found = dataclasses.replace(found, free_start=given, reason="")
    return found


def held_angles(measurement: Measurement) -> dict[int, np.ndarray]:
    """The measured joint angles held at their rest values before and after the manoeuvre:
    the initial angle (median at rest) up to ``margin`` before the move starts, the final one
    (median of the rest after it) from the free vibration's start, blended in over HOLD_RAMP.
    Angle-sensor noise at rest would otherwise drive the model — a forcing the real arm, whose
    joints are at rest, does not feel — and bias its decay and the gains (docs/experiment.md)."""
    angles = dict(measurement.angles)
    if not measurement.spec.hold_after_manoeuvre or not angles:
        return angles
    t = measurement.time
    move = manoeuvre(measurement)
    hold_from = move.free_start
    hold_to = move.start - move.margin - HOLD_RAMP if move.end > move.start else None
    out = {}
    for k, angle in angles.items():
        held = angle
        if hold_to is not None and hold_to > t[0]:
            weight = _ramp((hold_to - t) / HOLD_RAMP)
            held = (1.0 - weight) * held + weight * float(np.median(angle[t <= hold_to]))
        if hold_from is not None and hold_from < t[-1]:
            weight = _ramp((t - hold_from) / HOLD_RAMP)
            held = (1.0 - weight) * held + weight * float(np.median(angle[t >= hold_from]))
        out[k] = held
    notes = []
    if hold_to is not None and hold_to > t[0]:
        notes.append(f"joint angles held at their initial values up to t = {hold_to:.4g} s")
    if hold_from is not None and hold_from < t[-1]:
        notes.append(f"joint angles held at their final values from t = {hold_from:.4g} s")
    for note in notes:
        note += " (the joints are at rest; angle noise would drive the model)"
        if note not in measurement.notes:
            measurement.notes.append(note)
    return out


def _ramp(s: np.ndarray) -> np.ndarray:
    """0 for s ≤ 0, 1 for s ≥ 1, a cosine between."""
    return 0.5 * (1.0 - np.cos(np.pi * np.clip(s, 0.0, 1.0)))


def free_vibration_start(measurement: Measurement, results: Results) -> float | None:
    """Start (s) of the free vibration: the spec's value, else detected from the joint angles;
    warns with the reason when there is none."""
    found = manoeuvre(measurement, results)
    if found.free_start is None:
        _warn_once(measurement, f"no free-vibration window: {found.reason}; frequency and "
                                "damping are not estimated (set free_vibration_start in "
                                "[measurement] or --free-from if the arm is at rest)")
    return found.free_start


EARLY_FRACTION = 0.05  # of the simulated peak: a response before the move beyond this is warned


def _check_early_response(results: Results, measured: dict[str, np.ndarray], start: float,
                          measurement: Measurement) -> None:
    """Warn when a simulated channel responds before any measured joint moves (start, s)
    while the measured one is quiet: the model is driven by something the arm did not do
    (angle noise, with the hold switched off, or a joint profile moving early)."""
    before = results.time < start - HOLD_RAMP
    if before.sum() < 10:
        return
    for name, meas in measured.items():
        sim = results[name]
        quiet, early = float(np.std(meas[before])), float(np.std(sim[before]))
        if early > max(3.0 * quiet, EARLY_FRACTION * float(np.ptp(sim))):
            _warn_once(measurement, f"simulated {name} responds before the measured motion "
                                    f"starts at t = {start:.4g} s ({early:.3g} RMS against "
                                    f"{quiet:.3g} measured): the model is driven by what the "
                                    "arm did not do (angle noise? hold the joints at rest)")


def _warn_once(measurement: Measurement, message: str) -> None:
    """A MeasurementWarning, also kept in the measurement's notes (the report lists them)."""
    if message not in measurement.notes:
        measurement.notes.append(message)
        warnings.warn(f"{measurement.source}: {message}", MeasurementWarning, stacklevel=3)


def on_grid(measurement: Measurement, t: np.ndarray) -> dict[str, np.ndarray]:
    """Measured signals interpolated linearly onto the times t (s)."""
    return {name: np.interp(t, measurement.time, values)
            for name, values in measurement.signals.items()}


def signal_metrics(name: str, unit: str, t: np.ndarray, measured: np.ndarray,
                   simulated: np.ndarray, free_start: float | None) -> SignalMetrics:
    """All metrics of one channel; frequency/damping None when there is no usable window."""
    err = simulated - measured
    rms_meas = math.sqrt(float(np.mean(measured**2)))
    nrmse = math.sqrt(float(np.mean(err**2))) / rms_meas if rms_meas > 0 else math.inf
    corr = (float(np.corrcoef(measured, simulated)[0, 1])
            if np.std(measured) > 0 and np.std(simulated) > 0 else 0.0)
    peak_m, peak_s = float(np.abs(measured).max()), float(np.abs(simulated).max())
    fm = fs = zm = zs = None
    if free_start is not None:
        window = t >= free_start
        mode_m = dominant_mode(t[window], measured[window])
        mode_s = dominant_mode(t[window], simulated[window])
        if mode_m is not None:
            fm, zm = mode_m.frequency_hz, mode_m.damping_ratio
        if mode_s is not None:
            fs, zs = mode_s.frequency_hz, mode_s.damping_ratio
    return SignalMetrics(
        name=name, unit=unit, nrmse=nrmse, correlation=corr, peak_measured=peak_m,
        peak_simulated=peak_s, peak_error=(peak_s - peak_m) / peak_m if peak_m > 0 else math.inf,
        frequency_measured=fm, frequency_simulated=fs,
        frequency_error=fs / fm - 1.0 if fm and fs else None,
        damping_measured=zm, damping_simulated=zs)


def compare(scenario: Scenario, measurement: Measurement, progress: bool = False) -> Comparison:
    """Simulate ``scenario`` driven by ``measurement``'s angles; metrics of every measured
    sensor channel."""
    if not measurement.signals:
        raise MeasurementError(f"{measurement.source}: no sensor column to compare with (only "
                               "joint angles are mapped)")
    results = simulate_driven(driven_scenario(scenario, measurement), measurement,
                              progress=progress)
    return evaluate(results, measurement)


def simulate_driven(scenario: Scenario | None, measurement: Measurement,
                    progress: bool = False, run: Callable[[], Results] | None = None
                    ) -> Results:
    """``simulate(scenario)`` (or ``run()``: the fit's runs with sensitivities); if it fails
    while a measured angle is too noisy to drive the model (`measurement.noisy_angles`), the
    error names that column as the likely cause."""
    from ..errors import SimulationError
    from ..simulation import simulate

    try:
        return run() if run is not None else simulate(scenario, progress=progress)
    except SimulationError as exc:
        if not measurement.noisy_angles:
            raise
        raise SimulationError(f"{exc}\nLikely cause: the measured joint accelerations are "
                              "noise, not motion. "
                              + " ".join(measurement.noisy_angles.values())) from exc


def evaluate(results: Results, measurement: Measurement) -> Comparison:
    """Metrics of a finished simulation against the measurement."""
    measured = on_grid(measurement, results.time)
    free = free_vibration_start(measurement, results)
    _check_early_response(results, measured, manoeuvre(measurement, results).start,
                          measurement)
    metrics = [signal_metrics(name, measurement.units[name], results.time, values,
                              results[name], free)
               for name, values in measured.items()]
    return Comparison(results=results, measurement=measurement, measured=measured,
                      metrics=metrics, free_start=free)
