"""Actuators: bonded piezo patches driven by a voltage (SI units)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from .histories import ZERO, History
from .sensors import PiezoPatch


@dataclass(frozen=True)
class PiezoActuator(PiezoPatch):
    """A PZT patch bonded on one link between x_start and x_end (m, from the link's joint).

    Pin-force model with the sensor's constants (paper eq. 37 read backwards): a voltage V
    strains the patch and it pulls on the host's surface at the two ends, a moment pair
    ±M at x_end and x_start with M = w_p E_p d31 (t/2) V [N·m]. Its virtual work
    M (δψ(x_end) − δψ(x_start)) makes it a generalized force on the link's modal coordinates
    only, the same in every model (ψ = Φ′q is exact in the nonlinear model too).

    ``voltage``: the open-loop command (V) over time; a controller's output adds to it.
    ``limit``: the amplifier's saturation |V| ≤ limit (V); the patch never sees more.
    """

    voltage: History = ZERO
    limit: float = math.inf  # V
