"""Input shapers: impulse sequences that cancel the residual vibration of lightly damped modes.

A shaper is a sequence of impulses (amplitudes A_i summing to 1, times t_i ≥ 0, t_0 = 0, in s).
Convolving a command with it (`flexlink.motion.Shaped`) leaves, after the move, the vibration
of a mode of natural frequency ω and damping ratio ζ multiplied by the textbook percentage
vibration (Singer & Seering 1990, "Preshaping command inputs to reduce system vibration",
J. Dyn. Sys., Meas., Control 112, 76–82)

    V(ω, ζ) = e^{−ζω t_N} · | Σ_i A_i e^{ζω t_i} e^{i ω_d t_i} |,   ω_d = ω √(1 − ζ²),

the ratio of the residual amplitude to that of a single unit impulse at the last impulse time.

* ZV: V = 0 at the design mode; two impulses, half a damped period long.
* ZVD: also ∂V/∂ω = 0 there (a flat, second-order zero); three impulses, one period.
* EI (extra-insensitive): V equals the tolerable level V_tol at the design frequency, with a
  zero slope there and zeros on either side, so that V ≤ V_tol over the widest band;
  three impulses, about one period (Singer & Seering 1990; Singhose, Seering & Singer 1997).

Several modes: the sequences of each are convolved (`design`). Pure functions of (frequencies,
damping ratios, kind): the frequencies may come from anywhere (a model, a measurement).
Frequencies in Hz at the interface, rad/s inside.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

SHAPERS = ("zv", "zvd", "ei")
DEFAULT_TOLERABLE_VIBRATION = 0.05  # EI's V at the design frequency (5 %)
_MERGE_TOL_S = 1e-12  # s, impulses closer than this are merged after a convolution


@dataclass(frozen=True)
class ImpulseSequence:
    """Impulses of amplitudes ``amplitudes`` (sum 1) at ``times`` (s, increasing, first 0)."""

    amplitudes: tuple[float, ...]
    times: tuple[float, ...]

    def __post_init__(self) -> None:
        a, t = np.asarray(self.amplitudes, float), np.asarray(self.times, float)
        if a.shape != t.shape or a.ndim != 1 or a.size == 0:
            raise ValueError("a shaper needs as many amplitudes as times (at least one)")
        if not (np.all(np.isfinite(a)) and np.all(np.isfinite(t))):
            raise ValueError("shaper amplitudes and times must be finite")
        if t[0] != 0.0 or np.any(np.diff(t) <= 0.0):
            raise ValueError(f"shaper times must start at 0 s and increase, got {t.tolist()}")
        if abs(a.sum() - 1.0) > 1e-9:
            raise ValueError(f"shaper amplitudes must sum to 1, got {a.sum():.12g}")
        object.__setattr__(self, "amplitudes", tuple(map(float, a)))
        object.__setattr__(self, "times", tuple(map(float, t)))

    @property
    def duration(self) -> float:
        """Time of the last impulse, s: how much the shaper lengthens a move."""
        return self.times[-1]

    def convolve(self, other: ImpulseSequence) -> ImpulseSequence:
        """The sequence of both shapers applied one after the other (multi-mode shaping)."""
        a = np.outer(self.amplitudes, other.amplitudes).ravel()
        t = np.add.outer(self.times, other.times).ravel()
        order = np.argsort(t, kind="stable")
        a, t = a[order], t[order]
        keep_a, keep_t = [a[0]], [t[0]]
        for ai, ti in zip(a[1:], t[1:], strict=True):
            if ti - keep_t[-1] <= _MERGE_TOL_S:
                keep_a[-1] += ai
            else:
                keep_a.append(ai)
                keep_t.append(ti)
        return ImpulseSequence(tuple(keep_a), tuple(keep_t))


def check_mode(frequency_hz: float, damping: float, what: str = "") -> None:
    """ValueError naming the field unless 0 < frequency (Hz) and 0 ≤ damping < 1."""
    head = f"{what}: " if what else ""
    if not (isinstance(frequency_hz, int | float) and math.isfinite(frequency_hz)
            and frequency_hz > 0.0):
        raise ValueError(f"{head}frequencies_hz must be > 0 Hz, got {frequency_hz!r}")
    if not (isinstance(damping, int | float) and math.isfinite(damping) and 0.0 <= damping < 1.0):
        raise ValueError(f"{head}damping must be in [0, 1), got {damping!r}")


def _k_factor(damping: float) -> float:
    return math.exp(-damping * math.pi / math.sqrt(1.0 - damping**2))


def zv(frequency_hz: float, damping: float = 0.0) -> ImpulseSequence:
    """Zero-vibration shaper: [1, K]/(1 + K) at [0, T_d/2], K = exp(−ζπ/√(1−ζ²))."""
    check_mode(frequency_hz, damping)
    K, half = _k_factor(damping), 0.5 / (frequency_hz * math.sqrt(1.0 - damping**2))
    return ImpulseSequence((1.0 / (1.0 + K), K / (1.0 + K)), (0.0, half))


def zvd(frequency_hz: float, damping: float = 0.0) -> ImpulseSequence:
    """Zero-vibration-derivative shaper: [1, 2K, K²]/(1 + K)² at [0, T_d/2, T_d]."""
    check_mode(frequency_hz, damping)
    K, half = _k_factor(damping), 0.5 / (frequency_hz * math.sqrt(1.0 - damping**2))
    s = (1.0 + K) ** 2
    return ImpulseSequence((1.0 / s, 2.0 * K / s, K * K / s), (0.0, half, 2.0 * half))


def ei(frequency_hz: float, damping: float = 0.0,
       tolerable_vibration: float = DEFAULT_TOLERABLE_VIBRATION) -> ImpulseSequence:
    """Extra-insensitive shaper: V(ω_m) = V_tol, ∂V/∂ω(ω_m) = 0, V = 0 at two frequencies
    around ω_m.

    Undamped it is [(1+V), 2(1−V), (1+V)]/4 at [0, T/2, T] (exact); with damping the seven
    conditions (sum of amplitudes, V and its slope at ω_m, real and imaginary parts of the
    vibration vector at both zeros) are solved for A_1..A_3, t_2, t_3 and the two zero
    frequencies, starting from the undamped solution.
    """
    check_mode(frequency_hz, damping)
    v = tolerable_vibration
    if not (isinstance(v, int | float) and math.isfinite(v) and 0.0 < v < 1.0):
        raise ValueError(f"tolerable_vibration must be in (0, 1), got {v!r}")
    period = 1.0 / (frequency_hz * math.sqrt(1.0 - damping**2))
    a0 = np.array([(1.0 + v) / 4.0, (1.0 - v) / 2.0, (1.0 + v) / 4.0])
    if damping == 0.0:
        return ImpulseSequence(tuple(a0), (0.0, period / 2.0, period))
    from scipy.optimize import fsolve

    w_m = 2.0 * math.pi * frequency_hz
    x_zero = math.acos(-(1.0 - v) / (1.0 + v))  # undamped zeros: ω T/2 = x, 2π − x
    guess = np.array([*a0, 0.5, 1.0, x_zero / math.pi, 2.0 - x_zero / math.pi])

    def vector(a: np.ndarray, t: np.ndarray, w: float) -> np.ndarray:
        """Σ A_i e^{ζω t_i} (cos, sin)(ω_d t_i) · e^{−ζω t_N}, scaled so V = its norm."""
        wd = w * math.sqrt(1.0 - damping**2)
        grow = np.exp(damping * w * (t - t[-1]))
        return np.array([np.sum(a * grow * np.cos(wd * t)), np.sum(a * grow * np.sin(wd * t))])

    def equations(x: np.ndarray) -> np.ndarray:
        a, t = x[:3], np.array([0.0, x[3] * period, x[4] * period])
        lo, hi = x[5] * w_m, x[6] * w_m
        h = 1e-6 * w_m
        slope = (np.linalg.norm(vector(a, t, w_m + h)) - np.linalg.norm(vector(a, t, w_m - h)))
        return np.array([a.sum() - 1.0, np.linalg.norm(vector(a, t, w_m)) - v,
                         slope / (2e-6), *vector(a, t, lo), *vector(a, t, hi)])

    sol, info, ok, message = fsolve(equations, guess, full_output=True, xtol=1e-13)
    if ok != 1 or np.abs(info["fvec"]).max() > 1e-9:
        raise ValueError(f"EI shaper: no solution for damping {damping:g} and V {v:g} "
                         f"({message})")
    a = sol[:3] / sol[:3].sum()
    return ImpulseSequence(tuple(a), (0.0, sol[3] * period, sol[4] * period))


def design(kind: str, frequencies_hz: Sequence[float], damping: Sequence[float] | float = 0.0,
           tolerable_vibration: float = DEFAULT_TOLERABLE_VIBRATION) -> ImpulseSequence:
    """The shaper ``kind`` ("zv", "zvd" or "ei") for every mode (frequencies in Hz, damping
    ratios: one per mode, or one for all), convolved into one sequence."""
    if kind not in SHAPERS:
        raise ValueError(f"shaper must be one of {', '.join(map(repr, SHAPERS))}, "
                         f"got {kind!r}")
    freqs = list(np.atleast_1d(np.asarray(frequencies_hz, dtype=float)))
    if not freqs:
        raise ValueError("frequencies_hz: give at least one target mode (Hz)")
    zetas = list(np.broadcast_to(np.asarray(damping, dtype=float), (len(freqs),))) \
        if np.ndim(damping) == 0 else list(map(float, damping))  # type: ignore[arg-type]
    if len(zetas) != len(freqs):
        raise ValueError(f"damping: give one ratio per frequency ({len(freqs)}), "
                         f"got {len(zetas)}")
    sequence: ImpulseSequence | None = None
    for i, (f, z) in enumerate(zip(freqs, zetas, strict=True)):
        check_mode(float(f), float(z), f"mode {i + 1}")
        one = (ei(float(f), float(z), tolerable_vibration) if kind == "ei"
               else (zv if kind == "zv" else zvd)(float(f), float(z)))
        sequence = one if sequence is None else sequence.convolve(one)
    assert sequence is not None
    return sequence


def residual_vibration(sequence: ImpulseSequence, frequency_hz: np.ndarray | float,
                       damping: float = 0.0) -> np.ndarray:
    """Percentage residual vibration V (as a fraction, 1 = unshaped) of a mode of frequency
    ``frequency_hz`` (Hz, any shape) and damping ratio ``damping`` after ``sequence``."""
    f = np.asarray(frequency_hz, dtype=float)
    w = 2.0 * np.pi * f[..., None]
    a, t = np.asarray(sequence.amplitudes), np.asarray(sequence.times)
    wd = w * math.sqrt(1.0 - damping**2)
    grow = a * np.exp(damping * w * (t - t[-1]))
    c = np.sum(grow * np.cos(wd * t), axis=-1)
    s = np.sum(grow * np.sin(wd * t), axis=-1)
    return np.hypot(c, s)


__all__ = ["DEFAULT_TOLERABLE_VIBRATION", "SHAPERS", "ImpulseSequence", "check_mode", "design",
           "ei", "residual_vibration", "zv", "zvd"]
