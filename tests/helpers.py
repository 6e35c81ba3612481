"""Small building blocks shared by the tests (kept independent of flexlink.motion)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from flexlink.model import Chain, Link


@dataclass(frozen=True)
class CubicMotion:
    """β(t) = c0 + c1 t + c2 t² + c3 t³ (rad): arbitrary angle, rate and acceleration at once."""

    c0: float
    c1: float = 0.0
    c2: float = 0.0
    c3: float = 0.0

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        angle = self.c0 + self.c1 * t + self.c2 * t**2 + self.c3 * t**3
        rate = self.c1 + 2 * self.c2 * t + 3 * self.c3 * t**2
        acc = 2 * self.c2 + 6 * self.c3 * t
        return angle, rate, acc


@dataclass(frozen=True)
class SmoothStep:
    """Rest-to-rest cycloidal move from a0 to a1 (rad) over [start, start + duration] (s)."""

    a0: float
    a1: float
    start: float
    duration: float

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        tau = np.clip((t - self.start) / self.duration, 0.0, 1.0)
        active = (t > self.start) & (t < self.start + self.duration)
        d = self.a1 - self.a0
        angle = self.a0 + d * (tau - np.sin(2 * np.pi * tau) / (2 * np.pi))
        rate = np.where(active, d / self.duration * (1 - np.cos(2 * np.pi * tau)), 0.0)
        acc = np.where(active, d / self.duration**2 * 2 * np.pi * np.sin(2 * np.pi * tau), 0.0)
        return angle, rate, acc


def paper_links(modes: int = 4, damping: bool = True) -> tuple[Link, Link]:
    """Table 1 of Choi & Kwak (2016) with the documented choices (E1 = 30 GPa)."""
    link1 = Link("link1", 1.37, 0.5292, 30e9 * 0.045 * 0.014**3 / 12, tip_mass=0.129,
                 damping_ratio=0.02 if damping else 0.0, modes=modes, thickness=0.014)
    link2 = Link("link2", 0.6, 0.0636, 70e9 * 0.028 * 0.001**3 / 12,
                 damping_ratio=0.01 if damping else 0.0, modes=modes, thickness=0.001)
    return link1, link2


def chain_of(links, motions) -> Chain:
    return Chain(tuple(links), tuple(motions))
