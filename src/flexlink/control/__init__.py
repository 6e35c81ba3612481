"""Linearised plants and modes along a manoeuvre (docs/control.md): `linearize` gives a
`LinearPlant` (A, B, C, D with named states, inputs and outputs) about a rest configuration
or a time of a run; `frozen_modes` the frozen-time natural frequencies, damping ratios and
mode shapes over a run or a grid of joint angles; `mode_convergence` how far those
frequencies are from converged in the assumed modes (docs/modes.md)."""

from __future__ import annotations

from typing import Any

__all__ = ["FrozenModes", "LinearPlant", "ModeConvergence", "frozen_modes", "linearize",
           "mode_convergence"]
_HOMES = {"LinearPlant": "linear", "linearize": "linearization", "FrozenModes": "modes",
          "frozen_modes": "modes", "ModeConvergence": "convergence",
          "mode_convergence": "convergence"}


def __getattr__(name: str) -> Any:
    # Lazy: the command line registers `flexlink linearize` (.command) at start-up, and the
    # equations behind these (scipy, the dynamics) must not load before `flexlink run` forks
    # its figure process.
    if name in _HOMES:
        from importlib import import_module

        return getattr(import_module(f".{_HOMES[name]}", __name__), name)
    raise AttributeError(f"module 'flexlink.control' has no attribute {name!r}")
