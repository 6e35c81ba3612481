"""The one netCDF layout of runs and sweeps, as an `xarray.Dataset`."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import xarray as xr

    from .results import Results


def run_dataset(results: Results) -> xr.Dataset:
    """One variable per channel over ``time`` with ``units``, ``long_name`` and ``kind``."""
    import xarray as xr

    data_vars = {
        n: ("time", results[n], {"units": c.unit, "long_name": c.description, "kind": c.kind.value})
        for n, c in results.channels.items()
    }
    attrs = {k: str(v) for k, v in results.metadata.items()}
    return xr.Dataset(data_vars, coords={"time": ("time", results.time, {"units": "s"})},
                      attrs=attrs)
