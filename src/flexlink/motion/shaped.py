"""Shaped joint motion: a profile convolved with an input shaper (`flexlink.motion.shapers`).

θ(t) = Σ_i A_i · base(t − t_i): since Σ A_i = 1, the move starts and ends at the base's angles
and lasts the base's duration plus the shaper's. Rate and acceleration are the same sums of
the base's analytic derivatives. SI inside (s, rad); see docs/motion.md and docs/shaping.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .profiles import Triple
from .shapers import ImpulseSequence


@dataclass(frozen=True)
class Shaped:
    """``profile`` (any rest-to-rest or spin-up profile with ``start``) shaped by ``shaper``."""

    profile: object  # a JointMotion with start, end, from_deg and breakpoints
    shaper: ImpulseSequence

    def __post_init__(self) -> None:
        for attribute in ("evaluate", "start", "end"):
            if not hasattr(self.profile, attribute):
                raise ValueError(f"Shaped: the shaped profile must be a timed move (cycloidal, "
                                 f"quintic, harmonic or spinup), got "
                                 f"{type(self.profile).__name__}")
        if not isinstance(self.shaper, ImpulseSequence):
            raise ValueError(  # noqa: TRY004 — the scenario reader reports ValueErrors
                "Shaped: shaper must be an ImpulseSequence (motion.shapers.design)")

    @property
    def start(self) -> float:
        """Time the shaped move starts (the base's start), s."""
        return float(self.profile.start)  # type: ignore[attr-defined]

    @property
    def end(self) -> float:
        """Time the shaped move ends: the base's end plus the shaper's length, s."""
        return float(self.profile.end) + self.shaper.duration  # type: ignore[attr-defined]

    @property
    def from_deg(self) -> float:
        """Angle held before the move, deg (the base's)."""
        return float(self.profile.from_deg)  # type: ignore[attr-defined]

    @property
    def to_deg(self) -> float:
        """Angle reached at the end, deg (the base's; a spin-up has none)."""
        return float(self.profile.to_deg)  # type: ignore[attr-defined]

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """The base's breakpoints shifted by every impulse time, s."""
        base = getattr(self.profile, "breakpoints", ())
        return tuple(sorted({b + ti for b in base for ti in self.shaper.times}))

    def evaluate(self, t: np.ndarray) -> Triple:
        """Angle (rad), rate (rad/s), acceleration (rad/s²) at times t (s), shaped like t."""
        t = np.asarray(t, dtype=float)
        out = [np.zeros(t.shape) for _ in range(3)]
        for a, ti in zip(self.shaper.amplitudes, self.shaper.times, strict=True):
            for total, part in zip(out, self.profile.evaluate(t - ti), strict=True):  # type: ignore[attr-defined]
                total += a * part
        return out[0], out[1], out[2]





def shaped_move(shaped: str, from_deg: float, to_deg: float, start: float, duration: float,
                shaper: str, frequencies_hz: list[float], damping: list[float] | None = None,
                tolerable_vibration: float = 0.05) -> Shaped:
    """The scenario's ``profile = "shaped"``: a ``shaped`` ("cycloidal" or "quintic") move
    (degrees, s) convolved with the ``shaper`` designed for the target modes (Hz, damping
    ratios; none: undamped)."""
    from .profiles import Cycloidal, Quintic
    from .shapers import design

    bases = {"cycloidal": Cycloidal, "quintic": Quintic}
    if shaped not in bases:
        raise ValueError(f"Shaped: shaped must be 'cycloidal' or 'quintic', got {shaped!r}")
    base = bases[shaped](from_deg, to_deg, start, duration)
    zetas = [0.0] if damping is None else damping
    try:
        sequence = design(shaper, frequencies_hz, zetas if len(zetas) > 1 else zetas[0],
                          tolerable_vibration)
    except ValueError as exc:
        raise ValueError(f"Shaped: {exc}") from None
    return Shaped(base, sequence)
__all__ = ["Shaped", "shaped_move"]
