"""Joint motion from measured angle samples: validated, optionally low-pass filtered (zero-phase
Butterworth), interpolated by a quintic spline whose derivatives give rate and acceleration.

Inputs are seconds and degrees; ``evaluate`` returns rad, rad/s, rad/s². Never extrapolates.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from scipy.interpolate import BSpline

MIN_SAMPLES = 4
FILTER_ORDER = 4
UNIFORM_RTOL = 1e-3  # steps within this fraction of the median step count as uniform
RANGE_TOL = 1e-9  # s per s of |t|: round-off allowed at the ends of the covered range


def _spline(t: np.ndarray, y: np.ndarray) -> BSpline:
    """Quintic (C⁴) interpolating spline, cubic (C²) if there are fewer than 6 samples."""
    from scipy.interpolate import make_interp_spline  # slow import: only for measured angles

    return make_interp_spline(t, y, k=5 if t.size >= 6 else 3)


@dataclass(frozen=True, eq=False)
class MeasuredMotion:
    """A measured joint-angle history. Build it with ``from_arrays`` or ``from_csv``.

    ``time_s``/``angle_rad`` are the samples the spline interpolates (after any resampling and
    filtering). Evaluating outside ``time_range`` raises ValueError.
    """

    name: str
    time_s: np.ndarray = field(repr=False)  # s
    angle_rad: np.ndarray = field(repr=False)  # rad
    lowpass_hz: float | None = None  # Hz, cut-off of the zero-phase filter, None: unfiltered
    _angle: BSpline = field(init=False, repr=False)
    _rate: BSpline = field(init=False, repr=False)
    _acc: BSpline = field(init=False, repr=False)

    def __post_init__(self) -> None:
        spline = _spline(self.time_s, self.angle_rad)
        object.__setattr__(self, "_angle", spline)
        object.__setattr__(self, "_rate", spline.derivative(1))
        object.__setattr__(self, "_acc", spline.derivative(2))

    @property
    def time_range(self) -> tuple[float, float]:
        """(t_first, t_last), s: the times ``evaluate`` accepts."""
        return float(self.time_s[0]), float(self.time_s[-1])

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Angle (rad), rate (rad/s), acceleration (rad/s²) at times t (s), shaped like t."""
        t = np.asarray(t, dtype=float)
        t0, t1 = self.time_range
        if t.size:
            if not np.all(np.isfinite(t)):
                raise ValueError(f"{self._label()}: evaluation times must be finite")
            lo, hi = float(t.min()), float(t.max())
            tol = RANGE_TOL * max(1.0, abs(t0), abs(t1))
            if lo < t0 - tol or hi > t1 + tol:
                bad = lo if lo < t0 - tol else hi
                raise ValueError(
                    f"{self._label()}: t = {bad:g} s is outside the measured range "
                    f"[{t0:g}, {t1:g}] s; measured motion is not extrapolated")
            t = np.clip(t, t0, t1)
        return (np.asarray(self._angle(t), dtype=float), np.asarray(self._rate(t), dtype=float),
                np.asarray(self._acc(t), dtype=float))

    def _label(self) -> str:
        return f"measured motion {self.name!r}" if self.name else "measured motion"

    @classmethod
    def from_arrays(cls, time_s: np.ndarray, angle_deg: np.ndarray,
                    lowpass_hz: float | None = None, name: str = "") -> MeasuredMotion:
        """From samples: time_s (s, strictly increasing), angle_deg (deg); optional low-pass
        cut-off lowpass_hz (Hz)."""
        source = f"measured motion {name!r}" if name else "measured motion"
        return cls._build(time_s, angle_deg, lowpass_hz, name, source,
                          ("time_s", "angle_deg"), lambda i: f"sample {i}")

    @classmethod
    def from_csv(cls, path: str | os.PathLike[str], time_column: str = "t",
                 angle_column: str = "angle", lowpass_hz: float | None = None,
                 name: str | None = None) -> MeasuredMotion:
        """From a CSV file with a header row; time_column in s, angle_column in deg. Blank lines
        and lines starting with '#' are skipped. ``name`` defaults to the file's stem."""
        path = Path(path)
        lines: list[int] = []
        rows: list[list[str]] = []
        with path.open(newline="", encoding="utf-8-sig") as fh:  # tolerate a BOM
            reader = csv.reader(fh)
            for row in reader:
                if not row or not "".join(row).strip() or row[0].lstrip().startswith("#"):
                    continue
                lines.append(reader.line_num)
                rows.append(row)
        if not rows:
            raise ValueError(f"{path}: empty file, expected a header row")
        header = [h.strip() for h in rows[0]]
        cols = []
        for col in (time_column, angle_column):
            if col not in header:
                raise ValueError(f"{path}: no column {col!r}; available columns: "
                                 f"{', '.join(header)}")
            cols.append(header.index(col))
        data = np.empty((len(rows) - 1, 2))
        for r, (line, row) in enumerate(zip(lines[1:], rows[1:], strict=True)):
            for c, (col, j) in enumerate(zip((time_column, angle_column), cols, strict=True)):
                if j >= len(row):
                    raise ValueError(f"{path}: line {line} has {len(row)} fields, "
                                     f"column {col!r} is field {j + 1}")
                try:
                    data[r, c] = float(row[j])
                except ValueError:
                    raise ValueError(f"{path}: line {line}, column {col!r}: cannot read "
                                     f"{row[j]!r} as a number") from None
        data_lines = lines[1:]
        return cls._build(data[:, 0], data[:, 1], lowpass_hz,
                          path.stem if name is None else name, str(path),
                          (f"column {time_column!r}", f"column {angle_column!r}"),
                          lambda i: f"line {data_lines[i]}")

    @classmethod
    def _build(cls, time_s: np.ndarray, angle_deg: np.ndarray, lowpass_hz: float | None,
               name: str, source: str, labels: tuple[str, str],
               row: Callable[[int], str]) -> MeasuredMotion:
        t = np.asarray(time_s, dtype=float)
        y = np.asarray(angle_deg, dtype=float)
        for arr, label in zip((t, y), labels, strict=True):
            if arr.ndim != 1:
                raise ValueError(f"{source}: {label} must be one-dimensional, got shape "
                                 f"{arr.shape}")
        if t.size != y.size:
            raise ValueError(f"{source}: {labels[0]} has {t.size} samples but {labels[1]} has "
                             f"{y.size}")
        if t.size < MIN_SAMPLES:
            raise ValueError(f"{source}: need at least {MIN_SAMPLES} samples, got {t.size}")
        for arr, label in zip((t, y), labels, strict=True):
            bad = np.flatnonzero(~np.isfinite(arr))
            if bad.size:
                raise ValueError(f"{source}: {label} has a non-finite value ({arr[bad[0]]}) at "
                                 f"{row(int(bad[0]))}")
        steps = np.diff(t)
        bad = np.flatnonzero(steps <= 0.0)
        if bad.size:
            i = int(bad[0]) + 1
            raise ValueError(f"{source}: time is not strictly increasing at {row(i)} "
                             f"(t = {t[i]:g} s after {t[i - 1]:g} s)")
        y = np.radians(y)
        if lowpass_hz is not None:
            t, y = _lowpass(t, y, lowpass_hz, source)
            lowpass_hz = float(lowpass_hz)
        return cls(name=name, time_s=t, angle_rad=y, lowpass_hz=lowpass_hz)


def _lowpass(t: np.ndarray, y: np.ndarray, cutoff_hz: float,
             source: str) -> tuple[np.ndarray, np.ndarray]:
    """Zero-phase Butterworth low-pass of y(t); resamples onto a uniform grid (median step)
    first if the steps are not uniform. Returns the (possibly new) times and filtered values."""
    try:
        fc = float(cutoff_hz)
    except (TypeError, ValueError):
        raise ValueError(f"{source}: lowpass_hz must be a number (Hz), got {cutoff_hz!r}") from None
    if not math.isfinite(fc) or fc <= 0.0:
        raise ValueError(f"{source}: lowpass_hz must be a finite frequency > 0 Hz, got {fc:g}")
    steps = np.diff(t)
    h = float(np.median(steps))
    if np.max(np.abs(steps - h)) > UNIFORM_RTOL * h:
        count = round((t[-1] - t[0]) / h) + 1
        grid = np.linspace(t[0], t[-1], max(count, MIN_SAMPLES))
        y = _spline(t, y)(grid)
        t = grid
    fs = (t.size - 1) / (t[-1] - t[0])
    if fc >= 0.5 * fs:
        raise ValueError(f"{source}: lowpass_hz = {fc:g} Hz must be below the Nyquist "
                         f"frequency {0.5 * fs:g} Hz (sampling step {1.0 / fs:g} s)")
    return t, zero_phase_lowpass(y, fc, fs)


def zero_phase_lowpass(y: np.ndarray, cutoff_hz: float, fs: float) -> np.ndarray:
    """Butterworth low-pass of order FILTER_ORDER at cutoff_hz (Hz, below fs/2), forward and
    backward, of samples y at rate fs (Hz). The ends are padded by even reflection over three
    periods of the cut-off: a measured angle usually rests there, and the default odd
    reflection would pin the filtered end to the last sample's noise."""
    from .lowpass import butterworth_sections, zero_phase

    sos = butterworth_sections(FILTER_ORDER, cutoff_hz, fs)
    padlen = min(max(3 * (2 * len(sos) + 1), int(3.0 * fs / cutoff_hz)), y.size - 1)
    return zero_phase(sos, y, padlen)
