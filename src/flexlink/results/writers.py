"""Write one run into a results folder, atomically.

Everything goes into a hidden sibling folder first, which is renamed into place at the end:
a failed or interrupted run never leaves a half-written results folder behind.

Folder contents: ``results.csv`` (``t`` in s, then one column per channel, SI),
``channels.csv`` (name, unit, kind, quantity, subject, description of each column),
``results.nc`` (netCDF, `layout`), ``results.mat`` (MATLAB, the same content),
``scenario.resolved.toml`` (the scenario with every default filled in, and the flexlink
version), ``figures/*.png``, ``report.html`` (one self-contained page) and, when asked,
``animation.gif``. `reading.read_run` reads such a folder back.
"""

from __future__ import annotations

import csv
import shutil
import uuid
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..options import OptionError, check_writable
from ..scenario.toml_writer import dump_toml
from .figures import write_figures
from .folder import (
    ANIMATION_GIF,
    CHANNELS_CSV,
    REPORT_NAME,
    RESOLVED_NAME,
    RESULTS_CSV,
    RESULTS_MAT,
    RESULTS_NC,
    foreign_entries,
)
from .layout import run_layout
from .matlab import write_mat
from .netcdf import write_netcdf
from .results import Results

if TYPE_CHECKING:
    from .figure_worker import FigureWorker

CSV_FORMAT = "%.10g"
CHANNEL_COLUMNS = ("name", "unit", "kind", "quantity", "subject", "description")


class OutputFolderError(FileExistsError):
    """The output folder cannot be used (it holds other files, or is not a folder)."""


def check_output_dir(out_dir: Path, overwrite: bool = False) -> None:
    """Raise OutputFolderError unless ``out_dir`` can be created beside its siblings (its
    parent a writable folder) and is absent, empty, or (with ``overwrite``) an earlier flexlink
    results folder holding only files flexlink writes (`folder.foreign_entries`). Call it
    before a long simulation to fail early."""
    out_dir = Path(out_dir)
    try:
        check_writable(out_dir, "output folder")
    except OptionError as exc:
        raise OutputFolderError(str(exc)) from None
    if not out_dir.exists():
        return
    if not out_dir.is_dir():
        raise OutputFolderError(f"output path {out_dir} exists and is not a folder")
    if not any(out_dir.iterdir()):
        return
    if not overwrite:
        raise OutputFolderError(f"output folder {out_dir} already exists and is not empty; "
                                "choose another folder or overwrite it (--overwrite)")
    if not (out_dir / RESOLVED_NAME).is_file():
        raise OutputFolderError(f"refusing to overwrite {out_dir}: it does not look like a "
                                f"flexlink results folder (no {RESOLVED_NAME} in it)")
    foreign = foreign_entries(out_dir)
    if foreign:
        shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5
                                          else "")
        raise OutputFolderError(f"refusing to overwrite {out_dir}: it holds files flexlink "
                                f"did not write ({shown}); move them out of it or choose "
                                "another folder")


def write_run(
    results: Results,
    out_dir: Path,
    resolved: Mapping[str, Any],
    figures: bool = True,
    overwrite: bool = False,
    report: bool = True,
    animation: bool = False,
    figure_worker: FigureWorker | None = None,
) -> Path:
    """Write ``results`` and the ``resolved`` scenario dict into ``out_dir``; return it.
    ``report``: report.html (`report_html`); ``animation``: animation.gif (`animation`, a few
    seconds), shown in the report. ``figure_worker``: a `FigureWorker` that draws the figures
    in another process while this one writes the data files (the command line's); drawn here
    if it fails."""
    with atomic_folder(out_dir, overwrite) as partial:
        page = None
        try:
            if figures and figure_worker is not None:
                figure_worker.submit(results, partial / "figures")
            write_results_csv(results, partial / RESULTS_CSV)
            write_channels_csv(results, partial / CHANNELS_CSV)
            layout = run_layout(results)
            write_netcdf(layout, partial / RESULTS_NC)  # the folder is atomic already
            write_mat(layout, partial / RESULTS_MAT)
            text = resolved_toml(resolved)
            (partial / RESOLVED_NAME).write_text(text, encoding="utf-8")
            if report:  # its traces while the figures are drawn; the figures go in at the end
                from .report_html import run_page

                page = run_page(partial, results, text, name=Path(out_dir).name)
            if figures and (figure_worker is None or not figure_worker.wait()):
                if figure_worker is not None:  # it failed or died: start afresh
                    shutil.rmtree(partial / "figures", ignore_errors=True)
                write_figures(results, partial / "figures")
            if animation:
                from .animation import animate, page_speed

                animate(results, partial / ANIMATION_GIF, speed=page_speed(results.time))
            if page is not None:
                page.write(partial / REPORT_NAME)
        finally:
            if figure_worker is not None:
                # never remove the folder under a drawing child; a child that is done is
                # reaped only now, its ending overlapped with the report
                figure_worker.close()
    return Path(out_dir)


@contextmanager
def atomic_folder(out_dir: Path, overwrite: bool = False) -> Iterator[Path]:
    """Yield a hidden sibling folder of ``out_dir`` to write into; if the block succeeds it is
    renamed into place (replacing an earlier results folder), otherwise it is removed."""
    check_output_dir(Path(out_dir), overwrite)
    target = Path(out_dir).resolve()
    target.parent.mkdir(parents=True, exist_ok=True)
    partial = target.parent / f".{target.name}.partial-{uuid.uuid4().hex[:8]}"
    partial.mkdir()
    try:
        yield partial
        _move_into_place(partial, target)
    except BaseException:
        shutil.rmtree(partial, ignore_errors=True)
        raise


def _move_into_place(partial: Path, out_dir: Path) -> None:
    if out_dir.exists():  # empty, or an old run that check_output_dir allowed to replace
        old = out_dir.parent / f".{out_dir.name}.old-{uuid.uuid4().hex[:8]}"
        out_dir.rename(old)
        partial.rename(out_dir)
        shutil.rmtree(old, ignore_errors=True)
    else:
        partial.rename(out_dir)


CSV_ROWS_PER_CHUNK = 4096


def write_results_csv(results: Results, path: Path) -> None:
    """``t`` (s) then one column per channel (SI), comma separated, 10 significant digits.

    The text of ``np.savetxt(path, table, fmt=CSV_FORMAT, delimiter=",", header=…,
    comments="")``, byte for byte (a test), in a third less time: one ``%`` formatting per
    chunk of rows instead of one per row."""
    table = np.column_stack([results.time, *(results[n] for n in results.names)])
    line = ",".join([CSV_FORMAT] * table.shape[1]) + "\n"
    with open(path, "w", encoding="latin1") as fh:  # savetxt's encoding and newlines
        fh.write(",".join(["t", *results.names]) + "\n")
        for start in range(0, table.shape[0], CSV_ROWS_PER_CHUNK):
            chunk = table[start:start + CSV_ROWS_PER_CHUNK]
            fh.write((line * chunk.shape[0]) % tuple(chunk.ravel().tolist()))


def write_channels_csv(results: Results, path: Path) -> None:
    """One row per column of results.csv: name, unit (UDUNITS), kind, quantity, subject,
    description (the channel's record)."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(CHANNEL_COLUMNS)
        writer.writerow(["t", "s", "", "", "", "time"])
        for channel in results.channels.values():
            writer.writerow([channel.name, channel.unit, channel.kind.value, channel.quantity,
                             channel.subject, channel.description])


def resolved_toml(resolved: Mapping[str, Any]) -> str:
    """The resolved scenario as TOML, headed by a comment saying what it is."""
    version = resolved.get("flexlink_version", "unknown")
    head = (f"# Resolved scenario written by flexlink {version}: every default filled in,\n"
            "# bending stiffness as EI, CSV paths absolute. Run it again with\n"
            "#   flexlink run scenario.resolved.toml -o NEW_FOLDER\n\n")
    return head + dump_toml(resolved)
