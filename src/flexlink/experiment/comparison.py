"""Run a scenario with measured joint angles as inputs and compare its sensors with the
measured ones: normalised RMS error, correlation, peak error, and the dominant frequency and
damping of the free vibration after the manoeuvre, measured against simulated.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..channels import ChannelKind
from ..channels.catalogue import joint_name
from ..model import Scenario
from ..motion import MeasuredMotion
from ..results import Results
from .files import MeasurementError
from .measurement import Measurement, MeasurementWarning
from .vibration import dominant_mode, manoeuvre_end


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
    if t_last < t_end - 1e-9:
        warnings.warn(f"{measurement.source}: the data end at t = {t_last:g} s, before "
                      f"simulation.t_end = {t_end:g} s; simulating up to {t_last:g} s",
                      MeasurementWarning, stacklevel=2)
        measurement.notes.append(f"simulated up to the end of the data, t = {t_last:g} s")
    return MeasuredInputs(joints, t_last)


def driven_scenario(scenario: Scenario, measurement: Measurement) -> Scenario:
    """``scenario`` with the measured joint angles as joint motions, ending where the data do."""
    return measured_inputs(scenario, measurement).drive(scenario)


HOLD_RAMP = 0.05  # s, blend from the measured to the held angle


def held_angles(measurement: Measurement) -> dict[int, np.ndarray]:
    """The measured joint angles, held at their final value (median of the rest) once the
    manoeuvre has ended, blended in over HOLD_RAMP from the window's start. Angle-sensor noise after the
    manoeuvre would otherwise drive the model's free vibration — a forcing the real arm, whose
    joints are at rest, does not feel — and bias its decay (docs/experiment.md)."""
    angles = dict(measurement.angles)
    if not measurement.spec.hold_after_manoeuvre or not angles:
        return angles
    t = measurement.time
    start = measurement.spec.free_vibration_start
    if start is None:
        start = manoeuvre_end(t, list(angles.values()))
    if start is None or start >= t[-1]:
        return angles
    s = np.clip((t - start) / HOLD_RAMP, 0.0, 1.0)
    weight = 0.5 * (1.0 - np.cos(np.pi * s))
    out = {}
    for k, angle in angles.items():
        final = float(np.median(angle[t >= start]))
        out[k] = (1.0 - weight) * angle + weight * final
    note = (f"joint angles held at their final values from t = {start:.4g} s (the joints are "
            "at rest; angle noise would drive the model)")
    if note not in measurement.notes:
        measurement.notes.append(note)
    return out


def free_vibration_start(measurement: Measurement, results: Results) -> float | None:
    """Start (s) of the free vibration: the spec's value, else detected from the joint angles."""
    if measurement.spec.free_vibration_start is not None:
        return measurement.spec.free_vibration_start
    angles = [results[name] for name in results.names_of(ChannelKind.JOINT)
              if results.channels[name].quantity == "angle"]
    return manoeuvre_end(results.time, angles)


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
    from ..simulation import simulate

    if not measurement.signals:
        raise MeasurementError(f"{measurement.source}: no sensor column to compare with (only "
                               "joint angles are mapped)")
    results = simulate(driven_scenario(scenario, measurement), progress=progress)
    return evaluate(results, measurement)


def evaluate(results: Results, measurement: Measurement) -> Comparison:
    """Metrics of a finished simulation against the measurement."""
    measured = on_grid(measurement, results.time)
    free = free_vibration_start(measurement, results)
    metrics = [signal_metrics(name, measurement.units[name], results.time, values,
                              results[name], free)
               for name, values in measured.items()]
    return Comparison(results=results, measurement=measurement, measured=measured,
                      metrics=metrics, free_start=free)
