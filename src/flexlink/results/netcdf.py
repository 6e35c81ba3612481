"""Write an `xarray.Dataset` to a netCDF file atomically (sweep results).

The file is written under a hidden temporary name beside the target and renamed over it
(``os.replace``, atomic on one file system): readers see the old file or the new one, never a
half-written file, and a failed write leaves nothing behind.
"""

from __future__ import annotations

import os
import uuid
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import xarray as xr


def write_netcdf_atomic(dataset: xr.Dataset, path: str | Path) -> Path:
    """netCDF-3 (64-bit offsets) through scipy, so no netCDF4 library is needed; return path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.parent / f".{path.name}.partial-{uuid.uuid4().hex[:8]}"
    try:
        dataset.to_netcdf(partial, engine="scipy", format="NETCDF3_64BIT")
        os.replace(partial, path)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise
    return path
