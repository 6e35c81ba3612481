"""Read a run folder (written by `writers.write_run`) back into `Results`."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

from ..channels import Channel, ChannelKind
from .file_checks import DamagedRunFileError, checked_time, reading_file
from .folder import CHANNELS_CSV, RESULTS_CSV, RESULTS_NC
from .layout import channel_of, metadata_of
from .netcdf import read_netcdf
from .results import Results
from .shapes import shapes_of
from .variables import Layout


class NotARunFolderError(FileNotFoundError):
    """The folder is missing, or holds neither results.nc nor results.csv with channels.csv."""


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
        with reading_file(path):
            layout = read_netcdf(path)
        with reading_file(path):
            return results_of(layout, shapes=shapes)
    missing = [n for n in (RESULTS_CSV, CHANNELS_CSV) if not (folder / n).is_file()]
    if missing:
        raise NotARunFolderError(
            f"{folder} is not a flexlink run folder: it has no {RESULTS_NC} and no "
            f"{' and no '.join(missing)} (flexlink run writes them)")
    return read_csv_run(folder / RESULTS_CSV, folder / CHANNELS_CSV)


def results_of(layout: Layout, shapes: bool = True) -> Results:
    """The `Results` a run's layout holds (inverse of `layout.run_layout`): every variable over
    ``time`` with a channel's ``kind`` is a channel; the shape variables are its ``shapes``
    (left out without ``shapes``). DamagedRunFileError if the time is missing, not finite or
    not increasing, or the shapes are incomplete."""
    time = checked_time(layout)
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
    with reading_file(channels_csv):
        channels = _read_channels(channels_csv)
    with reading_file(results_csv):
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
