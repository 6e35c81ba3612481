"""Sweep errors: every problem of a sweep definition is reported at once, before any case runs."""

from __future__ import annotations

from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import xarray as xr


class SweepError(ValueError):
    """An invalid sweep (parameters, values, base scenario). ``problems`` lists every message."""

    def __init__(self, problems: Iterable[str]) -> None:
        self.problems = list(problems)
        count = len(self.problems)
        head = f"sweep has {count} problem{'s' if count != 1 else ''}:"
        super().__init__("\n".join([head, *(f"  - {p}" for p in self.problems)]))


class SweepInterrupted(KeyboardInterrupt):
    """Ctrl-C during a sweep. ``dataset`` holds every case finished so far (status "ok" or
    "failed"; the rest "not_run"); it was also written to ``output`` if one was given."""

    def __init__(self, dataset: xr.Dataset) -> None:
        super().__init__("sweep interrupted")
        self.dataset = dataset
