"""Results: the `Results` of a run, their one netCDF layout, the run folder and its figures.

`read_run(folder)` reads a run folder back (`flexlink.results.reading`)."""

from __future__ import annotations

from typing import Any

from .results import Results

__all__ = ["Results", "read_run"]


def __getattr__(name: str) -> Any:
    # lazy: the writers are not needed to simulate
    if name == "read_run":
        from .reading import read_run

        return read_run
    raise AttributeError(f"module 'flexlink.results' has no attribute {name!r}")
