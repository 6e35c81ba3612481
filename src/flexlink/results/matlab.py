"""The MATLAB file of a `Layout` (results.mat of a run, a sweep written to ``*.mat``).

``scipy.io.savemat`` (MATLAB 5 format, ``load`` reads it), the same content as the netCDF
file: ``t`` (s, a column), one variable per netCDF variable under a MATLAB-valid name (a run:
one column per channel; a sweep: case × time matrices, parameters per case, ``status`` and
``error`` as cell arrays of text), then

- ``variables``: a struct array, one element per variable: ``name`` (as in results.csv and
  the netCDF file), ``matlab_name`` (the variable in this file), ``dims``, and the netCDF
  attributes (``units``, ``long_name`` = description, ``kind``, ``quantity``, ``subject`` …;
  empty where a variable has none);
- ``attributes``: a struct of the global attributes (title, history, metadata).

NaN marks missing values, as in the netCDF file.
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import atomic_file
from .variables import Layout

MAX_NAME = 63  # MATLAB's namelengthmax
# MATLAB keywords (iskeyword): a variable cannot take these names
MATLAB_KEYWORDS = frozenset((
    "break", "case", "catch", "classdef", "continue", "else", "elseif", "end", "for",
    "function", "global", "if", "otherwise", "parfor", "persistent", "return", "spmd",
    "switch", "try", "while"))
RESERVED = ("variables", "attributes")
_MATLAB_TIME = "t"  # as in results.csv


def matlab_names(names: Iterable[str], taken: Iterable[str] = ()) -> dict[str, str]:
    """A MATLAB-valid, unique variable name for each name: other characters become ``_``, a
    leading non-letter gets ``x``, keywords get a trailing ``_``, at most 63 characters,
    clashes (with each other and with ``taken``) get ``_2``, ``_3`` …"""
    used = set(taken)
    out = {}
    for name in names:
        base = re.sub(r"[^A-Za-z0-9_]+", "_", name).strip("_") or "x"
        if not base[0].isalpha():
            base = "x" + base
        if base in MATLAB_KEYWORDS:
            base += "_"
        candidate, k = base[:MAX_NAME], 1
        while candidate in used:
            k += 1
            candidate = f"{base[:MAX_NAME - len(str(k)) - 1]}_{k}"
        used.add(candidate)
        out[name] = candidate
    return out


def write_mat_atomic(layout: Layout, path: str | Path) -> Path:
    """Write ``layout`` as a MATLAB file at ``path`` atomically; return the path."""
    with atomic_file(path) as partial:
        write_mat(layout, partial)
    return Path(path)


def write_mat(layout: Layout, path: Path) -> None:
    """Write ``layout`` to ``path`` (see the module docstring)."""
    from scipy.io import savemat

    variables = layout.variables
    names = matlab_names([n for n in variables if n != "time"], taken=(_MATLAB_TIME, *RESERVED))
    if "time" in variables:
        names = {"time": _MATLAB_TIME, **names}
    content: dict[str, Any] = {names[n]: _matlab_values(v.values) for n, v in variables.items()}
    content["variables"] = _variable_table(layout, names)
    keys = matlab_names(layout.attrs)
    content["attributes"] = {keys[k]: v for k, v in layout.attrs.items()}
    # a file object: savemat would append ".mat" to a path without that suffix
    with open(path, "wb") as fh:
        savemat(fh, content, oned_as="column", long_field_names=True)


def _matlab_values(values: np.ndarray) -> np.ndarray:
    """Text as a cell array (one text per case); numbers as they are."""
    values = np.asarray(values)
    if values.dtype.kind in "UO":
        return values.astype(object)
    return values


def _variable_table(layout: Layout, names: dict[str, str]) -> np.ndarray:
    """A 1 × n struct array describing each variable (see the module docstring)."""
    variables = layout.variables
    keys = list(dict.fromkeys(k for v in variables.values() for k in v.attrs))
    fields = ["name", "matlab_name", "dims", *matlab_names(keys, ("name", "matlab_name",
                                                                  "dims")).values()]
    table = np.empty((1, len(variables)), dtype=[(f, object) for f in fields])
    for i, (name, variable) in enumerate(variables.items()):
        table[0, i] = (name, names[name], ",".join(variable.dims),
                       *(variable.attrs.get(k, "") for k in keys))
    return table
