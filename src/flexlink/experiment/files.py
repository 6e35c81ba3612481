"""Read a measurement file into named raw columns: CSV with a header row, or MATLAB .mat.

No units, no mapping, no cleaning here (see `measurement.py`): only "which columns exist and
what numbers do they hold". Empty CSV fields and 'nan' become NaN (the conditioning step
decides what to do with them); anything else that is not a number is an error naming the line.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np


class MeasurementError(ValueError):
    """A measurement file or mapping that cannot be used; the message says what and how to fix."""


def read_columns(path: str | Path) -> dict[str, np.ndarray]:
    """Columns of a .csv/.txt (header row) or .mat file, by name, as float arrays."""
    path = Path(path)
    if not path.is_file():
        raise MeasurementError(f"measurement file not found: {path}")
    if path.suffix.lower() == ".mat":
        return read_mat(path)
    return read_csv(path)


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """A delimited text file with one header row; ',', ';' or tab separated; '#' comments."""
    try:
        text = path.read_text(encoding="utf-8-sig")  # tolerate a BOM (Excel exports)
    except UnicodeDecodeError:
        raise MeasurementError(f"{path}: not a UTF-8 text file; a measurement must be CSV "
                               "with a header row or a MATLAB .mat file") from None
    lines = [(i + 1, line) for i, line in enumerate(text.splitlines())
             if line.strip() and not line.lstrip().startswith("#")]
    if not lines:
        raise MeasurementError(f"{path}: empty file, expected a header row of column names")
    first = lines[0][1]
    delimiter = max((",", ";", "\t"), key=first.count)
    if first.count(delimiter) == 0:
        delimiter = ","
    rows = list(csv.reader((line for _, line in lines), delimiter=delimiter))
    header = [h.strip() for h in rows[0]]
    _check_header(header, path)
    if len(rows) < 2:
        raise MeasurementError(f"{path}: a header row but no data")
    data = np.empty((len(rows) - 1, len(header)))
    for r, ((line_no, _), row) in enumerate(zip(lines[1:], rows[1:], strict=True)):
        if len(row) != len(header):
            raise MeasurementError(
                f"{path}: line {line_no} has {len(row)} fields but the header has "
                f"{len(header)} (columns of unequal length, or a stray '{delimiter}')")
        for c, field in enumerate(row):
            field = field.strip()
            if not field:
                data[r, c] = np.nan  # a missing sample: conditioning fills or rejects it
                continue
            try:
                data[r, c] = float(field)
            except ValueError:
                raise MeasurementError(f"{path}: line {line_no}, column {header[c]!r}: cannot "
                                       f"read {field!r} as a number") from None
    return {name: data[:, c] for c, name in enumerate(header)}


def _check_header(header: list[str], path: Path) -> None:
    if not all(header):
        raise MeasurementError(f"{path}: the header row has an empty column name")
    try:
        [float(h) for h in header]
    except ValueError:
        pass
    else:
        raise MeasurementError(f"{path}: the first row holds numbers, expected a header row of "
                               "column names (e.g. t,beta1,beta2,acc)")
    seen = set()
    for name in header:
        if name in seen:
            raise MeasurementError(f"{path}: duplicate column name {name!r} in the header row")
        seen.add(name)


def read_mat(path: Path) -> dict[str, np.ndarray]:
    """A MATLAB v4–v7 .mat file. Numeric vectors become columns named after the variable;
    an N×M matrix gives columns ``name(1)`` … ``name(M)``; struct fields are ``name.field``;
    a dSPACE/Simulink-style struct array with ``name``/``Name`` and ``data``/``Data`` (or
    ``values``) fields is named by its ``name``."""
    from scipy.io import loadmat

    try:
        content = loadmat(path, squeeze_me=True, struct_as_record=False)
    except NotImplementedError:  # scipy's answer to an HDF5-based v7.3 file
        raise MeasurementError(
            f"{path}: MATLAB v7.3 (HDF5) files are not supported; save it as v7 with "
            "save(FILE, VARS, '-v7') or export a CSV") from None
    except (ValueError, TypeError, OSError) as exc:
        raise MeasurementError(f"{path}: not a readable MATLAB .mat file ({exc})") from None
    columns: dict[str, np.ndarray] = {}
    for name, value in content.items():
        if not name.startswith("__"):
            _collect(name, value, columns, depth=0)
    if not columns:
        raise MeasurementError(f"{path}: no numeric vectors found in the .mat file")
    return columns


def _collect(name: str, value: Any, out: dict[str, np.ndarray], depth: int) -> None:
    """Add the numeric vectors inside ``value`` to ``out`` (structs flattened a few levels)."""
    if depth > 4:
        return
    if hasattr(value, "_fieldnames"):  # a MATLAB struct (mat_struct)
        fields = {f: getattr(value, f) for f in value._fieldnames}
        label = _struct_label(fields)
        data = _first(fields, ("Data", "data", "values", "Values"))
        if label is not None and data is not None:
            _collect(label, data, out, depth + 1)
            return
        for field, sub in fields.items():
            _collect(f"{name}.{field}", sub, out, depth + 1)
        return
    arr = np.asarray(value)
    if arr.dtype == object:  # struct array or cell array
        for i, item in enumerate(arr.ravel()):
            _collect(f"{name}({i + 1})", item, out, depth + 1)
        return
    if not np.issubdtype(arr.dtype, np.number) or np.iscomplexobj(arr):
        return
    arr = np.asarray(arr, dtype=float)
    if arr.ndim == 1 and arr.size > 1:
        out[name] = arr
    elif arr.ndim == 2:
        if arr.shape[0] < arr.shape[1]:
            arr = arr.T  # samples along the longer dimension
        for j in range(arr.shape[1]):
            out[f"{name}({j + 1})"] = arr[:, j]


def _struct_label(fields: Mapping[str, Any]) -> str | None:
    label = _first(fields, ("Name", "name", "label", "Label"))
    return label if isinstance(label, str) and label.strip() else None


def _first(fields: Mapping[str, Any], keys: tuple[str, ...]) -> Any:
    for key in keys:
        if key in fields:
            return fields[key]
    return None
