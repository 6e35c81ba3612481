"""Analytic prescribed joint-angle profiles (implement ``flexlink.model.JointMotion``).

Constructors take angles in degrees (and rates in deg/s) because users write them that way;
``evaluate(t)`` works in SI: t in s, angle in rad, rate in rad/s, acceleration in rad/s².
All derivatives are analytic. Formulas: docs/motion.md.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

Triple = tuple[np.ndarray, np.ndarray, np.ndarray]
TWO_PI = 2.0 * math.pi
CONTINUITY_TOL_DEG = 1e-9  # deg, allowed jump between consecutive Sequence segments
TIMING_TOL_S = 1e-9  # s, allowed overlap of consecutive Sequence segments (round-off)


def _number(owner: object, name: str, value: object, unit: str, *,
            positive: bool = False, non_negative: bool = False) -> float:
    """``value`` as a finite float, or a ValueError naming the field."""
    label = f"{type(owner).__name__}: {name}"
    try:
        x = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"{label} must be a number ({unit}), got {value!r}") from None
    if not math.isfinite(x):
        raise ValueError(f"{label} must be finite ({unit}), got {x}")
    if positive and x <= 0.0:
        raise ValueError(f"{label} must be > 0 {unit}, got {x:g}")
    if non_negative and x < 0.0:
        raise ValueError(f"{label} must be >= 0 {unit}, got {x:g}")
    object.__setattr__(owner, name, x)  # normalise ints / numpy scalars to float
    return x


@dataclass(frozen=True)
class _RestToRest:
    """Rest-to-rest move θ = θ0 + Δ·p(τ), τ = (t − start)/duration clipped to [0, 1]."""

    from_deg: float  # deg, angle held before start
    to_deg: float  # deg, angle reached at start + duration and held afterwards
    start: float  # s
    duration: float  # s

    def __post_init__(self) -> None:
        _number(self, "from_deg", self.from_deg, "deg")
        _number(self, "to_deg", self.to_deg, "deg")
        _number(self, "start", self.start, "s", non_negative=True)
        _number(self, "duration", self.duration, "s", positive=True)

    @property
    def end(self) -> float:
        """Time the move ends, s."""
        return self.start + self.duration

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Times (s) where the acceleration is not smooth: the move's start and end."""
        return (self.start, self.end)

    @staticmethod
    def _shape(tau: np.ndarray) -> Triple:
        """Normalised profile p(τ) and its derivatives dp/dτ, d²p/dτ²."""
        raise NotImplementedError

    def evaluate(self, t: np.ndarray) -> Triple:
        """Angle (rad), rate (rad/s), acceleration (rad/s²) at times t (s), shaped like t."""
        t = np.asarray(t, dtype=float)
        th0, th1 = math.radians(self.from_deg), math.radians(self.to_deg)
        delta, d = th1 - th0, self.duration
        tau = (t - self.start) / d
        angle = np.where(tau <= 0.0, th0, th1)
        rate, acc = np.zeros(t.shape), np.zeros(t.shape)
        # The profile only where the joint moves: most of a run's samples are at rest.
        moving = (tau > 0.0) & (tau < 1.0)
        p, dp, ddp = self._shape(tau[moving])
        angle[moving] = th0 + delta * p
        rate[moving] = (delta / d) * dp
        acc[moving] = (delta / d**2) * ddp
        return angle, rate, acc


@dataclass(frozen=True)
class Cycloidal(_RestToRest):
    """Rest-to-rest cycloidal move: p(τ) = τ − sin(2πτ)/(2π).

    Zero rate and acceleration at both ends; jerk is discontinuous there.
    """

    @staticmethod
    def _shape(tau: np.ndarray) -> Triple:
        phase = TWO_PI * tau
        sine = np.sin(phase)
        return tau - sine / TWO_PI, 1.0 - np.cos(phase), TWO_PI * sine


@dataclass(frozen=True)
class Quintic(_RestToRest):
    """Rest-to-rest quintic polynomial move: p(τ) = 10τ³ − 15τ⁴ + 6τ⁵.

    Zero rate and acceleration at both ends.
    """

    @staticmethod
    def _shape(tau: np.ndarray) -> Triple:
        u = 1.0 - tau
        p = tau**3 * (10.0 - 15.0 * tau + 6.0 * tau**2)
        return p, 30.0 * tau**2 * u**2, 60.0 * tau * u * (1.0 - 2.0 * tau)


@dataclass(frozen=True)
class Spinup:
    """Kane–Ryan–Banerjee (1987) spin-up to the constant rate Ω in ``duration`` T.

    For 0 ≤ s = t − start ≤ T: rate (Ω/T)(s − (T/2π) sin(2πs/T)), angle its integral
    θ0 + (Ω/T)(s²/2 + (T/2π)²(cos(2πs/T) − 1)); afterwards the rate stays Ω and the angle grows
    linearly from θ0 + ΩT/2. Before start: θ0 at rest.
    """

    to_rate_deg_s: float  # deg/s, final rate Ω
    start: float  # s
    duration: float  # s, spin-up time T
    from_deg: float = 0.0  # deg, θ0

    def __post_init__(self) -> None:
        _number(self, "to_rate_deg_s", self.to_rate_deg_s, "deg/s")
        _number(self, "start", self.start, "s", non_negative=True)
        _number(self, "duration", self.duration, "s", positive=True)
        _number(self, "from_deg", self.from_deg, "deg")

    @property
    def end(self) -> float:
        """Time the spin-up phase ends (the rotation continues at Ω), s."""
        return self.start + self.duration

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Times (s) where the acceleration is not smooth: the spin-up's start and end."""
        return (self.start, self.end)

    def evaluate(self, t: np.ndarray) -> Triple:
        """Angle (rad), rate (rad/s), acceleration (rad/s²) at times t (s), shaped like t."""
        t = np.asarray(t, dtype=float)
        th0, omega = math.radians(self.from_deg), math.radians(self.to_rate_deg_s)
        T = self.duration
        s = t - self.start
        sc = np.clip(s, 0.0, T)
        half = np.pi * sc / T  # half the phase 2πs/T
        # cos φ − 1 = −2 sin²(φ/2) avoids cancellation for small s
        angle_in = th0 + (omega / T) * (0.5 * sc**2 - 2.0 * (T / TWO_PI) ** 2 * np.sin(half) ** 2)
        rate_in = (omega / T) * (sc - (T / TWO_PI) * np.sin(2.0 * half))
        acc_in = (omega / T) * 2.0 * np.sin(half) ** 2  # (Ω/T)(1 − cos φ)
        after = s > T
        angle = np.where(after, th0 + omega * (0.5 * T + (s - T)), angle_in)
        rate = np.where(after, omega, rate_in)
        acc = np.where(after | (s <= 0.0), 0.0, acc_in)
        return angle, rate, acc


@dataclass(frozen=True)
class Hold:
    """A joint held at a constant angle."""

    angle_deg: float  # deg

    def __post_init__(self) -> None:
        _number(self, "angle_deg", self.angle_deg, "deg")

    breakpoints: ClassVar[tuple[float, ...]] = ()  # a held joint never changes

    def evaluate(self, t: np.ndarray) -> Triple:
        """Constant angle (rad), zero rate and acceleration, shaped like t (s)."""
        t = np.asarray(t, dtype=float)
        zero = np.zeros(t.shape)
        return zero + math.radians(self.angle_deg), zero, zero.copy()


Segment = Cycloidal | Quintic | Spinup | Hold


@dataclass(frozen=True)
class Sequence:
    """Several segments of one joint, in time order.

    Before the first segment starts, the first segment's initial angle holds. Each segment is
    active from its start; between segments the previous one's end state holds (for a Spinup:
    rotation at Ω, so a Spinup can only be last). A Hold can only be first (it has no start).
    Consecutive segments must not overlap and must continue each other's angle (1e-9 deg).
    """

    segments: tuple[Segment, ...]
    _kinds: ClassVar[tuple[type, ...]] = (Cycloidal, Quintic, Spinup, Hold)

    def __post_init__(self) -> None:
        segments = tuple(self.segments)
        object.__setattr__(self, "segments", segments)
        if not segments:
            raise ValueError("Sequence needs at least one segment")
        for i, seg in enumerate(segments):
            if not isinstance(seg, self._kinds):
                raise TypeError(f"motion[{i}] must be a Cycloidal, Quintic, Spinup or Hold, "
                                 f"got {type(seg).__name__}")
            if isinstance(seg, Hold) and i > 0:
                raise ValueError(f"motion[{i}] is a Hold; a Hold has no start time and can only "
                                 "be the first segment")
            if isinstance(seg, Spinup) and i < len(segments) - 1:
                raise ValueError(f"motion[{i}] is a Spinup, which keeps rotating after it ends; "
                                 "only the last segment can be a Spinup")
        for i in range(1, len(segments)):
            self._check_follows(i, segments[i - 1], segments[i])

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Times (s) where the acceleration is not smooth: those of every segment."""
        return tuple(sorted({b for seg in self.segments for b in seg.breakpoints}))

    @staticmethod
    def _check_follows(i: int, prev: Segment, seg: Segment) -> None:
        assert not isinstance(seg, Hold) and not isinstance(prev, Spinup)
        if not isinstance(prev, Hold):
            if seg.start < prev.start:
                raise ValueError(f"segments must be sorted by start: motion[{i}] starts at "
                                 f"{seg.start:g} s, before motion[{i - 1}] ({prev.start:g} s)")
            if seg.start < prev.end - TIMING_TOL_S:
                raise ValueError(f"motion[{i}] starts at {seg.start:g} s, before motion[{i - 1}] "
                                 f"ends ({prev.end:g} s)")
        prev_deg = prev.angle_deg if isinstance(prev, Hold) else prev.to_deg
        if abs(seg.from_deg - prev_deg) > CONTINUITY_TOL_DEG:
            raise ValueError(f"motion[{i}].from_deg = {seg.from_deg:g} does not continue from "
                             f"the end of motion[{i - 1}] ({prev_deg:g} deg)")

    def evaluate(self, t: np.ndarray) -> Triple:
        """Angle (rad), rate (rad/s), acceleration (rad/s²) at times t (s), shaped like t."""
        t = np.asarray(t, dtype=float)
        if len(self.segments) == 1:
            return self.segments[0].evaluate(t)
        flat = t.ravel()
        starts = np.array([-np.inf if isinstance(s, Hold) else s.start for s in self.segments])
        active = np.maximum(np.searchsorted(starts, flat, side="right") - 1, 0)
        out = np.zeros((3, flat.size))
        for i, seg in enumerate(self.segments):
            mask = active == i
            if mask.any():
                out[:, mask] = np.stack(seg.evaluate(flat[mask]))
        angle, rate, acc = (row.reshape(t.shape) for row in out)
        return angle, rate, acc
