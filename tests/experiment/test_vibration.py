"""The free-vibration estimator against signals with known frequencies and damping ratios."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexlink.experiment.vibration import damped_modes, dominant_mode, manoeuvre_end


def damped(t: np.ndarray, f_hz: float, zeta: float, amplitude: float, phase: float) -> np.ndarray:
    """A·exp(−ζωn s)·cos(ωd s + φ) with damped frequency f_hz, s = t − t[0]."""
    s = t - t[0]
    omega_n = 2 * math.pi * f_hz / math.sqrt(1 - zeta**2)
    return amplitude * np.exp(-zeta * omega_n * s) * np.cos(2 * math.pi * f_hz * s + phase)


@pytest.mark.parametrize(("f1", "z1", "f2", "z2", "a2", "noise"), [
    (5.386, 0.02, 14.0, 0.01, 0.3, 0.02),  # accelerometer-like: a weaker higher mode
    (2.487, 0.01, 5.39, 0.02, 0.5, 0.05),  # PZT-like: two modes, more noise
    (2.0, 0.05, 7.0, 0.02, 0.5, 0.10),  # heavily damped, noisy
])
def test_frequency_and_damping_of_two_mode_signals(f1, z1, f2, z2, a2, noise) -> None:
    rng = np.random.default_rng(1)
    t = np.arange(1.6, 5.0, 1e-3)
    y = damped(t, f1, z1, 1.0, 0.3) + damped(t, f2, z2, a2, 1.0) + 0.1 + 0.02 * (t - t[0])
    y = y + noise * rng.normal(size=t.size)  # white noise, offset and drift as from a charge amp
    mode = dominant_mode(t, y)
    assert mode is not None
    assert abs(mode.frequency_hz / f1 - 1) < 1e-3  # judged: 1 %
    assert abs(mode.damping_ratio / z1 - 1) < 0.05
    # the reported standard errors are honest: the true value within 4 of them
    assert abs(mode.frequency_hz - f1) < 4 * mode.frequency_std
    assert abs(mode.damping_ratio - z1) < 4 * mode.damping_std
    second = [m for m in damped_modes(t, y) if abs(m.frequency_hz / f2 - 1) < 0.01]
    assert second and abs(second[0].damping_ratio / z2 - 1) < 0.15


def test_fft_alone_would_not_do() -> None:
    """With 3.4 s of data the FFT bin is 0.3 Hz wide: the refinement is what reaches 0.1 %."""
    t = np.arange(0.0, 3.4, 1e-3)
    f = 2.4817
    mode = dominant_mode(t, damped(t, f, 0.012, 1.0, 0.0))
    assert 1.0 / 3.4 > 0.1 * f * 0.01  # the resolution of a plain FFT exceeds the tolerance
    assert abs(mode.frequency_hz / f - 1) < 1e-5
    assert abs(mode.damping_ratio / 0.012 - 1) < 1e-3


def test_no_oscillation_and_too_short_windows() -> None:
    t = np.linspace(0.0, 1.0, 1001)
    assert dominant_mode(t, np.zeros_like(t)) is None
    assert dominant_mode(t[:10], np.sin(t[:10])) is None
    assert dominant_mode(t, np.sin(2 * np.pi * 0.5 * t)) is None  # half a period only


def test_manoeuvre_end() -> None:
    t = np.linspace(0.0, 3.0, 3001)
    tau = np.clip((t - 0.5) / 1.0, 0, 1)
    angle = 1.5 * (tau - np.sin(2 * np.pi * tau) / (2 * np.pi))
    end = manoeuvre_end(t, [angle, np.zeros_like(t)])
    assert 1.5 < end < 1.65  # the move ends at 1.5 s; the margin is a tenth of its length
    assert manoeuvre_end(t, [np.zeros_like(t)]) == 0.0
    assert manoeuvre_end(t, [t]) is None  # still moving at the end


def filtered_pot_move(duration: float, rest: float, noise_deg: float, seed: int):
    """Joint angles (rad) of a cycloidal move from 0.5 s: an encoder (0.05° steps) and a
    potentiometer with white noise, both filtered at 30 Hz as the docs suggest."""
    from flexlink.experiment.measurement import lowpass

    t = np.arange(0.0, 0.5 + duration + rest + 5e-4, 1e-3)
    tau = np.clip((t - 0.5) / duration, 0, 1)
    shape = tau - np.sin(2 * np.pi * tau) / (2 * np.pi)
    rng = np.random.default_rng(seed)
    encoder = np.round((90.0 * shape) / 0.05) * 0.05
    pot = 90.0 + 80.0 * shape + rng.normal(0.0, noise_deg, t.size)
    return t, {name: lowpass(t, np.radians(a), 30.0, name)
               for name, a in (("joint1_angle", encoder), ("joint2_angle", pot))}


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize(("duration", "rest"), [(1.0, 3.5), (1.5, 2.0), (2.0, 2.0)])
def test_window_robust_to_filtered_noise(duration, rest, seed) -> None:
    """Issue 15: with 0.2° of potentiometer noise filtered at 30 Hz the window started at
    3.1 s for a move ending at 1.5 s, or was not found with 2 s of rest after the move."""
    from flexlink.experiment.vibration import detect_manoeuvre

    t, angles = filtered_pot_move(duration, rest, 0.2, seed)
    found = detect_manoeuvre(t, angles)
    end = 0.5 + duration
    assert found.free_start is not None, found.reason
    assert end <= found.free_start < end + 0.25 * duration
    assert 0.5 - 0.05 < found.start < 0.5 + 0.15 * duration


def test_window_refusal_names_the_moving_joint() -> None:
    from flexlink.experiment.vibration import detect_manoeuvre

    t = np.linspace(0.0, 3.0, 3001)
    found = detect_manoeuvre(t, {"joint1_angle": np.zeros_like(t), "joint2_angle": 0.3 * t})
    assert found.free_start is None
    assert "joint2_angle still moves" in found.reason and "deg" in found.reason


def test_the_exact_projection_jacobian_reaches_the_optimum_of_differences() -> None:
    """The estimator's exact variable-projection Jacobian leads to the optimum that a fit of
    the same model with difference Jacobians (scipy's 2-point, amplitudes by lstsq) finds."""
    from scipy.optimize import least_squares

    rng = np.random.default_rng(4)
    t = np.arange(1.6, 4.0, 1e-3)
    y = damped(t, 2.48, 0.013, 1.0, 0.3) + damped(t, 5.02, 0.025, 0.6, 1.0) + 0.05
    y = y + 0.05 * rng.normal(size=t.size)
    modes = damped_modes(t, y, guesses=[2.5, 5.0])
    s = t - t[0]
    yn = y / np.std(y)

    def residual(p: np.ndarray) -> np.ndarray:
        cols = [np.ones_like(s), s / s[-1]]
        for sg, om in zip(p[:2], p[2:], strict=True):
            cols += [np.exp(-sg * s) * np.cos(om * s), np.exp(-sg * s) * np.sin(om * s)]
        a = np.column_stack(cols)
        return a @ np.linalg.lstsq(a, yn, rcond=None)[0] - yn

    omega0 = 2 * math.pi * np.array([2.5, 5.0])
    x0 = np.concatenate([0.01 * omega0, omega0])
    reference = least_squares(residual, x0, x_scale=np.abs(x0) + 1e-3, xtol=1e-12, ftol=1e-12)
    for k, m in enumerate(modes):
        sigma, omega = reference.x[k], reference.x[2 + k]
        assert m.frequency_hz == pytest.approx(omega / (2 * math.pi), rel=1e-8)
        assert m.damping_ratio == pytest.approx(sigma / math.hypot(sigma, omega), rel=1e-6)
