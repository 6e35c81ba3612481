"""The one netCDF layout of runs and sweeps: what results.nc and a sweep's file hold.

A `Layout` is plain numpy arrays and attribute dicts, no xarray: `flexlink run` writes
results.nc without importing xarray, whose import would be a large part of the command.
`Layout.to_xarray()` is the same content as an `xarray.Dataset` (what `Results.to_xarray()`
and `flexlink.sweep` return); `netcdf.write_netcdf_atomic` and `matlab.write_mat_atomic`
write it, `netcdf.read_netcdf` reads it back.

Conventions (CF-1.8):

- every variable has ``units`` (UDUNITS spelling) and ``long_name``; a channel adds its
  ``kind``, and its ``quantity`` and ``subject`` where it has them;
- the coordinate ``time`` is in s from the start of the simulation;
- global attributes ``Conventions``, ``title``, ``history`` (ISO time and what wrote it),
  ``references``, ``source`` (flexlink and its version), ``date_created``, then the metadata
  of the run or sweep, numbers as numbers;
- netCDF-3 has no booleans: true and false are stored as 1 and 0, and the names of those
  attributes are listed in the attribute ``boolean_attributes``; it has no 64-bit integers
  either: integers beyond 32 bits are stored as text (a sweep's ``seed`` always is);
- values that do not exist (the signals of a sweep's cases that did not finish) are NaN,
  declared by ``_FillValue`` = NaN.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..channels import Channel, ChannelKind, ChannelTable
from .variables import Layout, Variable

CONVENTIONS = "CF-1.8"
REFERENCES = ("M. S. Choi and M. K. Kwak (2016), Dynamic modeling of planar system consisting "
              "of two flexible links and experiment (the model flexlink implements and extends)")
BOOLEANS = "boolean_attributes"
# global attributes that describe the file, not the run: not part of a run's metadata
FILE_ATTRIBUTES = ("Conventions", "title", "history", "references", "source", "date_created",
                   BOOLEANS)
_INT32 = np.iinfo(np.int32)


def time_variable(time: np.ndarray) -> Variable:
    """The coordinate ``time`` (s)."""
    return Variable(("time",), np.asarray(time, dtype=float),
                    {"units": "s", "long_name": "time from the start of the simulation"})


def channel_attributes(channel: Channel) -> dict[str, str]:
    """``units``, ``long_name``, ``kind``, and ``quantity`` and ``subject`` if not empty."""
    attrs = {"units": channel.unit, "long_name": channel.description,
             "kind": channel.kind.value}
    attrs.update({k: v for k, v in (("quantity", channel.quantity),
                                    ("subject", channel.subject)) if v})
    return attrs


def channel_of(name: str, attrs: Mapping[str, Any]) -> Channel:
    """The channel record a variable's attributes describe (inverse of `channel_attributes`)."""
    return Channel(name, ChannelKind(attrs["kind"]), str(attrs.get("units", "")),
                   str(attrs.get("long_name", "")), str(attrs.get("quantity", "")),
                   str(attrs.get("subject", "")))


def global_attributes(title: str, created: str, wrote: str,
                      metadata: Mapping[str, Any]) -> dict[str, Any]:
    """The CF attributes, then ``metadata`` encoded for netCDF-3 (see the module docstring).

    ``created``: ISO 8601 time; ``wrote``: what made the data (``simulate …``, ``sweep …``)."""
    version = metadata.get("flexlink_version", "unknown")
    attrs: dict[str, Any] = {
        "Conventions": CONVENTIONS, "title": title,
        "history": f"{created} flexlink {version}: {wrote}",
        "references": REFERENCES, "source": f"flexlink {version}", "date_created": created,
    }
    booleans = []
    for key, value in metadata.items():
        if value is None or key in FILE_ATTRIBUTES:
            continue
        if isinstance(value, bool | np.bool_):
            booleans.append(key)
        attrs[key] = encode_attribute(value)
    if booleans:
        attrs[BOOLEANS] = " ".join(booleans)
    return attrs


def encode_attribute(value: Any) -> str | int | float:
    """A metadata value as netCDF-3 can hold it: bool as 0/1, int as int32 or else text,
    float, text."""
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, int | np.integer):
        return int(value) if _INT32.min <= value <= _INT32.max else str(value)
    if isinstance(value, float | np.floating):
        return float(value)
    return str(value)


def metadata_of(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """The metadata among global attributes (inverse of `global_attributes`: booleans back)."""
    booleans = set(str(attrs.get(BOOLEANS, "")).split())
    out: dict[str, Any] = {}
    for key, value in attrs.items():
        if key in FILE_ATTRIBUTES:
            continue
        if isinstance(value, np.generic):
            value = value.item()
        out[key] = bool(value) if key in booleans else value
    return out


def run_layout(results: ChannelTable) -> Layout:
    """A run: one variable per channel over ``time``; the links' deformed shapes, if the
    results have them (`shapes.shape_variables`); the metadata as global attributes."""
    from .shapes import shape_variables

    meta = results.metadata
    data = {n: Variable(("time",), results[n], channel_attributes(c))
            for n, c in results.channels.items()}
    shape_coords, shape_data = shape_variables(getattr(results, "shapes", ()))
    data.update(shape_data)
    what = ", ".join(f"{meta[k]}" for k in ("model", "method") if k in meta)
    wrote = f"simulate scenario {meta.get('scenario', '')!r}" + (f" ({what})" if what else "")
    title = f"flexlink run of scenario {meta.get('scenario', '')!r}"
    return Layout({"time": time_variable(results.time), **shape_coords}, data,
                  global_attributes(title, results.created, wrote, meta))


def parameter_variable(path: str, values: np.ndarray, description: str,
                       unit: str | None) -> Variable:
    """A sweep parameter's coordinate on ``case``: the scenario field's value in each case."""
    attrs = {"long_name": f"scenario field {path}", "sweep": description}
    if unit is not None:
        attrs["units"] = unit
    return Variable(("case",), np.asarray(values), attrs)


STATUS_MEANING = ("ok: finished; failed: see error; not_run: never ran (interrupted). "
                  "The signals of cases that are not ok are NaN")


def sweep_layout(time: np.ndarray | None, parameters: Mapping[str, Variable],
                 channels: Sequence[Channel], values: np.ndarray | None, status: np.ndarray,
                 error: np.ndarray, wall_time: np.ndarray, cpu_time: np.ndarray,
                 metadata: Mapping[str, Any], summaries: Mapping[str, Variable] | None = None
                 ) -> Layout:
    """A sweep: every channel over (case, time), NaN where a case is not ``ok``; the
    parameters as coordinates on ``case``; ``status``, ``error``, ``wall_time`` and
    ``cpu_time`` (s, NaN where a case did not finish) per case; ``summaries``, variables
    over ``case``.

    ``values``: channel × case × time (``time`` None: no histories, no time axis);
    ``metadata`` holds ``title`` and ``date_created``."""
    cases = status.size
    coords = {
        "case": Variable(("case",), np.arange(cases, dtype=np.int32),
                         {"long_name": "case number (0-based, in the order of the parameter "
                                       "table)", "units": "1"}),
        **({} if time is None else {"time": time_variable(time)}),
        **parameters,
    }
    data = {c.name: Variable(("case", "time"), values[k], channel_attributes(c), missing=True)
            for k, c in enumerate(channels) if values is not None}
    data.update(summaries or {})
    data["status"] = Variable(("case",), status.astype(str), {"long_name": STATUS_MEANING})
    data["error"] = Variable(("case",), error.astype(str),
                             {"long_name": "failure message of a failed case, else empty"})
    data["wall_time"] = Variable(("case",), wall_time, {
        "units": "s", "long_name": "wall time of the case's simulation"}, missing=True)
    data["cpu_time"] = Variable(("case",), cpu_time, {
        "units": "s", "long_name": "CPU time of the case's simulation (of the thread that "
                                   "ran it)"}, missing=True)
    rest = {k: v for k, v in metadata.items() if k not in ("title", "date_created")}
    wrote = f"sweep of {cases} cases ({rest.get('sweep_state', '')})"
    return Layout(coords, data, global_attributes(str(metadata.get("title", "flexlink sweep")),
                                                  str(metadata.get("date_created", "")), wrote,
                                                  rest))
