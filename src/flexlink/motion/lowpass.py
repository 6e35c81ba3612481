"""Zero-phase Butterworth low-pass of sampled signals with numpy and BLAS only.

The same filter as ``scipy.signal.butter(order, fc, output="sos", fs=fs)`` run forward and
backward by ``scipy.signal.sosfiltfilt(..., padtype="even")`` (equal to round-off; a test
compares them), without importing ``scipy.signal``, whose import brings ``scipy.stats`` and
costs more CPU than a measured record's whole conditioning. Each second-order section's
recursion y[n] + a1·y[n−1] + a2·y[n−2] = f[n] is a forward substitution with a banded
lower-triangular matrix (BLAS ``dtbsv``), so no Python loop runs over the samples.
"""

from __future__ import annotations

import math

import numpy as np


def butterworth_sections(order: int, cutoff_hz: float, fs: float) -> np.ndarray:
    """Second-order sections (rows b0 b1 b2 a0 a1 a2) of the digital Butterworth low-pass of
    even ``order`` with cut-off ``cutoff_hz`` (Hz, below fs/2) at sampling rate ``fs`` (Hz):
    the analog prototype's poles, pre-warped, mapped by the bilinear transform; the pole pair
    farthest from the unit circle first and the gain on the first section, as scipy orders
    them."""
    if order < 2 or order % 2:
        raise ValueError(f"order must be an even integer >= 2, got {order!r}")
    fs2 = 2.0  # the bilinear transform at a normalised rate, as scipy.signal.iirfilter
    warped = 2.0 * fs2 * math.tan(math.pi * (2.0 * cutoff_hz / fs) / fs2)
    analog = -np.exp(1j * np.pi * np.arange(-order + 1, order, 2) / (2 * order)) * warped
    poles = (2 * fs2 + analog) / (2 * fs2 - analog)
    gain = float(np.real(warped**order / np.prod(2 * fs2 - analog)))
    upper = sorted((p for p in poles if p.imag > 0), key=abs)
    sos = np.zeros((order // 2, 6))
    for row, p in zip(sos, upper, strict=True):
        row[:] = (1.0, 2.0, 1.0, 1.0, -2.0 * p.real, abs(p) ** 2)
    sos[0, :3] *= gain
    return sos


def _step_states(sos: np.ndarray) -> np.ndarray:
    """The sections' transposed-direct-form states in the steady state of a unit step
    (``scipy.signal.sosfilt_zi``)."""
    zi = np.empty((len(sos), 2))
    scale = 1.0
    for k, (b, a) in enumerate(zip(sos[:, :3], sos[:, 3:], strict=True)):
        minus = np.array([[1.0 + a[1], -1.0], [a[2], 1.0]])  # I − companion(a)ᵀ
        zi[k] = scale * np.linalg.solve(minus, b[1:] - a[1:] * b[0])
        scale *= b.sum() / a.sum()
    return zi


def _sections(sos: np.ndarray, x: np.ndarray, zi: np.ndarray) -> np.ndarray:
    """``scipy.signal.sosfilt(sos, x, zi=zi)``'s output (the final states are not needed)."""
    from scipy.linalg.blas import dtbsv

    y = np.array(x, dtype=float)
    band = np.empty((3, y.size))
    for (b0, b1, b2, _, a1, a2), (z0, z1) in zip(sos, zi, strict=True):
        f = b0 * y
        f[1:] += b1 * y[:-1]
        f[2:] += b2 * y[:-2]
        f[0] += z0
        f[1] += z1
        band[0], band[1], band[2] = 1.0, a1, a2  # lower band storage: diagonal, then below
        y = dtbsv(2, band, f, lower=1)
    return y


def zero_phase(sos: np.ndarray, y: np.ndarray, padlen: int) -> np.ndarray:
    """``scipy.signal.sosfiltfilt(sos, y, padtype="even", padlen=padlen)`` of a 1-D y."""
    y = np.asarray(y, dtype=float)
    if not 0 <= padlen < y.size:
        raise ValueError(f"padlen must be 0 to {y.size - 1} for {y.size} samples, got {padlen}")
    ext = (np.concatenate((y[padlen:0:-1], y, y[-2:-(padlen + 2):-1])) if padlen else y)
    zi = _step_states(sos)
    forward = _sections(sos, ext, zi * ext[0])
    backward = _sections(sos, forward[::-1], zi * forward[-1])[::-1]
    return backward[padlen:-padlen] if padlen else backward
