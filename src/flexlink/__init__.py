"""flexlink — planar flexible multibody chains with assumed modes.

Pipeline: scenario → model → simulation → solution → results (see ARCHITECTURE.md).
"""

from __future__ import annotations

from typing import Any

__all__ = [
    "MeanSquare",
    "Objective",
    "Results",
    "Scenario",
    "__version__",
    "frozen_modes",
    "linearize",
    "load_paper_experiment",
    "load_scenario",
    "mode_convergence",
    "simulate",
    "sweep",
]


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


def __getattr__(name: str) -> Any:
    # Lazy exports keep `flexlink --help` fast and sub-packages importable on their own.
    if name == "__version__":
        from ._version import package_version

        return package_version()
    if name == "simulate":
        from .simulation import simulate

        return simulate
    if name in ("Objective", "MeanSquare"):
        from .simulation import objective

        return getattr(objective, name)
    if name == "sweep":
        from .batch import sweep

        return sweep
    if name in ("load_scenario", "load_paper_experiment"):
        from . import scenario

        return getattr(scenario, name)
    if name == "Results":
        from .results import Results

        return Results
    if name == "Scenario":
        from .model import Scenario

        return Scenario
    if name in ("linearize", "frozen_modes", "mode_convergence"):
        from . import control

        return getattr(control, name)
    raise AttributeError(f"module 'flexlink' has no attribute {name!r}")
