"""Free vibration: where it starts, and its dominant frequency and damping ratio.

Estimator (docs/experiment.md): the peaks of a zero-padded, Hann-windowed FFT give starting
frequencies of up to ``max_modes`` components; then the signal is fitted by least squares with

    y(t) = c0 + c1·s + Σ_k exp(−σ_k s) (a_k cos ω_k s + b_k sin ω_k s),   s = t − t_start,

the amplitudes (c, a, b) solved linearly inside every evaluation (variable projection), σ_k and
ω_k nonlinearly. The dominant component is the one with the most energy in the window,
Σ over samples of its squared contribution. Its damped frequency is f = ω/2π and its damping
ratio ζ = σ/√(σ² + ω²). The FFT alone resolves 1/(window) Hz at best; the fit is limited
by noise and by how well the components are separated, not by the window length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MIN_CYCLES = 2.0  # the window must hold this many periods of a component
PEAK_FRACTION = 0.05  # spectral peaks below this fraction of the highest are ignored


@dataclass(frozen=True)
class Mode:
    """One damped sinusoid: damped frequency (Hz), damping ratio, amplitude at the window start."""

    frequency_hz: float
    damping_ratio: float
    amplitude: float
    energy: float
    frequency_std: float = math.nan  # Hz, standard error from the fit's Jacobian
    damping_std: float = math.nan  # standard error of the damping ratio


def manoeuvre_end(t: np.ndarray, angles: list[np.ndarray], rel_tol: float = 1e-3,
                  margin: float = 0.1) -> float | None:
    """Time (s) after which every joint angle stays within ``rel_tol`` of its range of its
    final value, plus ``margin`` × the manoeuvre's duration (the end of a smooth move is
    asymptotic). 0 if nothing moves, None if some joint is still moving at the end."""
    start, end = t[-1], t[0]
    moved = False
    for angle in angles:
        span = float(np.ptp(angle))
        if span < 1e-6:  # rad: a joint that does not move
            continue
        moved = True
        n_tail = max(3, angle.size // 10)
        tail = angle[-n_tail:]
        final = float(np.median(tail))
        # noisy angles (a potentiometer) never stay within rel_tol: allow their noise level,
        # the scatter about a straight line (a joint still moving is not noise)
        s = t[-n_tail:] - t[-n_tail]
        noise = float(np.std(tail - np.polyval(np.polyfit(s, tail, 1), s)))
        away = np.abs(angle - final) > max(rel_tol * span, 4.0 * noise)
        if away[-1]:
            return None
        last = int(np.flatnonzero(away)[-1]) + 1 if away.any() else 0
        first = int(np.argmax(np.abs(angle - angle[0]) > rel_tol * span))
        start, end = min(start, t[first]), max(end, t[last])
    if not moved:
        return float(t[0])
    free = end + margin * max(end - start, 0.0)
    return float(free) if free < t[-1] else None


def dominant_mode(t: np.ndarray, y: np.ndarray, max_modes: int = 3) -> Mode | None:
    """The component of the free vibration ``y(t)`` (uniform t) with the most energy, or None
    if the window is too short or holds no oscillation."""
    duration = float(t[-1] - t[0]) if len(t) else 0.0
    modes = [m for m in damped_modes(t, y, max_modes)
             if m.frequency_hz * duration >= MIN_CYCLES]  # a drift is no vibration
    return max(modes, key=lambda m: m.energy) if modes else None


def damped_modes(t: np.ndarray, y: np.ndarray, max_modes: int = 3,
                 guesses: list[float] | None = None) -> list[Mode]:
    """Fitted damped sinusoids of y(t), strongest spectral peaks first (see module doc), or
    one per starting frequency in ``guesses`` (Hz), in that order. Standard errors assume
    white residuals, widened by the AR(1) factor of their lag-one autocorrelation."""
    from scipy.optimize import least_squares

    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.size < 16 or not np.all(np.isfinite(y)):
        return []
    s = t - t[0]
    if guesses is None:
        guesses = spectral_peaks(t, y, max_modes)
    if not guesses:
        return []
    scale = float(np.std(y)) or 1.0
    yn = y / scale
    omega0 = np.array([2 * math.pi * f for f in guesses])

    def basis(params: np.ndarray) -> np.ndarray:
        sigma, omega = params[: len(guesses)], params[len(guesses):]
        cols = [np.ones_like(s), s / s[-1]]
        for sg, om in zip(sigma, omega, strict=True):
            decay = np.exp(-sg * s)
            cols += [decay * np.cos(om * s), decay * np.sin(om * s)]
        return np.column_stack(cols)

    def residual(params: np.ndarray) -> np.ndarray:
        a = basis(params)
        coef, *_ = np.linalg.lstsq(a, yn, rcond=None)
        return a @ coef - yn

    x0 = np.concatenate([0.01 * omega0, omega0])
    lower = np.concatenate([np.full(len(guesses), -0.5 / s[-1]), 0.5 * omega0])
    upper = np.concatenate([np.full(len(guesses), np.inf), 1.5 * omega0])
    x0 = np.clip(x0, lower + 1e-12, upper - 1e-12)
    fit = least_squares(residual, x0, bounds=(lower, upper), x_scale=np.abs(x0) + 1e-3,
                        method="trf", xtol=1e-12, ftol=1e-12, max_nfev=200)
    a = basis(fit.x)
    coef, *_ = np.linalg.lstsq(a, yn, rcond=None)
    std = _standard_errors(fit.jac, fit.fun, a.shape[1])
    modes = []
    for k in range(len(guesses)):
        sigma, omega = float(fit.x[k]), float(fit.x[len(guesses) + k])
        s_sigma, s_omega = std[k], std[len(guesses) + k]
        part = a[:, 2 + 2 * k: 4 + 2 * k] @ coef[2 + 2 * k: 4 + 2 * k] * scale
        modes.append(Mode(frequency_hz=omega / (2 * math.pi),
                          damping_ratio=sigma / math.hypot(sigma, omega),
                          amplitude=float(math.hypot(*coef[2 + 2 * k: 4 + 2 * k]) * scale),
                          energy=float(np.sum(part**2)),
                          frequency_std=s_omega / (2 * math.pi),
                          damping_std=math.hypot(s_sigma / omega, sigma * s_omega / omega**2)))
    return modes


def _standard_errors(jac: np.ndarray, r: np.ndarray, n_linear: int) -> np.ndarray:
    """σ of the nonlinear parameters: s² (JᵀJ)⁻¹, s² = Σr²/(m − p), AR(1)-widened."""
    m, p = jac.shape
    s2 = float(r @ r) / max(m - p - n_linear, 1)
    rc = r - r.mean()
    rho = float(rc[1:] @ rc[:-1]) / float(rc @ rc) if float(rc @ rc) > 0 else 0.0
    s2 *= (1 + rho) / (1 - rho) if 0 < rho < 1 else 1.0
    cov = s2 * np.linalg.pinv(jac.T @ jac)
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


def spectral_peaks(t: np.ndarray, y: np.ndarray, max_peaks: int) -> list[float]:
    """Frequencies (Hz) of the highest peaks of the zero-padded Hann-windowed FFT of the
    linearly detrended y(t), each with at least MIN_CYCLES periods in the window."""
    from scipy.signal import find_peaks

    dt = (t[-1] - t[0]) / (t.size - 1)
    detrended = y - np.polyval(np.polyfit(t - t[0], y, 1), t - t[0])
    n = 1 << max(16, math.ceil(math.log2(16 * t.size)))
    spectrum = np.abs(np.fft.rfft(detrended * np.hanning(t.size), n))
    freqs = np.fft.rfftfreq(n, dt)
    usable = freqs >= MIN_CYCLES / (t[-1] - t[0])
    spectrum = np.where(usable, spectrum, 0.0)
    if spectrum.max() <= 0:
        return []
    peaks, props = find_peaks(spectrum, height=PEAK_FRACTION * spectrum.max())
    order = np.argsort(props["peak_heights"])[::-1][:max_peaks]
    return [float(freqs[peaks[i]]) for i in order]
