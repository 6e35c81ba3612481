"""Command line: ``flexlink run``, ``flexlink paper``, ``flexlink show-paper``; ``sweep`` lives in
`flexlink.batch.command`, ``compare`` and ``fit`` in `flexlink.experiment.commands`,
``animate`` and ``report`` in `flexlink.results.command`.

Exit status: 0 success, 1 the simulation failed, 2 invalid input (scenario, options, output
folder), 130 interrupted. Input errors print every problem on stderr, one per line, without a
traceback, and leave no output folder behind.
"""

from __future__ import annotations

import argparse
import gc
import math
import os
import sys
import warnings
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any, NoReturn

PAPER_DEFAULT_OUTPUT = "paper_results"


class _VersionAction(argparse.Action):
    """``--version``: the installed version, read only when asked (importlib.metadata would
    otherwise be part of every command's start-up)."""

    def __init__(self, option_strings: Sequence[str], dest: str = argparse.SUPPRESS,
                 default: str = argparse.SUPPRESS, help: str | None = None) -> None:
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0,
                         help=help or "show program's version number and exit")

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        from ._version import package_version

        sys.stdout.write(f"flexlink {package_version()}\n")
        parser.exit()


class CommandParser(argparse.ArgumentParser):
    """The parser of one command: its options and positional arguments in any order
    (``flexlink fit S.toml -p X M.csv`` as well as ``flexlink fit -p X S.toml M.csv``, where
    argparse alone takes an optional positional only next to the one before it), and an
    argument it does not know reported with the command's own usage."""

    _parsing = False

    def parse_known_args(self, args: Sequence[str] | None = None,  # type: ignore[override]
                         namespace: argparse.Namespace | None = None
                         ) -> tuple[argparse.Namespace, list[str]]:
        if self._parsing or (args is not None and "--" in args):
            # the passes of parse_known_intermixed_args (Python 3.11, 3.12); or "--", which
            # it mishandles there, and after which every argument is positional anyway
            return super().parse_known_args(args, namespace)
        self._parsing = True
        try:
            namespace, extras = self.parse_known_intermixed_args(args, namespace)
        finally:
            self._parsing = False
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return namespace, extras


def build_parser() -> argparse.ArgumentParser:
    """The argument parser (also used by the docs and tests)."""
    parser = argparse.ArgumentParser(
        prog="flexlink",
        description="Simulate planar chains of flexible links (assumed modes; Choi & Kwak "
                    "2016): joints prescribed, driven by torques or servos, on a fixed or "
                    "moving base, first-order or geometrically nonlinear, open or closed loop.",
        epilog="Start from the built-in experiment: flexlink show-paper > my.toml, edit it, "
               "then flexlink run my.toml -o my_results. Scenario keys: docs/scenario.md.",
    )
    parser.add_argument("--version", action=_VersionAction)
    output = argparse.ArgumentParser(add_help=False)
    output.add_argument("-o", "--output", metavar="DIR", type=Path,
                        help="results folder to create (must not exist or be empty)")
    output.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    output.add_argument("--overwrite", action="store_true",
                        help="replace DIR if it holds an earlier flexlink run and nothing else")
    output.add_argument("-q", "--quiet", action="store_true",
                        help="no progress bar and no summary; print only the results folder")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True,
                                     parser_class=CommandParser)
    page = argparse.ArgumentParser(add_help=False)
    page.add_argument("--no-report", action="store_true",
                      help="skip report.html (the self-contained page of the run)")
    page.add_argument("--animate", action="store_true",
                      help="also write animation.gif (a few seconds) and show it in the report")

    run = commands.add_parser("run", parents=[output, page], help="simulate a scenario file",
                              description="Load a TOML scenario, simulate it, write DIR.")
    run.add_argument("scenario", nargs="?", type=Path, metavar="SCENARIO.toml",
                     help="scenario file (default output folder: <name>_results)")
    run.add_argument("--paper", action="store_true",
                     help="run the built-in paper experiment instead of a file")
    run.set_defaults(handler=_cmd_run, subparser=run)

    paper = commands.add_parser("paper", parents=[output, page],
                                help="simulate the paper's two-link experiment",
                                description="Simulate the built-in scenario of Choi & Kwak "
                                            f"(2016). Default DIR: {PAPER_DEFAULT_OUTPUT}.")
    paper.set_defaults(handler=_cmd_paper, paper=True, scenario=None)

    show = commands.add_parser("show-paper", help="print the built-in scenario as TOML",
                               description="Print the built-in paper scenario (with comments); "
                                           "redirect it to a file to start your own.")
    show.set_defaults(handler=_cmd_show_paper)

    warmup = commands.add_parser(
        "warmup", help="compile the numba loops now (pip install does it already)",
        description="Compile and cache every compiled loop flexlink runs (every path) by "
                    "simulating tiny scenarios, so that no later run waits for the compiler. "
                    "Installing flexlink (pip install ., pip install -e .) does this already: "
                    "then the command says so and does nothing. It is for installations "
                    "whose loops were not compiled or no longer match (built with "
                    "FLEXLINK_BUILD_KERNELS=none, edited sources, another numba): compiled "
                    "code goes to numba's cache, beside the modules, or NUMBA_CACHE_DIR for a "
                    "read-only installation.")
    warmup.set_defaults(handler=_cmd_warmup)

    from .batch.command import add_parser as add_sweep_parser

    add_sweep_parser(commands)

    from .experiment.commands import add_commands  # compare, fit: docs/experiment.md

    add_commands(commands, output)

    from .results.command import add_commands as add_results_commands  # animate, report

    add_results_commands(commands)

    from .shaping.command import add_commands as add_shaping_commands  # optimize

    add_shaping_commands(commands)

    from .control.command import add_commands as add_control_commands  # linearize, modes

    add_control_commands(commands, output)
    return parser


# paused: the collector paused by main() (start-up); command: main() runs the command's own
# process (no argv), which exits when it returns
_start_up: dict[str, bool] = {"paused": False, "command": False}


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``flexlink`` command; returns the exit status. ``argv``: the
    arguments (default: the command line's, and the process is about to exit).

    The command's own process (no ``argv``) runs its start-up without the garbage collector
    and freezes the heap at exit (ARCHITECTURE.md, "Start-up of `flexlink run`");
    `_collect_from_here` resumes the collector, skipping the objects made so far. A caller's
    own ``argv`` (a test, a script) goes on with its objects and its collector as they
    were."""
    command = argv is None
    if command:
        gc.disable()
        _start_up["paused"] = True
        _start_up["command"] = True
        _one_blas_thread(sys.argv[1:])
    try:
        return _main(argv)
    finally:
        if command:
            gc.freeze()
            _collect_from_here()  # if a failure came first
            _start_up["command"] = False


# The commands that run one simulation: its integrators limit BLAS to one thread anyway
# (solvers/threads.py) and the rest of a run multiplies matrices too small for threads; and
# those whose runs, fits and least squares are as small (their process pools inherit it).
ONE_BLAS_THREAD_COMMANDS = ("run", "paper", "compare", "fit", "optimize")
# OpenBLAS reads the first of these that is set; a user's own setting is kept.
BLAS_THREAD_VARIABLES = ("OPENBLAS_NUM_THREADS", "GOTO_NUM_THREADS", "OMP_NUM_THREADS")


def _one_blas_thread(args: Sequence[str]) -> None:
    """Start OpenBLAS (numpy's and scipy's) with one thread in the own process of a command
    of ONE_BLAS_THREAD_COMMANDS, unless the user chose a number of threads: the thread OpenBLAS starts for
    the second core spins for work after numpy's and scipy's imports, CPU that the figures'
    processes and the run itself wait for (ARCHITECTURE.md, "Start-up of `flexlink run`")."""
    if (args and args[0] in ONE_BLAS_THREAD_COMMANDS and "numpy" not in sys.modules
            and not any(name in os.environ for name in BLAS_THREAD_VARIABLES)):
        os.environ["OPENBLAS_NUM_THREADS"] = "1"


def command() -> NoReturn:
    """The ``flexlink`` program (``python -m flexlink`` and the installed script): `main`,
    then the end of the process without Python's teardown of its modules.

    After a run the interpreter holds ~10⁶ objects of numpy, scipy and numba, and unloading
    their modules one by one frees nothing a process that ends needs freed
    (ARCHITECTURE.md, "Start-up of `flexlink run`"): stdout and stderr are flushed and the
    exit functions (``atexit``) run as in a normal exit. Where other threads are still
    running, or flushing fails (a closed pipe), Python's usual exit runs instead."""
    status = main()
    _exit(status)


def _exit(status: int) -> NoReturn:
    import atexit
    import threading

    if threading.active_count() == 1:
        try:
            sys.stdout.flush()
            sys.stderr.flush()
        except (OSError, ValueError):
            pass  # Python's own exit reports it
        else:
            atexit._run_exitfuncs()  # the handlers a normal exit runs
            os._exit(status)
    raise SystemExit(status)


def _collect_from_here() -> None:
    """Resume the garbage collector paused by main(), leaving the start-up's objects out of
    its collections (a long run or sweep collects its own garbage as usual)."""
    if _start_up["paused"]:
        _start_up["paused"] = False
        gc.freeze()
        gc.enable()


def _main(argv: Sequence[str] | None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if getattr(args, "paused_start_up", False):
        # the command imports within the block, then calls the function (experiment/commands.py)
        args.start_up = (withheld_imports(_optional_imports()), _collect_from_here)
        args.own_process = _start_up["command"]  # flexlink/_light_start.py's measures: only here
    elif args.handler is not _cmd_run and args.handler is not _cmd_paper:
        _collect_from_here()  # only `run` and `paper` keep it paused through their imports
    if args.command == "run" and (args.paper == (args.scenario is not None)):
        args.subparser.error("give a scenario file or --paper (exactly one)")
    try:
        return int(args.handler(args))
    except KeyboardInterrupt:
        print("flexlink: interrupted", file=sys.stderr)
        return 130


def _cmd_show_paper(args: argparse.Namespace) -> int:
    from .scenario import paper_experiment_text

    sys.stdout.write(paper_experiment_text())
    return 0


# The warm-up runs: one per path (simulation.PATHS), and a free base moved by its loads with every joint
# prescribed (the forward path's inputs then come from the base loads only); "batched": the
# sweeps' Lawson loop over many variants at once.
WARMUP_RUNS = ("prescribed", "nonlinear", "nonlinear_step", "forward", "free_base",
               "nonlinear_forward", "nonlinear_forward_step", "closed_loop", "four_bar",
               "nonlinear_four_bar", "sensitivities", "batched")
# The warm-up runs that also compute sensitivities, with their fields: the Lawson tangent
# loop (prescribed), the Radau IIA steps' linearization (forward), the derivative of the
# momentum projection (free_base), the closed loops' rates at given states and their
# outputs at moved states (four_bar; also what held inputs' sensitivities evaluate) and the
# Gauss steps' replay and batched residuals (both nonlinear paths).
WARMUP_SENSITIVITIES: dict[str, list[str]] = {"sensitivities": ["links[0].EI"],
                                              "forward": ["links[0].EI"],
                                              "free_base": ["links[0].EI"],
                                              "four_bar": ["links[1].EI"],
                                              "nonlinear": ["links[0].EI"],
                                              "nonlinear_forward": ["links[0].EI"]}
# The warm-up runs that also take an objective's gradient, with its channel (a sensor on
# the modes: the reverse pass of the Lawson steps, and of the Radau IIA steps on the
# forward path, with the projection's derivative on the free base).
WARMUP_OBJECTIVES: dict[str, str] = {"sensitivities": "link2_tip_deflection",
                                     "forward": "link2_tip_deflection",
                                     "free_base": "link2_tip_deflection"}


def warmup_run(name: str, scenario: Any) -> None:
    """`simulate` of one warm-up run (`WARMUP_RUNS`), with its `WARMUP_SENSITIVITIES` and
    `WARMUP_OBJECTIVES`; "batched" also runs a sweep's batched Lawson loop."""
    fields = WARMUP_SENSITIVITIES.get(name)
    if fields:
        from .simulation.objective import warm_up
        from .simulation.sensitivities import simulate_with_sensitivities

        simulate_with_sensitivities(scenario, fields, shapes=False)
        if name in WARMUP_OBJECTIVES:
            warm_up(scenario, fields, WARMUP_OBJECTIVES[name])
        return
    from .simulation import simulate

    simulate(scenario, shapes=False)
    if name == "batched":
        from .batch.grouped import warm_up as warm_up_batched

        warm_up_batched(scenario)


def warmup_scenarios() -> dict[str, Any]:
    """Tiny variants of the paper scenario (20 ms simulated), keyed by `WARMUP_RUNS`, that run every
    compiled loop: the Lawson loop (prescribed), Gauss collocation (nonlinear: adaptive, and
    with a fixed `step`), the forward kernel with its Radau IIA integrator (driven joints; a
    free base), the nonlinear model's forward collocation (adaptive, and with a fixed `step`)
    the closed-loop Lawson loop, the kernels of mechanisms with closed loops (a
    four-bar, in both models), the tangent loop of sensitivities (the prescribed run,
    with `WARMUP_SENSITIVITIES`) and a sweep's batched Lawson loop (the prescribed run)."""
    import copy

    from .scenario import paper_experiment_path, resolve_scenario_dict, scenario_from_dict

    base = resolve_scenario_dict(paper_experiment_path())
    base["simulation"]["t_end"] = 0.02
    nonlinear = copy.deepcopy(base)
    nonlinear["simulation"]["model"] = "nonlinear"
    nonlinear_step = copy.deepcopy(nonlinear)
    nonlinear_step["simulation"]["step"] = 1e-3
    forward = copy.deepcopy(base)
    for joint in forward["joints"]:
        joint.pop("motion")
        joint.update(drive="torque", torque=[{"profile": "bang_bang", "amplitude": 0.01,
                                              "start": 0.0, "duration": 0.02}])
    free_base = copy.deepcopy(base)
    free_base["base"] = {"type": "free", "mass": 10.0, "inertia": 1.0, "loads": [
        {"moment": [{"profile": "bang_bang", "amplitude": 0.01, "start": 0.0,
                     "duration": 0.02}]}]}
    nonlinear_forward = copy.deepcopy(forward)
    nonlinear_forward["simulation"]["model"] = "nonlinear"
    nonlinear_forward_step = copy.deepcopy(nonlinear_forward)
    nonlinear_forward_step["simulation"]["step"] = 1e-3
    closed_loop = copy.deepcopy(base)
    closed_loop["actuators"] = [{"name": "warmup_patch", "kind": "piezo", "collocated_with": "pzt",
                                 "limit": 100.0}]
    closed_loop["controllers"] = [{"name": "warmup_ppf", "kind": "ppf", "sensor": "pzt",
                                   "actuator": "warmup_patch", "frequency_hz": 2.5,
                                   "damping": 0.3, "gain": 10.0, "sample_rate": 1000.0}]
    four_bar = {"simulation": {"t_end": 0.02, "dt_out": 0.01}, "links": [
        {"name": "crank", "length": 0.1, "mass_per_length": 1.0, "rigid": True},
        {"name": "coupler", "length": 0.3, "mass_per_length": 0.3, "EI": 20.0, "modes": 2},
        {"name": "rocker", "length": 0.25, "mass_per_length": 1.0, "rigid": True}], "joints": [
        {"motion": [{"profile": "spinup", "to_rate_deg_s": 90.0, "start": 0.0,
                     "duration": 0.02, "from_deg": 90.0}]},
        {"drive": "free", "initial_angle_deg": -60.0},
        {"drive": "free", "base_point": [0.3, 0.0], "initial_angle_deg": 100.0}],
        "closures": [{"name": "pin", "link": "coupler", "to_link": "rocker"}]}
    nonlinear_four_bar = copy.deepcopy(four_bar)
    nonlinear_four_bar["simulation"]["model"] = "nonlinear"
    with warnings.catch_warnings():  # a short run of the paper's arm ends before its moves
        warnings.simplefilter("ignore", UserWarning)
        return {name: scenario_from_dict(d) for name, d in zip(
            WARMUP_RUNS, (base, nonlinear, nonlinear_step, forward, free_base,
                          nonlinear_forward, nonlinear_forward_step, closed_loop, four_bar,
                          nonlinear_four_bar, base, base), strict=True)}


def _cmd_warmup(args: argparse.Namespace) -> int:
    import time

    from ._compiled_cache import cache_root, complete, read_record

    root = cache_root()
    if root is not None and complete(read_record(root), WARMUP_RUNS):
        print(f"every compiled loop was compiled when flexlink was installed ({root}): "
              "nothing to do")
        return 0
    status = 0
    for name, scenario in warmup_scenarios().items():
        start = time.perf_counter()
        try:
            warmup_run(name, scenario)
        except Exception as exc:  # noqa: BLE001 — report it and go on with the others
            print(f"{name}: failed: {type(exc).__name__}: {exc}", file=sys.stderr)
            status = 1
            continue
        print(f"{name} runs ready ({time.perf_counter() - start:.1f} s)")
    return status


def _cmd_paper(args: argparse.Namespace) -> int:
    return _cmd_run(args)


def _cmd_run(args: argparse.Namespace) -> int:
    worker = None
    if not args.no_figures:
        # matplotlib and the figures in second processes, while this one reads the scenario,
        # imports numba and scipy, simulates and writes (results/figure_worker.py); forked
        # first, while this process is small and before anything it alone needs is imported.
        # A command that fails before its figures stops the child (FigureWorker.close).
        from .results.figure_worker import FigureWorker

        worker = FigureWorker.start()
    try:
        return _load_simulate_and_write(args, worker)
    finally:
        if worker is not None:
            worker.close()


def _load_simulate_and_write(args: argparse.Namespace, worker: Any) -> int:
    from .results.writers import OutputFolderError, check_output_dir
    from .scenario import ScenarioError

    try:
        scenario, resolved = _load(args.scenario)
        out_dir = args.output or Path(
            PAPER_DEFAULT_OUTPUT if args.scenario is None else f"{args.scenario.stem}_results")
        check_output_dir(out_dir, args.overwrite)
    except ScenarioError as exc:
        return _fail(str(exc))
    except (OutputFolderError, ValueError, OSError) as exc:
        return _fail(f"error: {exc}")
    if worker is not None:  # its figures' frames are made while this process simulates
        from .channels.catalogue import catalogue

        worker.hint(catalogue(scenario))
    with withheld_imports(_optional_imports()):
        preload = _preload_compiled_code(scenario)  # after the fork: no fork with threads
        try:
            from .simulation import simulate  # noqa: F401 — imported while numba loads
        except ImportError:
            pass  # a library needs a withheld module after all: imported again below
        if preload is not None:
            preload.join()  # loaded meanwhile; compiled code must not run while it loads
    return _simulate_and_write(scenario, resolved, out_dir, args, worker)


# Modules that numba and scipy import when they are installed and that a run never uses:
# charset_normalizer (numpy.f2py's guess of a Fortran file's encoding, imported through
# scipy's copy of numpy's namespace), cffi (numba's typing of cffi functions) and yaml
# (numba's reading of a .numba_config.yaml in the current folder, so only where there is
# none). Each is optional to them (imported inside a try).
WITHHELD_IMPORTS = ("charset_normalizer", "cffi", "yaml")
NUMBA_CONFIG_FILE = ".numba_config.yaml"


def _optional_imports() -> tuple[str, ...]:
    """`WITHHELD_IMPORTS` for the command's own process (whose libraries then go without them
    until it exits), none for a caller of ``main(argv)`` that goes on."""
    if not _start_up["command"]:
        return ()
    if os.path.exists(NUMBA_CONFIG_FILE):
        return tuple(n for n in WITHHELD_IMPORTS if n != "yaml")
    return WITHHELD_IMPORTS


@contextmanager
def withheld_imports(names: Sequence[str]) -> Iterator[list[str]]:
    """Within the block, ``import name`` raises ImportError for each of ``names`` that is not
    imported yet (Python's own ``sys.modules[name] = None``); afterwards it imports as usual.
    Yields the names withheld. For `flexlink run`'s start-up: numba and scipy load meanwhile
    and go without the optional modules `WITHHELD_IMPORTS` (ARCHITECTURE.md, "Start-up of
    `flexlink run`"). Should a
    library need one after all, its import fails inside the block and succeeds when
    retried after it (the run imports the simulation code again on first use)."""
    held = [name for name in names if name not in sys.modules]
    for name in held:
        sys.modules[name] = None  # type: ignore[assignment]
    try:
        yield held
    finally:
        for name in held:
            if name in sys.modules and sys.modules[name] is None:
                del sys.modules[name]


def _preload_compiled_code(scenario: Any) -> Any:
    """Load (or compile) the step loop of a Lawson run in the background while this process
    imports the rest (solvers/lawson.py); the loading thread, or None."""
    settings = scenario.settings
    if (not scenario.is_forward and settings.model != "nonlinear"
            and settings.method == "lawson"):
        from .solvers.lawson import preload_compiled_loop

        return preload_compiled_loop()
    return None


def _simulate_and_write(scenario: Any, resolved: dict[str, Any], out_dir: Path,
                        args: argparse.Namespace, figure_worker: Any = None) -> int:
    from .errors import RunTooLarge, SimulationError
    from .results.writers import write_run
    from .simulation import simulate

    _collect_from_here()  # imports done
    try:
        results = simulate(scenario, progress=not args.quiet)
    except RunTooLarge as exc:  # refused before anything ran: an input error
        return _fail(f"error: {exc}")
    except (SimulationError, FloatingPointError) as exc:
        return _fail(f"simulation failed: {exc}", status=1)
    except ValueError as exc:
        return _fail(f"error: {exc}")
    results.metadata.update(_mode_convergence(scenario))
    try:
        write_run(results, out_dir, resolved, figures=not args.no_figures,
                  overwrite=args.overwrite, report=not args.no_report, animation=args.animate,
                  figure_worker=figure_worker)
    except (ValueError, OSError) as exc:
        return _fail(f"error: could not write {out_dir}: {exc}")
    print(out_dir if args.quiet else summary(results, out_dir, scenario.name))
    return 0


def _mode_convergence(scenario: Any) -> dict[str, Any]:
    """The run attributes of the mode-convergence estimate (control/convergence.py): none
    where the scenario cannot be linearised at t = 0, which the run itself did not need; a
    `mode_convergence_warning` naming any other failure of it."""
    from .control.convergence import estimate_for_command

    estimate, failure = estimate_for_command(scenario)
    if failure is not None:
        return {"mode_convergence_warning": failure}
    return estimate.metadata() if estimate is not None else {}


def _load(path: Path | None) -> tuple[Any, dict[str, Any]]:
    """(Scenario, resolved dict) from a file, or the built-in paper scenario for None."""
    from .scenario import paper_experiment_path, resolve_scenario_dict, scenario_from_dict

    source = paper_experiment_path() if path is None else path
    with warnings.catch_warnings(record=True) as caught:  # the scenario's, as "warning: ..."
        warnings.simplefilter("always")
        resolved = resolve_scenario_dict(source)
        scenario = scenario_from_dict(resolved, source=str(source))
    for message in dict.fromkeys(str(w.message) for w in caught  # each once
                                 if not issubclass(w.category, DeprecationWarning)):
        print(f"warning: {message}", file=sys.stderr)
    return scenario, resolved


def _fail(message: str, status: int = 2) -> int:
    print(message, file=sys.stderr)
    return status


def summary(results: Any, out_dir: Path, name: str) -> str:
    """A few lines: what ran, the peak of each channel, and where the files are."""
    t = results.time
    lines = [f"flexlink: simulated '{name}', t = {t[0]:g} to {t[-1]:g} s ({t.size} samples)",
             _model_line(results.metadata), *_accuracy_line(results.metadata),
             "peak |value| of each channel:"]
    width = max(len(n) for n in results.names) if results.names else 0
    for name_, channel in results.channels.items():
        values = results[name_]
        peak = float(abs(values).max()) if values.size else 0.0
        extra = f"  ({math.degrees(peak):.4g} deg)" if channel.unit == "rad" else ""
        lines.append(f"  {name_:<{width}}  {peak:.4g} {channel.unit}{extra}")
    if "mode_bases" in results.metadata:
        from .control.convergence import modes_line

        lines.append(modes_line(results.metadata))
    for key in ("validity_warning", "control_warning", "mode_convergence_warning",
                "stiff_links_warning"):
        if key in results.metadata:
            lines.append(f"warning: {results.metadata[key]}")
    files = sorted(p.relative_to(out_dir).as_posix() for p in out_dir.rglob("*") if p.is_file())
    lines.append(f"wrote {out_dir}{'/' if not str(out_dir).endswith('/') else ''}: "
                 + ", ".join(files))
    return "\n".join(lines)


def _accuracy_line(meta: dict[str, Any]) -> list[str]:
    """The tolerance the integrator was asked for and the error estimate it reached (none
    for a run without integration)."""
    if "rtol" not in meta:
        return []
    reached = (f"error estimate reached {meta['error_estimate']:.2g} of the peak"
               if "error_estimate" in meta else "no error estimate")
    measure = str(meta.get("error_estimate_measure", "")).split(":")[0]
    return [f"accuracy: rtol {meta['rtol']:g} asked for, {reached}"
            + (f" ({measure})" if measure and "error_estimate" in meta else "")]


def _model_line(meta: dict[str, Any]) -> str:
    """Which model and integrator ran and, for first order, how far the deflection went."""
    model = str(meta.get("model", "?")).replace("_", "-")
    if meta.get("geometric_stiffening") is not None and model == "first-order":
        model += " (geometrically stiffened)" if meta["geometric_stiffening"] else \
            " (the paper's, without geometric stiffening)"
    path = {"prescribed": "prescribed joints", "nonlinear": "prescribed joints",
            "forward": "forward dynamics", "nonlinear_forward": "forward dynamics",
            "closed_loop": "prescribed joints in closed loop"}.get(str(meta.get("path")),
                                                                   str(meta.get("path")))
    line = f"model: {model}, {path}, integrator {meta.get('method', '?')}"
    if "accuracy" in meta:  # the statement of simulation/accuracy.py, for the model that ran
        line += f"\naccuracy: {meta['accuracy']}"
    return line
