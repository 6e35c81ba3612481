"""Read a run folder (written by `writers.write_run`) back into `Results`."""

from __future__ import annotations

import csv
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ..channels import Channel, ChannelKind
from .folder import CHANNELS_CSV, RESULTS_CSV, RESULTS_NC
from .layout import channel_of, metadata_of
from .netcdf import read_netcdf
from .results import Results
from .shapes import shapes_of
from .variables import Layout


class NotARunFolderError(FileNotFoundError):
    """The folder is missing, or holds neither results.nc nor results.csv with channels.csv."""


class DamagedRunFileError(ValueError):
    """A file of a run folder cannot be read back (damaged, truncated, edited): the message
    names the file and what is wrong with it."""


def read_run(folder: str | Path, shapes: bool = True) -> Results:
    """The `Results` of a flexlink run folder: from results.nc (channels, kinds, metadata),
    else from results.csv and channels.csv (no metadata). ``shapes``: also the links' shapes
    (what animations draw; nothing else needs them). NotARunFolderError names the folder and
    the missing files, DamagedRunFileError the file that cannot be read."""
    folder = Path(folder)
    if not folder.is_dir():
        raise NotARunFolderError(f"{folder} is not a flexlink run folder: no such folder")
    path = folder / RESULTS_NC
    if path.is_file():
        with _reading(path):
            layout = read_netcdf(path)
        with _reading(path):
            return results_of(layout, shapes=shapes)
    missing = [n for n in (RESULTS_CSV, CHANNELS_CSV) if not (folder / n).is_file()]
    if missing:
        raise NotARunFolderError(
            f"{folder} is not a flexlink run folder: it has no {RESULTS_NC} and no "
            f"{' and no '.join(missing)} (flexlink run writes them)")
    return read_csv_run(folder / RESULTS_CSV, folder / CHANNELS_CSV)


@contextmanager
def _reading(path: Path) -> Iterator[None]:
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
    not a sweep file (no case coordinate or status) or its time is damaged."""
    with _reading(path):
        layout = read_netcdf(path)
    if "case" not in layout.coords or "status" not in layout.data:
        raise DamagedRunFileError(f"{path} is not a flexlink sweep file (no case coordinate)")
    with _reading(path):
        _check_time(layout)
    return layout


def _check_time(layout: Layout) -> np.ndarray:
    """The layout's time (s); DamagedRunFileError if missing, not finite or not increasing."""
    if "time" not in layout.coords:
        raise DamagedRunFileError("no time coordinate")
    time = np.asarray(layout.coords["time"].values, dtype=float)
    if time.ndim != 1 or not np.all(np.isfinite(time)) or np.any(np.diff(time) <= 0):
        raise DamagedRunFileError("its time is not a finite, increasing sequence")
    return time


def results_of(layout: Layout, shapes: bool = True) -> Results:
    """The `Results` a run's layout holds (inverse of `layout.run_layout`): every variable over
    ``time`` with a channel's ``kind`` is a channel; the shape variables are its ``shapes``
    (left out without ``shapes``). DamagedRunFileError if the time is missing, not finite or
    not increasing, or the shapes are incomplete."""
    time = _check_time(layout)
    results = Results(time=time, metadata=metadata_of(layout.attrs),
                      created=str(layout.attrs.get("date_created", "")),
                      shapes=shapes_of(layout) if shapes else [])
    kinds = {k.value for k in ChannelKind}
    for name, variable in layout.data.items():
        if variable.dims == ("time",) and variable.attrs.get("kind") in kinds:
            results.add(channel_of(name, variable.attrs), variable.values)
    return results


def read_csv_run(results_csv: Path, channels_csv: Path) -> Results:
    """`Results` from results.csv (``t``, then one column per channel) and channels.csv."""
    with _reading(channels_csv):
        channels = _read_channels(channels_csv)
    with _reading(results_csv):
        with results_csv.open(encoding="utf-8") as fh:
            header = fh.readline().strip().split(",")
        table = np.loadtxt(results_csv, delimiter=",", skiprows=1, ndmin=2)
    if header[:1] != ["t"] or len(header) != table.shape[1]:
        raise ValueError(f"{results_csv}: expected a header 't,<channel>,…' over every column")
    unknown = [n for n in header[1:] if n not in channels]
    if unknown:
        raise ValueError(f"{channels_csv} does not describe column(s) {', '.join(unknown)} "
                         f"of {results_csv}")
    time = table[:, 0]
    if not np.all(np.isfinite(time)) or np.any(np.diff(time) <= 0):
        raise DamagedRunFileError(f"{results_csv}: column t is not a finite, increasing "
                                  "sequence")
    results = Results(time=time)
    for k, name in enumerate(header[1:], start=1):
        results.add(channels[name], table[:, k])
    return results


def _read_channels(path: Path) -> dict[str, Channel]:
    with path.open(newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    if rows and "kind" not in rows[0]:
        raise ValueError(f"{path} has no 'kind' column (an older flexlink wrote it); "
                         "read results.nc instead")
    return {r["name"]: Channel(r["name"], ChannelKind(r["kind"]), r["unit"], r["description"],
                               r.get("quantity") or "", r.get("subject") or "")
            for r in rows if r["name"] != "t"}
