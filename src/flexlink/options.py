"""Checks of the commands' options and output paths, shared by every command: one helper per
kind of check, each raising `OptionError` (or argparse's own error, exit status 2) with a
message that names the option or file, the value and what is allowed.

* argparse types (`finite_float`, `positive_float`, `nonnegative_finite_float`,
  `positive_int`, `nonnegative_int`): a value of the wrong kind or range is a usage error
  naming the option;
* `check_size`: a request whose arrays or work would be out of proportion (a grid of 10⁸
  points, 10⁹ animation frames) is refused before anything runs, with the size it would need
  and the limit;
* `check_unique`: the same name given twice;
* `check_writable`, `check_output_file`: an output path under a regular file, or in a folder
  that cannot be written (or a folder where a file is to be written), is refused before any
  work;
* `check_finite`: no result with NaN or infinity is written; `json_text`: JSON files hold
  null there (JSON has neither, and strict readers refuse Python's NaN).
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from .errors import SimulationError


class OptionError(ValueError):
    """An invalid option or output path; the message names it (exit status 2)."""


class NonFiniteResult(SimulationError):
    """A result holds NaN or infinity (the model diverged): nothing is written (exit 1)."""


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None


def finite_float(text: str) -> float:
    """argparse type: a finite number."""
    value = _number(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, got {text!r}")
    return value


def positive_float(text: str) -> float:
    """argparse type: a finite number > 0."""
    value = finite_float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text!r}")
    return value


def nonnegative_finite_float(text: str) -> float:
    """argparse type: a finite number >= 0."""
    value = finite_float(text)
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, got {text!r}")
    return value


def _integer(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    value = _integer(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be an integer >= 1, got {text!r}")
    return value


def nonnegative_int(text: str) -> int:
    """argparse type: an integer >= 0."""
    value = _integer(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0, got {text!r}")
    return value


def check_size(field: str, count: float, limit: float, noun: str, fix: str = "") -> None:
    """OptionError if ``count`` ``noun`` (what ``field`` asks for) exceed ``limit``; ``fix``
    says what fits."""
    if not count <= limit:  # also NaN
        raise OptionError(f"{field}: {_count(count)} {noun}, more than the {_count(limit)} "
                          f"allowed{'; ' + fix if fix else ''}")


def _count(value: float) -> str:
    return f"{value:,.0f}" if value < 1e7 else f"{value:.3g}"


def check_unique(field: str, values: Iterable[Any]) -> None:
    """OptionError naming the first value of ``values`` given more than once."""
    seen: set[Any] = set()
    for value in values:
        if value in seen:
            raise OptionError(f"{field}: {value!r} is given twice")
        seen.add(value)


def check_writable(path: str | Path, what: str = "output") -> None:
    """OptionError unless ``path`` can be created: its nearest existing ancestor must be a
    folder in which this process can create entries (tried, so that a read-only file system
    or a folder closed even to root counts)."""
    path = Path(path)
    parent = path.absolute().parent
    while not parent.exists():
        if parent.is_symlink():  # a dangling link
            raise OptionError(f"{what} {path}: {parent} is a broken link")
        parent = parent.parent
    if not parent.is_dir():
        raise OptionError(f"{what} {path}: {parent} is a file, not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise OptionError(f"{what} {path}: cannot write in {parent} (no permission); "
                          "choose another place")
    try:
        probe = tempfile.mkdtemp(prefix=".flexlink-probe-", dir=parent)
    except OSError as exc:
        raise OptionError(f"{what} {path}: cannot write in {parent} "
                          f"({exc.strerror or exc}); choose another place") from None
    os.rmdir(probe)


def check_output_file(path: str | Path, what: str = "output") -> None:
    """OptionError unless the file ``path`` can be written: `check_writable`, and not an
    existing folder."""
    if Path(path).is_dir():
        raise OptionError(f"{what} {path} is a folder; give a file name")
    check_writable(path, what)


def json_safe(value: Any) -> Any:
    """``value`` (mappings, sequences, numbers) with NaN and ±inf as None and numpy scalars
    and arrays as Python numbers and lists."""
    import numpy as np

    if isinstance(value, Mapping):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, list | tuple):
        return [json_safe(v) for v in value]
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer | np.bool_):
        return value.item()
    return value


def json_text(value: Any) -> str:
    """``value`` as indented JSON text (`json_safe`: null for NaN and ±inf), ending with a
    newline."""
    import json

    return json.dumps(json_safe(value), indent=2, allow_nan=False) + "\n"


def check_finite(values: Mapping[str, Any], what: str) -> None:
    """`NonFiniteResult` naming the first entry of ``values`` (name → array or number) that
    holds NaN or infinity, so that nothing non-finite is written; ``what``: the result."""
    import numpy as np

    for name, value in values.items():
        array = np.asarray(value)
        if array.dtype.kind in "fc" and not np.all(np.isfinite(array)):
            raise NonFiniteResult(f"{what}: {name} is not finite (NaN or infinity); the model "
                                  "diverged there, so nothing was written")
