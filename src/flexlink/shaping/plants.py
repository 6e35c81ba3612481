"""The arm as a plant for shaping: its frequencies at a configuration, and detuned copies.

Frequencies come from the first-order model's own M, C, K (`FirstOrderSystem.matrices`) at
the arm held still at the given joint angles: ω² are the eigenvalues of K φ = ω² M φ and each
mode's damping ratio is φᵀ C φ / (2ω) with φ mass-normalised (exact for the modal damping the
links carry, up to the small coupling of C between modes). No modal physics of its own.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np

from ..dynamics.first_order import FirstOrderSystem
from ..model import Scenario
from ..motion import Hold


def arm_modes(scenario: Scenario, angles_deg: Sequence[float], count: int | None = None,
              geometric_stiffening: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies in Hz, damping ratios) of the lowest ``count`` modes (all if None) of the
    arm held at ``angles_deg`` (deg, one per joint), lowest first."""
    from scipy.linalg import eigh

    if len(angles_deg) != len(scenario.chain.joints):
        raise ValueError(f"give one angle per joint ({len(scenario.chain.joints)}), got "
                         f"{len(angles_deg)}")
    chain = dataclasses.replace(scenario.chain, joints=tuple(Hold(float(a)) for a in angles_deg))
    stiffening = (scenario.settings.geometric_stiffening if geometric_stiffening is None
                  else geometric_stiffening)
    system = FirstOrderSystem(chain, stiffening)
    if system.n == 0:
        return np.zeros(0), np.zeros(0)
    M, C, K, _ = (a[0] for a in system.matrices(np.zeros(1)))
    w2, phi = eigh(K, M)  # φᵀ M φ = I
    w = np.sqrt(np.maximum(w2, 0.0))
    zeta = np.einsum("ij,ik,kj->j", phi, C, phi) / (2.0 * np.where(w > 0, w, 1.0))
    n = w.size if count is None else min(count, w.size)
    return w[:n] / (2.0 * math.pi), zeta[:n]


def scale_frequencies(scenario: Scenario, factor: float) -> Scenario:
    """``scenario`` with every flexible link's EI multiplied by factor², which multiplies every
    clamped frequency by ``factor`` (the plant of a frequency error of factor − 1)."""
    if not factor > 0.0:
        raise ValueError(f"frequency factor must be > 0, got {factor!r}")
    links = tuple(link if link.rigid else dataclasses.replace(link, EI=link.EI * factor**2)
                  for link in scenario.chain.links)
    chain = dataclasses.replace(scenario.chain, links=links)
    return dataclasses.replace(scenario, chain=chain)


__all__ = ["arm_modes", "scale_frequencies"]
