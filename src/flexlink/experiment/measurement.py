"""Measured data in: which file column is which joint or sensor, in what unit, and the
conditioning every column gets before it meets the model.

A mapping comes from a scenario's ``[measurement]`` section, from ``--map`` options, or by
default from column names (``joint<k>_angle`` in rad and sensor names in SI, i.e. the layout
of a ``results.csv`` written by ``flexlink run``). Conditioning, in this order: time scaled and
shifted onto the simulation clock; time must not run backwards (error); duplicated time stamps
are dropped (warning); short runs of NaN are interpolated (warning), long ones are errors;
non-uniform sampling is resampled onto a uniform grid, and gaps of a few samples are bridged
(warning), longer gaps are errors; units and scale applied; zero-phase low-pass where asked.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..channels import Channel, ChannelKind, Unit
from ..channels.catalogue import catalogue, joint_name
from ..model import Scenario
from ..motion.measured import zero_phase_lowpass
from ..scenario.errors import Problems
from .files import MeasurementError
from .vibration import EDGE_S, joint_rest

MAX_FILL = 10  # samples: longer runs of NaN, or longer gaps in time, are errors
UNIFORM_RTOL = 1e-3  # steps within this fraction of the median step count as uniform
MEASUREMENT_KEYS = ("file", "time_column", "time_unit", "time_offset", "free_vibration_start",
                    "hold_after_manoeuvre", "columns")
COLUMN_KEYS = ("column", "joint", "sensor", "unit", "scale", "offset", "lowpass_hz")
MIN_SAMPLES = 4  # the fewest samples a measurement (and its part within the run) may have
TIME_UNITS = {"s": 1.0, "ms": 1e-3, "us": 1e-6, "min": 60.0}
# unit name → (factor to SI, SI unit in UDUNITS spelling, as the channel records give it);
# the older spellings m/s^2 and N*m are still read
UNITS: dict[str, tuple[float, str]] = {
    "rad": (1.0, Unit.RADIAN), "deg": (math.pi / 180.0, Unit.RADIAN),
    "mrad": (1e-3, Unit.RADIAN),
    "m": (1.0, Unit.METRE), "mm": (1e-3, Unit.METRE), "um": (1e-6, Unit.METRE),
    "m s-2": (1.0, Unit.METRE_PER_SECOND2), "mm s-2": (1e-3, Unit.METRE_PER_SECOND2),
    "m/s^2": (1.0, Unit.METRE_PER_SECOND2), "mm/s^2": (1e-3, Unit.METRE_PER_SECOND2),
    "g": (9.80665, Unit.METRE_PER_SECOND2),
    "V": (1.0, Unit.VOLT), "mV": (1e-3, Unit.VOLT),
    "1": (1.0, Unit.ONE), "strain": (1.0, Unit.ONE), "ustrain": (1e-6, Unit.ONE),
    "N m": (1.0, Unit.NEWTON_METRE), "N*m": (1.0, Unit.NEWTON_METRE),
    "rad s-1": (1.0, Unit.RADIAN_PER_SECOND), "deg s-1": (math.pi / 180.0, Unit.RADIAN_PER_SECOND),
    "m s-1": (1.0, Unit.METRE_PER_SECOND),
}


class MeasurementWarning(UserWarning):
    """Something in the data was repaired by a standard fix; the message says what was done."""


@dataclass(frozen=True)
class ColumnMap:
    """One file column → joint ``joint`` (0-based) or channel ``sensor``, SI = unit·(scale·raw + offset)."""

    column: str
    joint: int | None = None
    sensor: str | None = None
    unit: str | None = None  # None: the SI unit of the target
    scale: float = 1.0
    offset: float = 0.0  # in ``unit``
    lowpass_hz: float | None = None

    @property
    def target(self) -> str:
        return joint_name(self.joint, "angle") if self.joint is not None else str(self.sensor)


@dataclass(frozen=True)
class MeasurementSpec:
    """How to read one measurement file (the resolved ``[measurement]`` section)."""

    file: str | None = None
    time_column: str = "t"
    time_unit: str = "s"
    time_offset: float = 0.0  # s, added to the file's times to get simulation time
    free_vibration_start: float | None = None  # s; None: detected from the joint angles
    # joints at rest after the manoeuvre: hold their angles (sensor noise is not motion)
    hold_after_manoeuvre: bool = True
    columns: tuple[ColumnMap, ...] = ()  # empty: map columns by name

    def as_dict(self) -> dict[str, Any]:
        """The spec as a TOML-ready dict (None values left out)."""
        out: dict[str, Any] = {k: getattr(self, k) for k in MEASUREMENT_KEYS if k != "columns"}
        out["columns"] = [{k: v for k, v in (
            ("column", c.column), ("joint", None if c.joint is None else c.joint + 1),
            ("sensor", c.sensor), ("unit", c.unit), ("scale", c.scale), ("offset", c.offset),
            ("lowpass_hz", c.lowpass_hz)) if v is not None} for c in self.columns]
        return {k: v for k, v in out.items() if v is not None}


@dataclass
class Measurement:
    """Conditioned data on a uniform time grid (s, simulation clock), SI units."""

    time: np.ndarray
    angles: dict[int, np.ndarray]  # joint index (0-based) → angle, rad
    signals: dict[str, np.ndarray]  # channel name → values in the channel's SI unit
    units: dict[str, str]
    source: str
    spec: MeasurementSpec
    notes: list[str] = field(default_factory=list)  # every repair, as warned
    # joint index (0-based) → why its angle is too noisy to drive the model (warned)
    noisy_angles: dict[int, str] = field(default_factory=dict)


def channel_units(scenario: Scenario) -> dict[str, str]:
    """Unit of every channel a simulation of ``scenario`` produces, except the joint angles
    (those are inputs: a column maps to ``joint = k``)."""
    angles = {c.name for c in joint_angle_channels(scenario)}
    return {c.name: c.unit for c in catalogue(scenario) if c.name not in angles}


def joint_angle_channels(scenario: Scenario) -> list[Channel]:
    """The joint-angle channels, joint 1 first (the catalogue lists them in joint order)."""
    return [c for c in catalogue(scenario)
            if c.kind == ChannelKind.JOINT and c.quantity == "angle"]


def parse_spec(table: Mapping[str, Any] | None, scenario: Scenario,
               source: str = "[measurement]") -> MeasurementSpec:
    """Validate a ``[measurement]`` table (all problems at once, as MeasurementError)."""
    if table is None:
        return MeasurementSpec()
    p = Problems()
    path = "measurement"
    if not isinstance(table, Mapping):
        raise MeasurementError(f"{source}: [measurement] must be a table")
    p.unknown_keys(table, MEASUREMENT_KEYS, path)
    file = p.string(table, "file", path, default=None)
    spec: dict[str, Any] = {
        "file": file,
        "time_column": p.string(table, "time_column", path, default="t"),
        "time_unit": p.string(table, "time_unit", path, default="s", choices=TIME_UNITS),
        "time_offset": p.number(table, "time_offset", path, unit="s", default=0.0),
        "free_vibration_start": p.number(table, "free_vibration_start", path, unit="s",
                                         ge=0, default=None),
        "hold_after_manoeuvre": p.boolean(table, "hold_after_manoeuvre", path, default=True),
    }
    columns = []
    for cpath, ctable in p.table_array(table, "columns", required=False):
        parsed = _column(ctable, f"measurement.{cpath}", scenario, p)
        if parsed is not None:
            columns.append(parsed)
    _check_targets(columns, p)
    if p:
        raise MeasurementError("\n".join([f"{source} has {len(p.messages)} problem(s):",
                                          *(f"  - {m}" for m in p.messages)]))
    return MeasurementSpec(**{k: v for k, v in spec.items() if v is not None},
                           columns=tuple(columns))


def parse_map_option(text: str, scenario: Scenario) -> ColumnMap:
    """``COLUMN=TARGET[,unit=U][,scale=S][,offset=O][,lowpass_hz=F]`` from the command line;
    TARGET is ``joint<k>`` or a sensor/channel name."""
    head, *options = [part.strip() for part in text.split(",")]
    if "=" not in head:
        raise MeasurementError(f"--map {text!r}: expected COLUMN=TARGET (TARGET joint<k> or a "
                               "sensor name), e.g. --map beta1=joint1,unit=deg")
    column, target = (s.strip() for s in head.split("=", 1))
    table: dict[str, Any] = {"column": column}
    joints = [k for k, c in enumerate(joint_angle_channels(scenario))
              if target in (c.name, c.subject)]  # joint2_angle, or joint2
    if joints:
        table["joint"] = joints[0] + 1
    else:
        table["sensor"] = target
    for option in options:
        key, sep, value = option.partition("=")
        if not sep:
            raise MeasurementError(f"--map {text!r}: option {option!r} must be KEY=VALUE")
        key = key.strip()
        try:
            table[key] = value.strip() if key == "unit" else float(value)
        except ValueError:
            raise MeasurementError(f"--map {text!r}: {key} must be a number, got "
                                   f"{value!r}") from None
    p = Problems()
    parsed = _column(table, f"--map {text!r}", scenario, p)
    if p or parsed is None:
        raise MeasurementError("\n".join(p.messages))
    return parsed


def _column(table: Mapping[str, Any], path: str, scenario: Scenario,
            p: Problems) -> ColumnMap | None:
    before = len(p.messages)
    p.unknown_keys(table, COLUMN_KEYS, path)
    column = p.string(table, "column", path)
    joint = sensor = None
    n_joints = len(scenario.chain.links)
    units = channel_units(scenario)
    if ("joint" in table) == ("sensor" in table):
        p.add(f"{path}: give exactly one of 'joint' (1 … {n_joints}) or 'sensor' (one of "
              f"{', '.join(repr(n) for n in units)})")
    elif "joint" in table:
        joint = p.integer(table, "joint", path, ge=1, le=n_joints)
    else:
        sensor = p.string(table, "sensor", path)
        if sensor is not None and sensor not in units:
            p.add(f"{path}.sensor: the scenario has no sensor or channel {sensor!r} (known: "
                  f"{', '.join(repr(n) for n in units)})")
    unit = p.string(table, "unit", path, default=None, choices=UNITS)
    si = Unit.RADIAN if joint is not None else units.get(sensor or "")
    if unit is not None and si is not None and UNITS[unit][1] != si:
        allowed = ", ".join(repr(u) for u, (_, s) in UNITS.items() if s == si)
        p.add(f"{path}.unit {unit!r} does not fit {'a joint angle' if joint else sensor!r} "
              f"({si}); allowed: {allowed}")
    scale = p.number(table, "scale", path, default=1.0, nonzero=True)
    offset = p.number(table, "offset", path, default=0.0)
    lowpass = p.number(table, "lowpass_hz", path, unit="Hz", gt=0, default=None)
    if len(p.messages) > before or column is None:
        return None
    return ColumnMap(column=column, joint=None if joint is None else joint - 1, sensor=sensor,
                     unit=unit, scale=float(scale or 1.0), offset=float(offset or 0.0),
                     lowpass_hz=lowpass)


def _check_targets(columns: Sequence[ColumnMap], p: Problems) -> None:
    seen: dict[str, str] = {}
    for c in columns:
        if c.target in seen:
            p.add(f"measurement: columns {seen[c.target]!r} and {c.column!r} both map to "
                  f"{c.target}")
        seen[c.target] = c.column


def default_columns(names: Sequence[str], scenario: Scenario) -> tuple[ColumnMap, ...]:
    """Map by name: joint-angle channels (``joint1_angle``, rad) and sensors (SI)."""
    joints = {c.name: k for k, c in enumerate(joint_angle_channels(scenario))}
    sensors = {c.name for c in catalogue(scenario) if c.kind == ChannelKind.SENSOR}
    out = []
    for name in names:
        if name in joints:
            out.append(ColumnMap(column=name, joint=joints[name]))
        elif name in sensors:
            out.append(ColumnMap(column=name, sensor=name))
    return tuple(out)


def condition(columns: Mapping[str, np.ndarray], spec: MeasurementSpec, scenario: Scenario,
              source: str) -> Measurement:
    """Apply ``spec`` to raw file columns: checks, repairs (warned), units, filtering."""
    maps = spec.columns or default_columns(list(columns), scenario)
    if not maps:
        raise MeasurementError(
            f"{source}: no column is mapped to a joint or sensor. Map them in the scenario's "
            "[measurement] section or with --map COLUMN=TARGET; by default columns named "
            f"joint<k>_angle (rad) or like a sensor ({', '.join(s.name for s in scenario.sensors)}"
            f") are used. File columns: {', '.join(columns)}")
    missing = [c.column for c in maps if c.column not in columns]
    if spec.time_column not in columns:
        missing.insert(0, spec.time_column)
    if missing:
        raise MeasurementError(f"{source}: no column {', '.join(repr(m) for m in missing)}; "
                               f"available columns: {', '.join(columns)}")
    notes: list[str] = []
    hints: dict[int, str] = {}

    def warn(message: str, category: type[MeasurementWarning] = MeasurementWarning) -> None:
        notes.append(message)
        warnings.warn(f"{source}: {message}", category, stacklevel=3)

    t = np.asarray(columns[spec.time_column], dtype=float) * TIME_UNITS[spec.time_unit]
    t = t + spec.time_offset
    data = {c.column: np.asarray(columns[c.column], dtype=float) for c in maps}
    for name, values in data.items():
        if values.shape != t.shape:
            raise MeasurementError(f"{source}: column {name!r} has {values.size} samples but "
                                   f"time column {spec.time_column!r} has {t.size}")
    t, data = _clean_time(t, data, spec.time_column, source, warn)
    data = {name: _fill_nan(t, values, name, source, warn) for name, values in data.items()}
    t, data = _uniform(t, data, source, warn, notes)
    # the offset that puts the first sample at 0, whatever offset is already applied
    fix = (f"set time_offset = {spec.time_offset - t[0]:g} (s) in [measurement] or "
           "--time-offset to shift them")
    if t[0] > 1e-9 * max(1.0, abs(t[-1])):
        raise MeasurementError(
            f"{source}: the data start at t = {t[0]:g} s on the simulation clock, but the "
            f"simulation starts at 0 s; {fix}")
    if t[-1] <= 0.0:
        raise MeasurementError(
            f"{source}: the data end at t = {t[-1]:g} s on the simulation clock, before the "
            f"simulation starts at 0 s; {fix}")
    free = spec.free_vibration_start
    if free is not None and not t[0] <= free < t[-1]:
        raise MeasurementError(
            f"{source}: free_vibration_start (--free-from) = {free:g} s is outside the data, "
            f"{t[0]:g} to {t[-1]:g} s on the simulation clock")
    angles: dict[int, np.ndarray] = {}
    signals: dict[str, np.ndarray] = {}
    units: dict[str, str] = {}
    units_of = channel_units(scenario)
    for c in maps:
        si_unit = Unit.RADIAN if c.joint is not None else units_of[str(c.sensor)]
        factor = UNITS[c.unit][0] if c.unit else 1.0
        values = factor * (c.scale * data[c.column] + c.offset)
        if c.lowpass_hz is not None:
            values = lowpass(t, values, c.lowpass_hz, f"{source}: column {c.column!r}")
        if c.joint is not None:
            quantised = c.lowpass_hz is None and _check_quantised(values, c.column, warn)
            noisy = None if quantised else _check_noisy(t, values, c.column, c.lowpass_hz, warn)
            if noisy:
                hints[c.joint] = noisy
            angles[c.joint] = values
        else:
            if values.size and np.ptp(values) == 0.0:
                warn(f"sensor column {c.column!r} ({c.sensor}) is constant ({values[0]:g}) "
                     "over the whole record: a dead or unplugged channel? Its comparison "
                     "metrics are infinite (normalised by its zero spread) and its "
                     "correlation undefined; check the file or drop the column",
                     ConstantChannelWarning)
            signals[str(c.sensor)] = values
        units[c.target] = si_unit
    return Measurement(time=t, angles=angles, signals=signals, units=units, source=source,
                       spec=spec, notes=notes, noisy_angles=hints)


def _clean_time(t: np.ndarray, data: dict[str, np.ndarray], name: str, source: str,
                warn: Any) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    if t.size < MIN_SAMPLES:
        raise MeasurementError(f"{source}: need at least {MIN_SAMPLES} samples, got {t.size}")
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size:
        raise MeasurementError(f"{source}: time column {name!r} has {bad.size} missing or "
                               f"non-finite value(s), the first at data row {bad[0] + 1}")
    steps = np.diff(t)
    back = np.flatnonzero(steps < 0)
    if back.size:
        i = int(back[0]) + 1
        raise MeasurementError(
            f"{source}: time goes backwards at data row {i + 1} (t = {t[i]:g} s after "
            f"{t[i - 1]:g} s); sort the file or split concatenated records")
    dup = np.flatnonzero(steps == 0) + 1
    if dup.size:
        keep = np.ones(t.size, dtype=bool)
        keep[dup] = False
        warn(f"{dup.size} duplicated time stamp(s) (first at t = {t[dup[0]]:g} s): kept the "
             "first sample of each, dropped the repeats")
        t = t[keep]
        data = {k: v[keep] for k, v in data.items()}
    return t, data


def _fill_nan(t: np.ndarray, values: np.ndarray, name: str, source: str,
              warn: Any) -> np.ndarray:
    bad = ~np.isfinite(values)
    if not bad.any():
        return values
    if bad.all():
        raise MeasurementError(f"{source}: column {name!r} has no valid values")
    edges = np.diff(np.concatenate([[0], bad.astype(int), [0]]))
    starts, ends = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)
    longest = int(np.argmax(ends - starts))
    if ends[longest] - starts[longest] > MAX_FILL:
        raise MeasurementError(
            f"{source}: column {name!r} has {ends[longest] - starts[longest]} missing or "
            f"non-finite (NaN, inf) samples in a row from t = {t[starts[longest]]:g} s; at most {MAX_FILL} are "
            "interpolated. Cut the file or fix the data there")
    filled = values.copy()
    filled[bad] = np.interp(t[bad], t[~bad], values[~bad])
    infinite = int(np.isinf(values).sum())
    warn(f"column {name!r}: {int(bad.sum())} missing or non-finite sample(s)"
         + (f" ({infinite} of them ±inf: an overflow or a saturated sensor?)" if infinite else "")
         + " filled by linear "
         f"interpolation (first at t = {t[np.argmax(bad)]:g} s)")
    return filled


def _uniform(t: np.ndarray, data: dict[str, np.ndarray], source: str, warn: Any,
             notes: list[str]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    steps = np.diff(t)
    h = float(np.median(steps))
    if np.max(np.abs(steps - h)) <= UNIFORM_RTOL * h:
        return t, data
    gaps = np.flatnonzero(steps > 1.5 * h)
    if gaps.size:
        worst = int(gaps[np.argmax(steps[gaps])])
        if steps[worst] > MAX_FILL * h:
            raise MeasurementError(
                f"{source}: gap of {steps[worst]:g} s in the data at t = {t[worst]:g} s "
                f"(the sampling step is {h:g} s); gaps longer than {MAX_FILL} steps are not "
                "bridged. Cut the file or fix the data there")
        warn(f"{gaps.size} gap(s) in time up to {steps[worst]:g} s (first at t = "
             f"{t[gaps[0]]:g} s) bridged by linear interpolation")
    grid = t[0] + h * np.arange(math.floor((t[-1] - t[0]) / h * (1 + 1e-12)) + 1)
    notes.append(f"non-uniform sampling resampled onto a uniform {h:g} s grid (linear)")
    return grid, {k: np.interp(grid, t, v) for k, v in data.items()}


def _check_quantised(angle: np.ndarray, name: str, warn: Any) -> bool:
    """Warn about a stepped (encoder) angle fed unfiltered to the spline, whose second
    derivative — the joint acceleration driving the model — is then spikes."""
    steps = np.diff(angle)
    changing = np.flatnonzero(steps != 0.0)
    if changing.size < 10:
        return False
    during = steps[changing[0]:changing[-1] + 1]  # from the first change to the last
    flat = float(np.mean(during == 0.0))
    if flat > 0.3:
        size = float(np.min(np.abs(steps[steps != 0]))) if np.any(steps != 0) else 0.0
        warn(f"column {name!r}: the angle moves in steps of {math.degrees(size):.3g} deg "
             f"(quantised) and is not filtered; its second derivative drives the model as "
             "acceleration spikes. Set lowpass_hz (e.g. 30)")
        return True
    return False


def lowpass(t: np.ndarray, values: np.ndarray, cutoff_hz: float, label: str) -> np.ndarray:
    """Zero-phase Butterworth low-pass (order 4, forward and backward) on a uniform grid."""
    fs = (t.size - 1) / (t[-1] - t[0])
    if cutoff_hz >= 0.5 * fs:
        raise MeasurementError(f"{label}: lowpass_hz = {cutoff_hz:g} Hz must be below the "
                               f"Nyquist frequency {0.5 * fs:g} Hz of the samples")
    return zero_phase_lowpass(values, cutoff_hz, fs)


class ConstantChannelWarning(MeasurementWarning):
    """A measured sensor column never changes (a dead channel): nothing to compare against;
    the message names the column."""


class NoisyAngleWarning(MeasurementWarning):
    """A measured joint angle is so noisy that the spline's second derivative — the joint
    acceleration driving the model — is mostly noise; the message names the column and a
    ``lowpass_hz`` that would do."""


NOISE_RATIO = 1.0  # noise-driven joint acceleration (RMS at rest) / manoeuvre's: warned above
CUTOFFS_HZ = (100.0, 50.0, 30.0, 20.0, 15.0, 10.0, 7.0, 5.0, 3.0, 2.0, 1.0)  # suggestions
MIN_CUTOFF_CYCLES = 5.0  # a suggested cut-off keeps ≥ this many cycles per move duration


def _check_noisy(t: np.ndarray, angle: np.ndarray, column: str, cutoff_hz: float | None,
                 warn: Any) -> str | None:
    """Warn when the angle's noise at rest, differentiated twice, gives joint accelerations
    beyond NOISE_RATIO × the manoeuvre's (4·travel/duration², the least any rest-to-rest move
    of that travel and duration needs); suggest the highest cut-off from CUTOFFS_HZ that
    brings them below half of that. Returns the warning's text (None: not noisy)."""
    rest = joint_rest(t, angle)
    if rest is None or rest.end <= rest.start:
        return None
    duration = rest.end - rest.start
    a_move = 4.0 * rest.travel / (duration * (1.0 + 2.0 * rest.hidden)) ** 2
    spare = rest.hidden * duration + EDGE_S
    before = (t < rest.start - spare) & (t > t[0] + EDGE_S)
    after = (t > rest.end + spare) & (t < t[-1] - EDGE_S)
    at_rest = before | after
    if at_rest.sum() < 10:
        return None
    a_noise = _acceleration_rms(t, angle, at_rest)
    if a_noise <= NOISE_RATIO * a_move:
        return None
    fs = (t.size - 1) / (t[-1] - t[0])
    floor = MIN_CUTOFF_CYCLES / duration
    usable = [f for f in CUTOFFS_HZ if floor <= f < min(0.5 * fs, cutoff_hz or math.inf)]
    good = [f for f in usable if _acceleration_rms(
        t, zero_phase_lowpass(angle, f, fs), at_rest) <= 0.5 * NOISE_RATIO * a_move]
    if good:
        advice = f"set lowpass_hz = {good[0]:g} (Hz) on this column"
    else:
        advice = (f"even lowpass_hz = {min(usable, default=floor):.3g} Hz (the lowest that "
                  "keeps the manoeuvre) leaves it noisy: check the sensor")
    noise = math.sqrt(np.mean([np.var(angle[part]) for part in (before, after) if part.any()]))
    message = (f"column {column!r}: its noise at rest ({math.degrees(noise):.2g} deg{'' if cutoff_hz is None else f' after lowpass_hz = {cutoff_hz:g}'}) "
               f"makes joint accelerations of {a_noise:.3g} rad s-2 RMS through the spline's "
               f"second derivative, {a_noise / a_move:.3g}× the manoeuvre's "
               f"({a_move:.3g} rad s-2); they drive the model (a run may stop with a spurious "
               f"large deflection). {advice[0].upper()}{advice[1:]}")
    warn(message, NoisyAngleWarning)
    return message


def _acceleration_rms(t: np.ndarray, angle: np.ndarray, mask: np.ndarray) -> float:
    """RMS (rad/s²) of the second differences of angle (rad) over the samples in mask."""
    dt = float(t[1] - t[0])
    inner = mask[1:-1] & mask[:-2] & mask[2:]
    d2 = (angle[2:] - 2.0 * angle[1:-1] + angle[:-2])[inner] / dt**2
    return float(np.sqrt(np.mean(d2**2))) if d2.size else 0.0
