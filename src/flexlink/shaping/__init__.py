"""Manoeuvres without residual vibration: input-shaped and optimised joint trajectories.

* `plants` — the arm's frequencies and damping at a configuration (from the first-order
  model's M, C, K), and plants with every link's frequencies scaled (robust designs);
* `residual` — the one measure of residual vibration: elastic energy at the move's end, and
  the peak tip deflection after it;
* `optimize` — joint trajectories (cycloid plus harmonics) that minimise the residual energy
  under rate, acceleration and torque limits (`flexlink optimize`);
* `figures` — residual vibration of the unshaped, shaped and optimised moves, and residual
  against frequency error.

The shapers themselves are `flexlink.motion.shapers` (pure functions of frequencies, damping
and kind). Docs: docs/shaping.md.
"""

from .optimize import Limits, OptimizedMove, optimize_move
from .plants import arm_modes, scale_frequencies
from .residual import residual_peak

__all__ = ["Limits", "OptimizedMove", "arm_modes", "optimize_move", "residual_peak",
           "scale_frequencies"]
