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

from typing import Any

# lazy: the command line imports flexlink.shaping.command at start-up, not the optimiser
_EXPORTS = {"Limits": "optimize", "OptimizedMove": "optimize", "optimize_move": "optimize",
            "InfeasibleMove": "optimize", "arm_modes": "plants",
            "scale_frequencies": "plants", "residual_peak": "residual"}


def __getattr__(name: str) -> Any:
    if name not in _EXPORTS:
        raise AttributeError(f"module 'flexlink.shaping' has no attribute {name!r}")
    from importlib import import_module

    return getattr(import_module(f".{_EXPORTS[name]}", __name__), name)


__all__ = ["InfeasibleMove", "Limits", "OptimizedMove", "arm_modes", "optimize_move",
           "residual_peak", "scale_frequencies"]
