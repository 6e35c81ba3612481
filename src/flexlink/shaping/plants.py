"""The arm as a plant for shaping: its frequencies at a configuration, and detuned copies.

Frequencies and damping ratios are the frozen-time modes of the linearised plant
(`flexlink.control.frozen_modes`, what `flexlink modes` prints) of the arm held still at the
given joint angles: no modal physics of its own.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from ..control import frozen_modes
from ..model import Scenario


def arm_modes(scenario: Scenario, angles_deg: Sequence[float], count: int | None = None,
              geometric_stiffening: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(frequencies in Hz, damping ratios) of the lowest ``count`` modes (all if None) of the
    arm held at ``angles_deg`` (deg, one per joint), lowest first."""
    if len(angles_deg) != len(scenario.chain.joints):
        raise ValueError(f"give one angle per joint ({len(scenario.chain.joints)}), got "
                         f"{len(angles_deg)}")
    if all(link.rigid for link in scenario.chain.links):
        return np.zeros(0), np.zeros(0)
    if geometric_stiffening is not None:
        settings = dataclasses.replace(scenario.settings,
                                       geometric_stiffening=geometric_stiffening)
        scenario = dataclasses.replace(scenario, settings=settings)
    grid = {f"joint{k + 1}": [float(a)] for k, a in enumerate(angles_deg)}
    modes = frozen_modes(scenario, angles=grid, count=count)
    return modes.frequency_hz[0], modes.damping_ratio[0]


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
