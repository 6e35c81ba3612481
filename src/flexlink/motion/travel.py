"""A cart's prescribed travel (m) from the joint profiles: one copy of each profile's
formulas. The profiles take degrees and evaluate radians; a travel profile is written in
metres where the profile takes degrees, and `Travel` reads its values back in metres."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import JointMotion

_PER_RADIAN = 180.0 / math.pi  # the profile's radians back to the metres written as degrees


@dataclass(frozen=True)
class Travel:
    """Travel s(t) (m), speed (m/s) and acceleration (m/s²) of ``profile`` (a joint profile
    or Sequence built with metres in place of degrees)."""

    profile: JointMotion

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """Times (s) where the acceleration is not smooth: the profile's."""
        return tuple(getattr(self.profile, "breakpoints", ()))

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s, v, a = self.profile.evaluate(t)
        return s * _PER_RADIAN, v * _PER_RADIAN, a * _PER_RADIAN
