"""The numpy zero-phase Butterworth low-pass and local maxima against scipy.signal's."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import butter, find_peaks, sosfiltfilt

from flexlink.experiment.vibration import local_maxima
from flexlink.motion.lowpass import butterworth_sections, zero_phase
from flexlink.motion.measured import zero_phase_lowpass


@pytest.mark.parametrize(("order", "cutoff", "fs"), [(4, 100.0, 500.0), (4, 3.0, 500.0),
                                                     (2, 20.0, 1000.0), (6, 240.0, 500.0)])
def test_sections_equal_scipy_butter(order: int, cutoff: float, fs: float) -> None:
    ours = butterworth_sections(order, cutoff, fs)
    ref = butter(order, cutoff, btype="low", output="sos", fs=fs)
    np.testing.assert_allclose(ours, ref, rtol=1e-13, atol=1e-300)


@pytest.mark.parametrize(("cutoff", "fs", "n", "padlen"), [
    (100.0, 500.0, 2001, 15), (3.0, 500.0, 2001, 500), (20.0, 1000.0, 4000, 150),
    (240.0, 500.0, 40, 39), (50.0, 500.0, 300, 0)])
def test_zero_phase_equals_sosfiltfilt(cutoff: float, fs: float, n: int, padlen: int) -> None:
    rng = np.random.default_rng(3)
    y = np.cumsum(rng.normal(size=n)) + 5.0 + np.sin(np.arange(n) * 0.3)
    sos = butter(4, cutoff, btype="low", output="sos", fs=fs)
    ref = sosfiltfilt(sos, y, padtype="even", padlen=padlen)
    got = zero_phase(butterworth_sections(4, cutoff, fs), y, padlen)
    # the recursion amplifies round-off by about fs/cutoff
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-14 * fs / cutoff * np.abs(ref).max())


def test_zero_phase_lowpass_keeps_constants_and_passes_low_frequencies() -> None:
    fs, t = 500.0, np.arange(2001) / 500.0
    np.testing.assert_allclose(zero_phase_lowpass(np.full(t.size, 2.5), 10.0, fs), 2.5,
                               rtol=1e-12)
    slow, fast = np.sin(2 * np.pi * 1.0 * t), np.sin(2 * np.pi * 100.0 * t)
    out = zero_phase_lowpass(slow + fast, 10.0, fs)
    inner = slice(200, -200)
    assert np.max(np.abs(out[inner] - slow[inner])) < 1e-3


def test_bad_order_and_padlen_are_refused() -> None:
    with pytest.raises(ValueError, match="even integer"):
        butterworth_sections(3, 10.0, 100.0)
    with pytest.raises(ValueError, match="padlen"):
        zero_phase(butterworth_sections(4, 10.0, 100.0), np.zeros(10), 10)


def test_local_maxima_equal_find_peaks() -> None:
    rng = np.random.default_rng(0)
    for _ in range(3000):  # small integers: many flat tops, flat ends and ties
        x = rng.integers(0, 4, size=int(rng.integers(0, 25))).astype(float)
        np.testing.assert_array_equal(local_maxima(x), find_peaks(x)[0])
    x = rng.normal(size=20000)
    np.testing.assert_array_equal(local_maxima(x), find_peaks(x)[0])
