"""Rest-to-rest move with harmonics: the cycloid plus sine/cosine terms that keep zero rate
and acceleration at both ends and the end angles fixed (the trajectory optimiser's
parametrisation, docs/shaping.md).

With τ = (t − start)/duration in [0, 1] and k = 2, 3, … (coefficient j multiplies k = j + 2),
the normalised rate is

    p′(τ) = (1 − cos 2πτ) + Σ a_k (cos 2πτ − cos 2πkτ) + Σ b_k (sin 2πkτ − k sin 2πτ),

each added term vanishing with its derivative at τ = 0 and 1 and integrating to zero, so
p(0) = 0, p(1) = 1 and p′ = p″ = 0 at both ends for any coefficients.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .profiles import TWO_PI, Triple, _RestToRest


@dataclass(frozen=True)
class Harmonic(_RestToRest):
    """Cycloidal move plus harmonics: ``cosine`` = (a_2, a_3, …), ``sine`` = (b_2, b_3, …),
    dimensionless (fractions of the cycloid's normalised rate)."""

    cosine: tuple[float, ...] = ()
    sine: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        super().__post_init__()
        for name in ("cosine", "sine"):
            values = tuple(float(v) for v in getattr(self, name))
            if not all(math.isfinite(v) for v in values):
                raise ValueError(f"Harmonic: {name} must be finite numbers, got {values}")
            object.__setattr__(self, name, values)

    def _shape(self, tau: np.ndarray) -> Triple:  # type: ignore[override]
        phase = TWO_PI * tau
        s1, c1 = np.sin(phase), np.cos(phase)
        p = tau - s1 / TWO_PI
        dp = 1.0 - c1
        ddp = TWO_PI * s1
        for j, a in enumerate(self.cosine):
            if a:
                k = j + 2
                sk, ck = np.sin(k * phase), np.cos(k * phase)
                p = p + a * (s1 - sk / k) / TWO_PI
                dp = dp + a * (c1 - ck)
                ddp = ddp + a * TWO_PI * (k * sk - s1)
        for j, b in enumerate(self.sine):
            if b:
                k = j + 2
                sk, ck = np.sin(k * phase), np.cos(k * phase)
                p = p + b * ((1.0 - ck) / k - k * (1.0 - c1)) / TWO_PI
                dp = dp + b * (sk - k * s1)
                ddp = ddp + b * TWO_PI * k * (ck - c1)
        return p, dp, ddp


__all__ = ["Harmonic"]
