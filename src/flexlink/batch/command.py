"""``flexlink sweep``: the command-line face of `flexlink.batch.sweep`.

Exit status as ``flexlink run``: 0 every case finished, 1 some case failed (the file holds the
others), 2 invalid input (nothing run, no file written), 130 interrupted (the file holds the
finished cases).
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..results.variables import Layout

EXAMPLE = ("flexlink sweep --paper --grid 'links[0].EI=250,300,350' "
           "--random 'joints[0].motion[0].duration=uniform:0.8:1.2' --samples 20 --seed 1 "
           "-o sweep.nc")


def add_parser(commands: Any) -> argparse.ArgumentParser:
    """The ``sweep`` sub-command of the ``flexlink`` parser."""
    sweep = commands.add_parser(
        "sweep", help="simulate many variants of a scenario (grid or random samples)",
        description="Run a grid and/or random samples over numeric scenario fields on all "
                    "cores (or a Dask cluster) and write one netCDF file: every channel over "
                    "(case, time), the parameter values as coordinates, a status per case. "
                    "Fields are paths into the scenario file: links[0].EI, links[link1].E, "
                    "joints[0].motion[0].duration, sensors[1].x (docs/sweep.md).",
        epilog=f"Example: {EXAMPLE}")
    sweep.add_argument("scenario", nargs="?", type=Path, metavar="SCENARIO.toml",
                       help="base scenario file")
    sweep.add_argument("--paper", action="store_true",
                       help="use the built-in paper experiment as the base scenario")
    sweep.add_argument("--spec", type=Path, metavar="SWEEP.toml",
                       help="a sweep file: base scenario, grid, random, samples, seed, "
                            "sampler, channels (instead of those options; docs/sweep.md)")
    sweep.add_argument("--grid", action="append", default=[], metavar="PATH=VALUES",
                       help="grid values: PATH=v1,v2,… or PATH=linspace:start:stop:count or "
                            "PATH=geomspace:start:stop:count (repeat for a cartesian product)")
    sweep.add_argument("--random", action="append", default=[], metavar="PATH=DIST",
                       help="random values: PATH=uniform:low:high, PATH=loguniform:low:high or "
                            "PATH=normal:mean:std (repeatable; needs --samples)")
    sweep.add_argument("--samples", type=int, metavar="N",
                       help="random draws (with a grid: the same N draws at every grid point)")
    sweep.add_argument("--seed", type=int, help="seed of the random draws (default: drawn "
                                                "and recorded in the file)")
    sweep.add_argument("--sampler", choices=("random", "lhs"),
                       help="independent draws (default: random) or a Latin hypercube")
    sweep.add_argument("--channels", metavar="NAME,…",
                       help="keep only these channels (default: all); saves memory")
    sweep.add_argument("--summary", action="append", default=[], metavar="METRIC:CHANNEL",
                       help="keep a per-case metric of a channel (repeatable): peak, rms, max, "
                            "min, mean, final, residual (…:after=T s), settling (…:band=B), "
                            "e.g. residual:link2_tip_deflection:after=3 (docs/sweep.md)")
    sweep.add_argument("--no-histories", action="store_true",
                       help="keep only the --summary metrics, not the channels over time: "
                            "large studies in little memory and disk")
    sweep.add_argument("-o", "--output", type=Path, metavar="FILE.nc",
                       help="netCDF file to write (default: <scenario name>_sweep.nc)")
    sweep.add_argument("--overwrite", action="store_true", help="replace an existing FILE.nc")
    sweep.add_argument("--workers", type=int, metavar="N",
                       help="local worker processes (default: every core)")
    sweep.add_argument("--scheduler", metavar="ADDRESS",
                       help="run on a Dask cluster, e.g. tcp://10.0.0.5:8786 "
                            "(needs pip install 'flexlink[cluster]')")
    sweep.add_argument("--skip-invalid", action="store_true",
                       help="run the valid cases and record the invalid ones (with their "
                            "problems) as failed cases; default: refuse the whole sweep")
    sweep.add_argument("-q", "--quiet", action="store_true",
                       help="no progress bar and no summary; print only the file name")
    # paused_start_up: the collector stays paused through the imports (_start_up_imports)
    sweep.set_defaults(handler=run_command, subparser=sweep, paused_start_up=True)
    return sweep


def run_command(args: argparse.Namespace) -> int:
    """Handle ``flexlink sweep``; returns the exit status."""
    _start_up_imports(args)
    from ..scenario import ScenarioError
    from .errors import SweepError, SweepInterrupted
    from .run import run_sweep

    definition_options = [args.scenario, args.paper or None, args.grid or None,
                          args.random or None, args.samples, args.seed, args.sampler,
                          args.channels, args.summary or None, args.no_histories or None]
    if args.spec is not None and any(o is not None for o in definition_options):
        args.subparser.error("--spec defines the sweep: give no scenario, --paper, --grid, "
                             "--random, --samples, --seed, --sampler, --channels, --summary "
                             "or --no-histories with it")
    if args.spec is None and args.paper == (args.scenario is not None):
        args.subparser.error("give a scenario file or --paper (exactly one), or --spec")
    try:
        definition = _definition(args)
        with _spec_errors(args.spec):  # the base scenario may be missing
            output = args.output or Path(f"{_base_name(definition['base'])}_sweep.nc")
        _check_output(output, args.overwrite)
        started = time.perf_counter()
        with _spec_errors(args.spec):
            layout = run_sweep(**definition, output=output, workers=args.workers,
                               scheduler=args.scheduler, progress=not args.quiet,
                               skip_invalid=args.skip_invalid)
    except (ScenarioError, SweepError) as exc:
        return _fail(str(exc))
    except SweepInterrupted as exc:
        counts = {s: int((exc.dataset.status == s).sum()) for s in ("ok", "failed")}
        print(f"flexlink: interrupted; wrote {output} with {counts['ok']} finished and "
              f"{counts['failed']} failed cases", file=sys.stderr)
        return 130
    except MemoryError:
        return _fail(f"error: out of memory collecting the cases for {output} (memory, not "
                     "the disk): keep fewer channels (--channels), run fewer cases or a "
                     "coarser dt_out")
    except OSError as exc:
        return _fail(f"error: could not write {output}: {exc}")
    print(output if args.quiet else summary(layout, output, time.perf_counter() - started))
    return 1 if layout.attrs["cases_failed"] else 0


def _start_up_imports(args: argparse.Namespace) -> None:
    """Import the sweep's code (numpy, scipy, numba) within the block `cli.main` gives
    (``args.start_up``: optional modules of numba and scipy withheld), with the start-up
    measures of a command's own process (`flexlink._light_start`: numba loads the cached
    kernels without its typing registries, numpy's unused submodules stay lazy), which the
    forked workers inherit; then resume the garbage collector, as `flexlink fit` does
    (ARCHITECTURE.md, "Start-up of `flexlink run`"). Without ``start_up`` (a caller of the
    handler itself): nothing, the command imports as it goes."""
    if not hasattr(args, "start_up"):
        return
    block, imports_done = args.start_up
    with block:
        if getattr(args, "own_process", False):
            from .._light_start import start_command_process

            start_command_process()
        try:
            import numba  # noqa: F401 — the workers' kernels load in this process

            from . import run  # noqa: F401 — the simulation's modules and scipy
        except ImportError:
            pass  # a library needs a withheld module after all: imported again on use
    imports_done()


def _definition(args: argparse.Namespace) -> dict[str, Any]:
    """The sweep's definition (`sweep` keyword arguments) from a sweep file or the options."""
    from ..scenario import paper_experiment_path
    from .parameters import parse_grid_option, parse_random_option
    from .spec import read_sweep_file

    if args.spec is not None:
        return read_sweep_file(args.spec)
    channels = None if args.channels is None else [
        c.strip() for c in args.channels.split(",") if c.strip()]
    return {"base": paper_experiment_path() if args.paper else args.scenario,
            "grid": _collect(parse_grid_option, args.grid),
            "random": _collect(parse_random_option, args.random),
            "samples": args.samples, "seed": args.seed,
            "sampler": args.sampler or "random", "channels": channels,
            "summaries": args.summary, "histories": not args.no_histories}


def _spec_errors(spec: Path | None) -> contextlib.AbstractContextManager[None]:
    """Problems of a sweep defined by a sweep file name that file."""
    from .spec import sweep_file_errors

    return contextlib.nullcontext() if spec is None else sweep_file_errors(spec)


def _collect(parse: Any, options: list[str]) -> list[Any]:
    from .errors import SweepError

    parsed, problems = [], []
    for option in options:
        try:
            parsed.append(parse(option))
        except SweepError as exc:
            problems += exc.problems
    if problems:
        raise SweepError(problems)
    return parsed


def _base_name(path: Path) -> str:
    """The scenario's simulation.name (the file name if it has none), for the default output."""
    from ..scenario.load import read_toml

    simulation = read_toml(path).get("simulation")
    name = simulation.get("name") if isinstance(simulation, dict) else None
    return name if isinstance(name, str) and name.strip() else path.stem


def _check_output(path: Path, overwrite: bool) -> None:
    from .errors import SweepError

    if path.is_dir():
        raise SweepError([f"output {path} is a folder; give a file name such as sweep.nc"])
    if path.exists() and not overwrite:
        raise SweepError([(f"output file {path} already exists; choose another name or "
                           "replace it (--overwrite)")])
    from ..options import OptionError, check_writable

    try:  # before any case runs: under a file, in a folder that cannot be written
        check_writable(path)
    except OptionError as exc:
        raise SweepError([str(exc)]) from None


def _fail(message: str, status: int = 2) -> int:
    print(message, file=sys.stderr)
    return status


def summary(layout: Layout, output: Path, wall: float, max_errors: int = 5) -> str:
    """What ran, how many cases finished or failed (with the first errors), the range of each
    summary metric, where it went; from the sweep's `Layout` (its file's content)."""
    import numpy as np

    attrs, data = layout.attrs, layout.data
    status = np.asarray(data["status"].values).astype(str)
    count = status.size
    ok, failed = int(attrs["cases_ok"]), int(attrs["cases_failed"])
    lines = [(f"flexlink: swept {attrs['title'].removeprefix('flexlink sweep of ')!r}, "
              f"{count} cases in {wall:.3g} s: {ok} ok, {failed} failed")]
    running = float(attrs.get("running_time_s", 0.0))
    if running > 0:  # the progress bar's rate; the rest is start-up, checks and writing
        lines.append(f"  {count / running:.3g} cases/s while the cases ran ({running:.3g} s); "
                     f"{max(wall - running, 0.0):.2g} s to check the cases, start the workers "
                     "and write")
    parameters = [name for name, v in layout.coords.items() if v.dims == ("case",)
                  and name != "case"]
    ok_cases = status == "ok"
    for name, variable in data.items():
        if "metric" in variable.attrs and ok_cases.any():
            values = np.asarray(variable.values)[ok_cases]
            unset = int(np.isnan(values).sum())  # a settling time not reached in the run
            why = "not settled by t_end" if variable.attrs["metric"] == "settling" else "no value"
            note = f" ({unset} ok cases NaN: {why})" if unset else ""
            if unset == values.size:
                lines.append(f"  {name}: NaN in every ok case: {why}")
                continue
            lines.append(f"  {name}: min {np.nanmin(values):.4g}, median "
                         f"{np.nanmedian(values):.4g}, max {np.nanmax(values):.4g} "
                         f"{variable.attrs.get('units', '')}{note}")
    errors = np.asarray(data["error"].values).astype(str)
    for index in np.flatnonzero(status == "failed")[:max_errors].tolist():
        values = ", ".join(f"{p} = {layout.coords[p].values[index]:g}" for p in parameters)
        lines.append(f"  case {index} ({values}): {errors[index]}")
    if failed > max_errors:
        lines.append(f"  … {failed - max_errors} more failed cases (variable 'error' of the "
                     "file)")
    lines.append(f"wrote {output}")
    return "\n".join(lines)
