"""The content of one netCDF (or .mat) file in memory: variables with their dimensions,
values and attributes, and the file's global attributes. `layout` fills it, `netcdf` and
`matlab` write it, `reading` and the sweep code read it."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import xarray as xr


@dataclass(frozen=True)
class Variable:
    """One netCDF variable: dimension names, values, attributes; ``missing``: NaN marks values
    that do not exist (written with ``_FillValue`` NaN)."""

    dims: tuple[str, ...]
    values: np.ndarray
    attrs: Mapping[str, Any] = field(default_factory=dict)
    missing: bool = False


@dataclass(frozen=True)
class Layout:
    """The content of one netCDF file: coordinates, data variables, global attributes."""

    coords: dict[str, Variable]
    data: dict[str, Variable]
    attrs: dict[str, Any]

    @property
    def variables(self) -> dict[str, Variable]:
        """Coordinates first, then data variables, in order."""
        return {**self.coords, **self.data}

    def to_xarray(self) -> xr.Dataset:
        """The same content as an `xarray.Dataset`; ``encoding`` carries the fill values, so
        that ``dataset.to_netcdf`` writes what `write_netcdf_atomic` writes."""
        import xarray as xr

        def variable(v: Variable) -> xr.Variable:
            out = xr.Variable(v.dims, v.values, dict(v.attrs))
            if out.dtype.kind == "f":
                out.encoding["_FillValue"] = np.nan if v.missing else None
            return out

        return xr.Dataset({n: variable(v) for n, v in self.data.items()},
                          coords={n: variable(v) for n, v in self.coords.items()},
                          attrs=dict(self.attrs))
