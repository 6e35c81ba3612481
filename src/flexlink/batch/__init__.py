"""Batch simulation: grid and random sweeps over scenario fields, on all cores or a Dask cluster.

Public API: `sweep` (also ``flexlink.sweep``), `SweepError`, `SweepInterrupted`, and the
parameter constructors `grid_values`, `random_distribution`. The method and the file layout
are documented in ``docs/sweep.md``.
"""

from __future__ import annotations

from .errors import SweepError, SweepInterrupted
from .parameters import GridParameter, RandomParameter, grid_values, random_distribution
from .run import sweep

__all__ = ["GridParameter", "RandomParameter", "SweepError", "SweepInterrupted", "grid_values",
           "random_distribution", "sweep"]
