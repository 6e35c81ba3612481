"""Batch simulation: grid and random sweeps over scenario fields, on all cores or a Dask cluster.

Public API: `sweep` (also ``flexlink.sweep``), `read_sweep_file` (a sweep defined in TOML),
`SweepError`, `SweepInterrupted`, and the parameter constructors `grid_values`,
`random_distribution`. The method and the file layout
are documented in ``docs/sweep.md``.
"""

from __future__ import annotations

from typing import Any

__all__ = ["GridParameter", "RandomParameter", "SweepError", "SweepInterrupted", "grid_values",
           "random_distribution", "read_sweep_file", "sweep"]

_HOMES = {"sweep": "run", "SweepError": "errors", "SweepInterrupted": "errors",
          "GridParameter": "parameters", "RandomParameter": "parameters",
          "grid_values": "parameters", "random_distribution": "parameters",
          "read_sweep_file": "spec"}


def __getattr__(name: str) -> Any:
    # Lazy: `flexlink sweep --help` (which imports .command) must not load numpy and scipy.
    if name in _HOMES:
        from importlib import import_module

        return getattr(import_module(f".{_HOMES[name]}", __name__), name)
    raise AttributeError(f"module 'flexlink.batch' has no attribute {name!r}")
