"""``flexlink compare`` and ``flexlink fit``: argument definitions and handlers (cli.py only
registers them). Exit status as for ``run``: 0 success, 1 the simulation failed, 2 invalid
input (scenario, measurement file, mapping, options, output folder)."""

from __future__ import annotations

import argparse
import contextlib
import math
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..options import check_unique, finite_float
from .files import MeasurementError


def add_commands(commands: Any, output: argparse.ArgumentParser) -> None:
    """Register ``compare`` and ``fit`` on the subparsers ``commands`` (with the shared
    output options ``output``)."""
    data = argparse.ArgumentParser(add_help=False)
    data.add_argument("scenario", type=Path, metavar="SCENARIO.toml",
                      help="scenario file; its [measurement] section maps the file's columns")
    data.add_argument("measured", type=Path, nargs="?", metavar="MEASURED.csv|.mat",
                      help="measurement file (default: [measurement] file)")
    data.add_argument("--map", action="append", default=[], metavar="COL=TARGET[,KEY=V]",
                      help="map a column to joint<k> or a sensor, e.g. "
                           "beta1=joint1,unit=deg or pzt_v=pzt,lowpass_hz=100 (repeatable; "
                           "replaces the [measurement] columns)")
    data.add_argument("--time-column", metavar="NAME", help="time column (default t)")
    data.add_argument("--time-offset", type=finite_float, metavar="S",
                      help="seconds added to the file's times (simulation starts at 0)")
    data.add_argument("--free-from", type=finite_float, metavar="S",
                      help="start of the free vibration (default: detected from the angles)")
    data.add_argument("--no-hold", action="store_true",
                      help="drive the joints with the measured angles also after the "
                           "manoeuvre (default: held at their final values)")
    compare = commands.add_parser(
        "compare", parents=[output, data], help="compare a scenario with measured data",
        description="Drive SCENARIO with the measured joint angles and compare its sensors "
                    "with the measured ones: overlays, metrics, report (docs/experiment.md).")
    # paused_start_up: the collector stays paused through the imports (_start_up_imports)
    compare.set_defaults(handler=run_compare, paused_start_up=True)
    fit = commands.add_parser(
        "fit", parents=[output, data], help="identify parameters from measured data",
        description="Estimate scenario parameters (links[0].EI, links[1].damping_ratio, "
                    "pzt:gain, …) from measured signals by least squares "
                    "(docs/experiment.md).")
    fit.add_argument("-p", "--param", action="append", default=[], metavar="PATH[=LO:HI[:X0]]",
                     help="parameter to fit (repeatable; replaces [fit] parameters)")
    fit.add_argument("--channel", action="append", default=[], metavar="NAME",
                     help="measured channel to fit (default: all mapped sensors)")
    fit.add_argument("--window", metavar="START:END",
                     help="fit window in s (default: the free vibration to the end)")
    fit.add_argument("--max-simulations", type=int, metavar="N",
                     help="budget of simulations (default 60)")
    fit.add_argument("--objective", choices=("modal", "time"),
                     help="match free-vibration frequencies and damping (modal, default) or "
                          "the time histories (time)")
    fit.set_defaults(handler=run_fit, paused_start_up=True)


def _fail(message: str, status: int = 2) -> int:
    print(message, file=sys.stderr)
    return status


def _start_figures(args: argparse.Namespace) -> Any:
    """A forked worker drawing the figures while this process loads, fits and writes
    (`figure_worker`), or None: no figures, or no fork. Forked before the heavy imports:
    the child needs only matplotlib."""
    if args.no_figures:
        return None
    from .figure_worker import FigureWorker
    from .figures import FigureData  # noqa: F401 — numpy and the plotting helpers, shared

    return FigureWorker.start()


def _start_up_imports(args: argparse.Namespace, fitting: bool = False) -> None:
    """Import what loading, comparing and (``fitting``) fitting use within the block
    `cli.main` gives (``args.start_up``: `cli.withheld_imports` of optional modules of numba and scipy that
    they never use), then resume the garbage collector it paused, as `flexlink run` does
    (ARCHITECTURE.md, "Start-up of `flexlink run`"); without ``start_up`` (a caller of the
    handler itself) just the imports."""
    block, imports_done = getattr(args, "start_up", (contextlib.nullcontext(), None))
    preload = None
    with block:
        if getattr(args, "own_process", False):  # the command's own process (`cli.main`)
            from .._light_start import start_command_process

            start_command_process()
        try:
            # the measured angles drive a Lawson run: its compiled loop loads meanwhile
            from ..solvers.lawson import preload_compiled_loop

            preload = preload_compiled_loop()
            import scipy.interpolate
            import scipy.optimize  # noqa: F401

            from . import identification, loading, report  # noqa: F401

            if fitting:  # its first runs, the first computing the sensitivities
                from ..simulation import prescribed, sensitivities  # noqa: F401
                from ..solvers import _lawson_sensitivity_numba, lawson_sensitivity  # noqa: F401
        except ImportError:
            pass  # a library needs a withheld module after all: imported again on use
        finally:
            if preload is not None:
                preload.join()  # compiled code must not run while it loads
        if getattr(args, "own_process", False):  # the figures wait for the fit: a free core
            from ..dynamics.prescribed_kernel import split_state_rows

            split_state_rows()
    if imports_done is not None:
        imports_done()


def _run(args: argparse.Namespace, work: Any) -> int:
    """Common error handling: input problems → 2, failed simulation → 1; warnings printed."""
    from ..errors import SimulationError
    from ..results.writers import OutputFolderError, check_output_dir
    from ..scenario import ScenarioError

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            out_dir = args.output or Path(f"{args.scenario.stem}_{args.command}")
            check_output_dir(out_dir, args.overwrite)
            status = work(out_dir)
        except ScenarioError as exc:
            status = _fail(str(exc))
        except (MeasurementError, OutputFolderError) as exc:
            status = _fail(f"error: {exc}")
        except (SimulationError, FloatingPointError) as exc:
            status = _fail(f"simulation failed: {exc}", status=1)
        except (ValueError, OSError) as exc:
            status = _fail(f"error: {exc}")
    for w in caught:
        if not issubclass(w.category, DeprecationWarning):
            print(f"warning: {w.message}", file=sys.stderr)
    return status


def _with_figure_worker(command: Callable[[argparse.Namespace, Any], int],
                        args: argparse.Namespace) -> int:
    """``command(args, worker)`` with the figure worker started before it and closed after."""
    worker = _start_figures(args)
    try:
        return command(args, worker)
    finally:
        if worker is not None:
            worker.close()
        if getattr(args, "own_process", False):  # its second thread (`_start_up_imports`)
            from ..dynamics.prescribed_kernel import end_split_state_rows

            end_split_state_rows()


def run_compare(args: argparse.Namespace) -> int:
    return _with_figure_worker(_compare_command, args)


def _compare_command(args: argparse.Namespace, worker: Any) -> int:
    _start_up_imports(args)
    from .comparison import compare
    from .report import metrics_table, write_comparison

    def work(out_dir: Path) -> int:
        experiment = _load(args)
        scenario, resolved, measurement = (experiment.scenario, experiment.resolved,
                                           experiment.measurement)
        comparison = compare(scenario, measurement, progress=not args.quiet)
        write_comparison(comparison, out_dir, resolved, overwrite=args.overwrite,
                         figures=not args.no_figures, figure_worker=worker)
        print(out_dir if args.quiet else f"{metrics_table(comparison.metrics)}\nwrote {out_dir}")
        return 0

    return _run(args, work)


def run_fit(args: argparse.Namespace) -> int:
    return _with_figure_worker(_fit_command, args)


def _fit_command(args: argparse.Namespace, worker: Any) -> int:
    _start_up_imports(args, fitting=True)
    from .identification import fit
    from .parameters import (
        check_distinct,
        model_values,
        parse_parameter_option,
        parse_parameter_table,
    )
    from .report import metrics_table, write_fit

    def work(out_dir: Path) -> int:
        experiment = _load(args)
        file, measurement, table = (experiment.file, experiment.measurement,
                                    experiment.fit_table)
        allowed = ("parameters", "channels", "window", "max_simulations", "objective")
        unknown = set(table) - set(allowed)
        if unknown:
            raise MeasurementError(f"[fit]: unknown key(s) {', '.join(sorted(unknown))} "
                                   f"(allowed: {', '.join(allowed)})")
        objective = args.objective or table.get("objective", "modal")
        channel_list = args.channel or table.get("channels")
        if channel_list is not None and (not isinstance(channel_list, list) or not all(
                isinstance(c, str) for c in channel_list)):
            raise MeasurementError(f"[fit] channels: expected an array of channel names, got "
                                   f"{channel_list!r}")
        check_unique("--channel" if args.channel else "[fit] channels", channel_list or [])
        channels = measurement.units
        if args.param:
            params = [parse_parameter_option(p, file, channels) for p in args.param]
        else:
            entries = table.get("parameters", [])
            if not isinstance(entries, list):
                raise MeasurementError("[fit] parameters: expected an array of tables")
            params = [parse_parameter_table(e, f"fit.parameters[{i}]", file, channels)
                      for i, e in enumerate(entries)]
        check_unique("--param" if args.param else "[fit] parameters",
                     [p.path for p in params])
        check_distinct(params, "--param" if args.param else "[fit] parameters")
        if not params:
            raise MeasurementError("no parameters to fit: give -p links[0].EI (repeatable) or "
                                   "[[fit.parameters]] path = \"links[0].EI\" in the scenario")
        window = _window(args.window, table.get("window"))
        span = measurement.time[0], measurement.time[-1]
        if ((window[0] is not None and window[0] >= span[1])
                or (window[1] is not None and window[1] <= span[0])):
            raise MeasurementError(f"fit window {window[0]}:{window[1]} s lies outside the "
                                   f"measured data, {span[0]:g} to {span[1]:g} s")
        step = float(measurement.time[-1] - measurement.time[-2])
        if window[1] is not None and window[1] > span[1] + 0.5 * step:
            raise MeasurementError(f"fit window end {window[1]:g} s is past the measured data, "
                                   f"{span[0]:g} to {span[1]:g} s; give END <= {span[1]:g} or "
                                   "leave it out (the end of the data)")
        budget = (args.max_simulations if args.max_simulations is not None
                  else table.get("max_simulations", 60))
        if isinstance(budget, bool) or not isinstance(budget, int) or budget < 3:
            field = ("--max-simulations" if args.max_simulations is not None
                     else "[fit] max_simulations")
            raise MeasurementError(f"{field} must be an integer >= 3, got {budget!r}")
        progress = None if args.quiet else (lambda m: print(m, file=sys.stderr))
        result = fit(file, measurement, params, channel_list, window,
                     max_simulations=budget, progress=progress, objective=objective)
        fitted = file.resolved(model_values(params, [e.value for e in result.estimates]))
        write_fit(result, out_dir, fitted, overwrite=args.overwrite,
                  figures=not args.no_figures, figure_worker=worker)
        if args.quiet:
            print(out_dir)
        else:
            for e in result.estimates:
                print(f"{e.path:<28} {e.value:.6g}  (95 % {e.ci_low:.6g} … {e.ci_high:.6g})"
                      f"{f' {e.unit}' if e.unit not in ('', '1') else ''}"
                      f"{'  AT BOUND' if e.at_bound else ''}")
            print(f"{metrics_table(result.comparison.metrics)}\nwrote {out_dir}")
        return 0

    return _run(args, work)


def _load(args: argparse.Namespace) -> Any:
    from .loading import load_experiment

    check_unique("--map", [m.partition("=")[0].strip() for m in args.map])
    return load_experiment(args.scenario, args.measured, args.map,
                           time_column=args.time_column, time_offset=args.time_offset,
                           free_vibration_start=args.free_from,
                           hold_after_manoeuvre=False if args.no_hold else None)


def _window(option: str | None, table_value: Any) -> tuple[float | None, float | None]:
    if option is not None:
        start, sep, end = option.partition(":")
        try:
            window = (float(start) if start.strip() else None,
                      float(end) if sep and end.strip() else None)
        except ValueError:
            raise MeasurementError(f"--window {option!r}: expected START:END in s") from None
        return _checked_window(window, "--window")
    if table_value is None:
        return None, None
    if (not isinstance(table_value, list) or len(table_value) != 2
            or not all(isinstance(v, int | float) and not isinstance(v, bool)
                       for v in table_value)):
        raise MeasurementError(f"[fit] window: expected [START, END] in s, got {table_value!r}")
    return _checked_window((float(table_value[0]), float(table_value[1])), "[fit] window")


def _checked_window(window: tuple[float | None, float | None], field: str
                    ) -> tuple[float | None, float | None]:
    """The window if its ends are finite and in order; MeasurementError naming ``field``."""
    start, end = window
    if any(v is not None and not math.isfinite(v) for v in window):
        raise MeasurementError(f"{field}: the ends must be finite numbers (s), got "
                               f"{start}:{end}")
    if start is not None and end is not None and not start < end:
        raise MeasurementError(f"{field}: the start must be before the end, got {start:g} to "
                               f"{end:g} s")
    return window
