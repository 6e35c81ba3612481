"""The netCDF file of a `Layout` (runs and sweeps): written and read with scipy alone.

netCDF-3 with 64-bit offsets (``scipy.io.netcdf_file``, version 2), so neither the netCDF4
library nor xarray is needed to write or read it; xarray, MATLAB ``ncread`` and Julia read it.
What xarray would do when writing a Dataset to netCDF-3 is done here once, for the layout's
few types: text as UTF-8 character arrays (``_Encoding``), integers as int32, the
non-dimension coordinates named in each variable's ``coordinates`` attribute, ``_FillValue``
NaN on variables whose NaN marks missing values.
"""

from __future__ import annotations

from collections.abc import Mapping
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import atomic_file
from .variables import Layout, Variable

_INT32 = np.iinfo(np.int32)
_ENCODING = "utf-8"
_WRITE_SLICE = 1 << 22  # bytes converted to big-endian at a time


def write_netcdf_atomic(layout: Layout, path: str | Path) -> Path:
    """Write ``layout`` to ``path`` atomically (see `atomic.atomic_file`); return the path."""
    with atomic_file(path) as partial:
        write_netcdf(layout, partial)
    return Path(path)


def write_netcdf(layout: Layout, path: Path) -> None:
    """Write ``layout`` to ``path`` (netCDF-3, 64-bit offsets)."""
    variables = {name: _stored(v) for name, v in layout.variables.items()}
    coordinates = _coordinates_attribute(layout)
    with _streaming_file()(path, "w", version=2) as nc:
        for key, value in layout.attrs.items():
            setattr(nc, key, _attribute(value))
        for name, (dims, values) in variables.items():
            _create_dimensions(nc, name, dims, values.shape)
        for name, (dims, values) in variables.items():
            variable = layout.variables[name]
            var = nc.add_variable(name, values, dims)
            attrs = dict(variable.attrs)
            if variable.missing:
                attrs["_FillValue"] = np.float64(np.nan)
            if values.dtype.kind == "S":
                attrs["_Encoding"] = _ENCODING
            if name in coordinates:
                attrs["coordinates"] = coordinates[name]
            for key, value in attrs.items():
                setattr(var, key, _attribute(value))


def _stored(variable: Variable) -> tuple[tuple[str, ...], np.ndarray]:
    """Dimensions and values as netCDF-3 holds them (text: a trailing character dimension)."""
    values = np.asarray(variable.values)
    if values.dtype.kind in "UO":
        encoded = np.char.encode(values.astype(str), _ENCODING)
        width = max(1, encoded.dtype.itemsize)
        chars = np.ascontiguousarray(encoded.astype(f"S{width}")).view("S1")
        return (*variable.dims, f"string{width}"), chars.reshape(*values.shape, width)
    if values.dtype.kind in "iub":
        if values.size and (values.min() < _INT32.min or values.max() > _INT32.max):
            raise ValueError("netCDF-3 holds integers of 32 bits only")
        return variable.dims, values.astype(np.int32)
    if values.dtype == np.float32:  # stored single on purpose (the links' shapes)
        return variable.dims, values
    return variable.dims, np.asarray(values, dtype=np.float64)  # no copy of float64 data


@cache
def _streaming_file() -> type:
    """scipy's `netcdf_file` that writes each variable's data from the caller's array, in
    big-endian slices of a few MB, instead of a big-endian copy of every variable held until
    the file is closed: a sweep's channels (hundreds of MB) are written without a second and
    third copy in memory. The bytes written are the same."""
    from scipy.io import netcdf_file
    from scipy.io._netcdf import netcdf_variable

    class StreamingFile(netcdf_file):  # type: ignore[misc]
        def add_variable(self, name: str, values: np.ndarray, dims: tuple[str, ...]) -> Any:
            """A variable holding ``values`` (native byte order) as they are."""
            values = np.ascontiguousarray(values)
            shape = tuple(self.dimensions[d] for d in dims)
            self.variables[name] = netcdf_variable(values, values.dtype.char,
                                                   values.dtype.itemsize, shape, dims)
            return self.variables[name]

        def _write_var_data(self, name: str) -> None:
            var = self.variables[name]
            if var.isrec:  # no record (unlimited) dimension in flexlink's layouts
                super()._write_var_data(name)
                return
            begin = self.fp.tell()  # as scipy: the variable's offset, in its header entry
            self.fp.seek(var._begin)
            self._pack_begin(begin)
            self.fp.seek(begin)
            flat = var.data.reshape(-1)
            big = flat.dtype.newbyteorder(">")
            step = max(1, _WRITE_SLICE // flat.dtype.itemsize)
            for start in range(0, flat.size, step):
                self.fp.write(np.asarray(flat[start:start + step], dtype=big).tobytes())
            self._write_var_padding(var, var._vsize - flat.size * flat.dtype.itemsize)

    return StreamingFile


def _create_dimensions(nc: Any, name: str, dims: tuple[str, ...], shape: tuple[int, ...]) -> None:
    for dim, size in zip(dims, shape, strict=True):
        if dim not in nc.dimensions:
            nc.createDimension(dim, size)
        elif nc.dimensions[dim] != size:
            raise ValueError(f"variable {name!r}: dimension {dim} has {size} entries, "
                             f"not {nc.dimensions[dim]}")


def _coordinates_attribute(layout: Layout) -> dict[str, str]:
    """Each data variable's non-dimension coordinates (CF ``coordinates``): those whose
    dimensions it has; this is how readers tell them from data variables."""
    extra = {n: v for n, v in layout.coords.items() if v.dims != (n,)}
    out = {}
    for name, variable in layout.data.items():
        names = [n for n, v in extra.items() if set(v.dims) <= set(variable.dims)]
        if names:
            out[name] = " ".join(names)
    return out


def _attribute(value: Any) -> Any:
    """An attribute value as scipy writes it faithfully (it would store a Python float in
    32 bits and refuses non-ASCII text)."""
    if isinstance(value, str):
        return value.encode(_ENCODING)
    if isinstance(value, bool | np.bool_):
        return np.int32(value)
    if isinstance(value, int | np.integer):
        return np.int32(value)
    if isinstance(value, float | np.floating):
        return np.float64(value)
    return np.asarray(value)


def read_netcdf(path: str | Path) -> Layout:
    """The `Layout` of a netCDF file written by `write_netcdf` (inverse of it)."""
    from scipy.io import netcdf_file

    with netcdf_file(path, "r", mmap=False) as nc:
        # scipy keeps attributes in `_attributes` only (xarray's scipy backend reads it too)
        attrs = {k: _decoded(v) for k, v in nc._attributes.items()}
        read = {name: _read_variable(var) for name, var in nc.variables.items()}
    listed = {c for _, (_, a) in read.items() for c in str(a.get("coordinates", "")).split()}
    coords, data = {}, {}
    for name, (variable, attributes) in read.items():
        is_coord = variable.dims == (name,) or name in listed
        (coords if is_coord else data)[name] = variable
    return Layout(coords, data, attrs)


def _read_variable(var: Any) -> tuple[Variable, Mapping[str, Any]]:
    raw = {k: _decoded(v) for k, v in var._attributes.items()}
    attrs = {k: v for k, v in raw.items() if k not in ("_FillValue", "_Encoding", "coordinates")}
    dims, values = tuple(var.dimensions), np.array(var.data)
    if values.dtype.kind == "S":  # character array: the last dimension is the text's width
        width = values.shape[-1]
        joined = np.ascontiguousarray(values).view(f"S{width}").reshape(values.shape[:-1])
        dims, values = dims[:-1], np.char.decode(joined, raw.get("_Encoding", _ENCODING))
    return Variable(dims, values, attrs, missing="_FillValue" in raw), raw


def _decoded(value: Any) -> Any:
    """A stored attribute as Python: text as str, a one-element array as its number."""
    if isinstance(value, bytes):
        return value.decode(_ENCODING)
    value = np.asarray(value)
    return value.item() if value.size == 1 else value
