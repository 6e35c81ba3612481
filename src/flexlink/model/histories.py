"""Input histories u(t): force, moment and torque inputs of forward-dynamics runs (SI units).

A history is a description evaluated at given times; it holds no state.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class History(Protocol):
    """A scalar input history u(t) (N, N·m, …) evaluated at times t (s)."""

    def value(self, t: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class Table:
    """Samples (t_i, u_i), linearly interpolated, held constant outside [t_0, t_last]."""

    t: tuple[float, ...]
    u: tuple[float, ...]

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or t.size < 2 or len(self.u) != t.size:
            raise ValueError("a table needs at least two samples and as many values as times")
        if not np.all(np.diff(t) > 0) or not np.all(np.isfinite(self.u)):
            raise ValueError("table times must increase strictly and values must be finite")

    def value(self, t: np.ndarray) -> np.ndarray:
        return np.interp(np.asarray(t, dtype=float), self.t, self.u)


@dataclass(frozen=True)
class BangBang:
    """+amplitude on [start, start + duration/2), −amplitude on [start + duration/2,
    start + duration), zero elsewhere: a rest-to-rest slew of a rigid body."""

    amplitude: float
    start: float
    duration: float

    def value(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        half = self.start + 0.5 * self.duration
        out = np.where((t >= self.start) & (t < half), self.amplitude, 0.0)
        return np.where((t >= half) & (t < self.start + self.duration), -self.amplitude, out)


@dataclass(frozen=True)
class Step:
    """``amplitude`` on [start, start + duration), zero elsewhere (duration may be inf)."""

    amplitude: float
    start: float = 0.0
    duration: float = float("inf")

    def value(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return np.where((t >= self.start) & (t < self.start + self.duration), self.amplitude, 0.0)


@dataclass(frozen=True)
class Sum:
    """The sum of several histories (a list of segments in a scenario file)."""

    parts: tuple[History, ...]

    def value(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return sum((p.value(t) for p in self.parts), np.zeros_like(t))


ZERO = Sum(())
