"""Reading a run's or a sweep's files defensively: a damaged file (random bytes, truncated,
edited) is a `DamagedRunFileError` naming it, never the parser's own exception."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .netcdf import read_netcdf
from .variables import Layout


class DamagedRunFileError(ValueError):
    """A file of a run folder cannot be read back (damaged, truncated, edited): the message
    names the file and what is wrong with it."""


@contextmanager
def reading_file(path: Path) -> Iterator[None]:
    """Any failure to parse ``path`` as a DamagedRunFileError naming it: a damaged file
    fails in the parser in ways as many as its bytes (scipy's reader raises TypeError,
    ValueError, KeyError, IndexError, struct.error, MemoryError, …)."""
    try:
        yield
    except DamagedRunFileError as exc:
        if str(path) in str(exc):
            raise
        raise DamagedRunFileError(f"{path}: {exc}") from None
    except OSError as exc:
        raise DamagedRunFileError(f"cannot read {path}: {exc.strerror or exc}") from None
    except Exception as exc:  # noqa: BLE001 — see the docstring
        detail = f"{type(exc).__name__}: {exc}"[:200]
        raise DamagedRunFileError(
            f"{path} is damaged or not written by flexlink ({detail}); write it again "
            "(flexlink run, flexlink sweep)") from None


def read_sweep_layout(path: Path) -> Layout:
    """The layout of a sweep file; DamagedRunFileError naming it if it cannot be parsed, is
    not a sweep file (no case coordinate or status) or its time is damaged (a sweep that kept
    only summary metrics has no time)."""
    with reading_file(path):
        layout = read_netcdf(path)
    if "case" not in layout.coords or "status" not in layout.data:
        raise DamagedRunFileError(f"{path} is not a flexlink sweep file (no case coordinate)")
    if "time" in layout.coords:
        with reading_file(path):
            checked_time(layout)
    return layout


def checked_time(layout: Layout) -> np.ndarray:
    """The layout's time (s); DamagedRunFileError if missing, not finite or not increasing."""
    if "time" not in layout.coords:
        raise DamagedRunFileError("no time coordinate")
    time = np.asarray(layout.coords["time"].values, dtype=float)
    if time.ndim != 1 or not np.all(np.isfinite(time)) or np.any(np.diff(time) <= 0):
        raise DamagedRunFileError("its time is not a finite, increasing sequence")
    return time
