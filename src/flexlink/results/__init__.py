"""Results: the `Results` of a run, their one netCDF layout, the run folder and its figures."""

from .results import Results

__all__ = ["Results"]
