"""Linearised plants and modes along a manoeuvre (docs/control.md): `linearize` gives a
`LinearPlant` (A, B, C, D with named states, inputs and outputs) about a rest configuration
or a time of a run; `frozen_modes` the frozen-time natural frequencies, damping ratios and
mode shapes over a run or a grid of joint angles."""

from .linear import LinearPlant
from .linearize import linearize
from .modes import FrozenModes, frozen_modes

__all__ = ["FrozenModes", "LinearPlant", "frozen_modes", "linearize"]
