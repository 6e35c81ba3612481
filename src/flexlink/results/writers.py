"""Write one run into a results folder, atomically.

Everything goes into a hidden sibling folder first, which is renamed into place at the end:
a failed or interrupted run never leaves a half-written results folder behind.

Folder contents: ``results.csv`` (``t`` in s, then one column per channel, SI),
``channels.csv`` (name, unit, description of each column), ``results.nc`` (netCDF with units
in the attributes), ``scenario.resolved.toml`` (the scenario with every default filled in, and
the flexlink version) and ``figures/*.png``.
"""

from __future__ import annotations

import csv
import shutil
import uuid
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from ..scenario.toml_writer import dump_toml
from .results import Results

RESOLVED_NAME = "scenario.resolved.toml"
CSV_FORMAT = "%.10g"


class OutputFolderError(FileExistsError):
    """The output folder cannot be used (it holds other files, or is not a folder)."""


def check_output_dir(out_dir: Path, overwrite: bool = False) -> None:
    """Raise OutputFolderError unless ``out_dir`` is absent, empty, or (with ``overwrite``)
    an earlier flexlink results folder. Call it before a long simulation to fail early."""
    out_dir = Path(out_dir)
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


def write_run(
    results: Results,
    out_dir: Path,
    resolved: Mapping[str, Any],
    figures: bool = True,
    overwrite: bool = False,
) -> Path:
    """Write ``results`` and the ``resolved`` scenario dict into ``out_dir``; return it."""
    with atomic_folder(out_dir, overwrite) as partial:
        write_results_csv(results, partial / "results.csv")
        write_channels_csv(results, partial / "channels.csv")
        write_netcdf(results, partial / "results.nc")
        (partial / RESOLVED_NAME).write_text(resolved_toml(resolved), encoding="utf-8")
        if figures:
            sensors = [s["name"] for s in resolved.get("sensors", [])]
            write_figures(results, partial / "figures", sensors)
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


def write_results_csv(results: Results, path: Path) -> None:
    """``t`` (s) then one column per channel (SI), comma separated, 10 significant digits."""
    table = np.column_stack([results.time, *(results[n] for n in results.names)])
    header = ",".join(["t", *results.names])
    np.savetxt(path, table, fmt=CSV_FORMAT, delimiter=",", header=header, comments="")


def write_channels_csv(results: Results, path: Path) -> None:
    """One row per column of results.csv: name, unit, description."""
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh)
        writer.writerow(["name", "unit", "description"])
        writer.writerow(["t", "s", "time"])
        for name, channel in results.channels.items():
            writer.writerow([name, channel.unit, channel.description])


def write_netcdf(results: Results, path: Path) -> None:
    """netCDF-3 (classic) written by scipy, laid out as ``Results.to_xarray()``: one variable per
    channel over ``time`` with ``units`` and ``long_name``, the metadata as global attributes.
    Writing it directly keeps xarray's import out of a command-line run."""
    from scipy.io import netcdf_file

    with netcdf_file(path, "w", version=2) as nc:
        for key, value in results.metadata.items():
            setattr(nc, key, str(value))
        nc.createDimension("time", results.time.size)
        _netcdf_variable(nc, "time", results.time, "s", "")
        for name, channel in results.channels.items():
            _netcdf_variable(nc, name, results[name], channel.unit, channel.description)
            nc.variables[name].kind = channel.kind.value


def _netcdf_variable(nc: Any, name: str, values: np.ndarray, unit: str, long_name: str) -> None:
    var = nc.createVariable(name, "d", ("time",))
    var[:] = values
    var.units = unit
    if long_name:
        var.long_name = long_name


def write_figures(results: Results, folder: Path, sensors: Sequence[str]) -> list[Path]:
    """joint_angles.png, sensors.png (if any sensor) and tip_paths.png; return their paths."""
    from . import plotting

    folder.mkdir(exist_ok=True)
    figures = {}
    if plotting.joint_channels(results):
        figures["joint_angles"] = plotting.plot_joint_angles(results)
    present = [s for s in sensors if s in results]
    if present:
        figures["sensors"] = plotting.plot_sensors(results, present)
    if plotting.tip_links(results):
        figures["tip_paths"] = plotting.plot_tip_paths(results)
    paths = []
    for stem, fig in figures.items():
        paths.append(folder / f"{stem}.png")
        fig.savefig(paths[-1], dpi=plotting.DPI)
    return paths


def resolved_toml(resolved: Mapping[str, Any]) -> str:
    """The resolved scenario as TOML, headed by a comment saying what it is."""
    version = resolved.get("flexlink_version", "unknown")
    head = (f"# Resolved scenario written by flexlink {version}: every default filled in,\n"
            "# bending stiffness as EI, CSV paths absolute. Run it again with\n"
            "#   flexlink run scenario.resolved.toml -o NEW_FOLDER\n\n")
    return head + dump_toml(resolved)
