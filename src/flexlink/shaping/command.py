"""``flexlink optimize SCENARIO -o DIR``: a manoeuvre without residual vibration.

Writes to DIR: ``optimized.toml`` (the scenario with the optimised joints as
``profile = "harmonic"``: ``flexlink run DIR/optimized.toml`` reproduces the move),
``trajectory.csv`` (t in s; angle, rate, acceleration of every joint in deg, deg/s, deg/s²),
``summary.json`` (limits, continuous-time peaks, residual energies, residual tip
deflection of the cycloidal, shaped and optimised moves, their robustness over a band of
frequency errors in every model compared, run time, how the optimiser stopped),
``scenario.resolved.toml`` (the scenario given, every default filled in) and the figures
``residual.png`` and ``robustness.png``. Exit status as `flexlink run`: 2 for bad
input or an infeasible request (the message names the binding limit), 1 if a simulation
fails.
"""

from __future__ import annotations

import argparse
import math
import platform
import sys
from pathlib import Path
from typing import Any

from ..options import (
    check_size,
    json_text,
    nonnegative_finite_float,
    nonnegative_int,
    positive_float,
    positive_int,
)

ERRORS_PCT = tuple(2.5 * i for i in range(-8, 9))  # %, the robustness curve's plants
BAND_PCT = (-10.0, -5.0, 0.0, 5.0, 10.0)  # %, the frequency errors of the robustness report
BAND_PAIR = ("cycloidal", "optimised")  # the moves of the robustness report


def add_commands(commands: Any) -> None:
    """Register ``optimize`` on the subparsers ``commands``."""
    p = commands.add_parser(
        "optimize", help="joint trajectories without residual vibration",
        description="Choose the joint trajectories of a scenario's rest-to-rest moves (the "
                    "cycloid plus harmonics, end angles and duration fixed) that minimise the "
                    "residual vibration energy after the move, within joint rate, "
                    "acceleration and torque limits; compare them with the cycloidal and the "
                    "input-shaped moves. docs/shaping.md.")
    p.add_argument("scenario", nargs="?", type=Path, metavar="SCENARIO.toml",
                   help="scenario file (default: the built-in paper experiment with --paper)")
    p.add_argument("--paper", action="store_true", help="optimise the built-in paper scenario")
    p.add_argument("-o", "--output", type=Path, metavar="DIR", required=True,
                   help="folder to create (must not exist or be empty)")
    p.add_argument("--overwrite", action="store_true",
                   help="replace DIR if it holds an earlier flexlink folder")
    p.add_argument("--duration", type=positive_float, metavar="S",
                   help="duration of every move, s (default: each move's own)")
    p.add_argument("--rate-limit", metavar="DEG_S[,…]",
                   help="joint rate limit, deg/s: one value, or one per joint")
    p.add_argument("--acceleration-limit", metavar="DEG_S2[,…]",
                   help="joint acceleration limit, deg/s²")
    p.add_argument("--torque-limit", metavar="NM[,…]", help="joint torque limit, N·m")
    p.add_argument("--harmonics", type=positive_int, default=4,
                   help="cosine and sine terms per joint (default 4)")
    p.add_argument("--robust", type=nonnegative_finite_float, default=10.0, metavar="PCT",
                   help="also cancel the vibration of plants with every frequency ±PCT %% off "
                        "(default 10; 0: the nominal plant only, a deeper but narrow notch)")
    p.add_argument("--stiffening", choices=("both", "scenario"), default="both",
                   help="plants with and without geometric stiffening (default), or only the "
                        "scenario's setting")
    p.add_argument("--seed", type=nonnegative_int, default=0,
                   help="seed of the starting point (0)")
    p.add_argument("--workers", type=positive_int,
                   help="processes for the gradient (all cores)")
    p.add_argument("--shaper", choices=("zv", "zvd", "ei"), default="zvd",
                   help="the input shaper of the comparison (default zvd, lowest 2 modes)")
    p.add_argument("--model", choices=("first_order", "nonlinear"), action="append",
                   help="model(s) the comparison and the robustness report run in (default "
                        "the scenario's model; repeat for both)")
    p.add_argument("--max-iterations", type=int, default=30, metavar="N",
                   help="iteration limit of the optimiser (default 30)")
    p.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    # paused_start_up: the collector stays paused through the imports (_start_up_imports)
    p.set_defaults(handler=run_optimize, paused_start_up=True)


def _check_arguments(args: argparse.Namespace) -> None:
    """ValueError naming the option when a number is out of its range (before anything
    runs); the parser's types (flexlink.options) have refused non-numbers, non-finite
    durations and worker counts below 1 already."""
    if not (math.isfinite(args.robust) and 0.0 <= args.robust < 50.0):
        raise ValueError(f"--robust must be a percentage in [0, 50), got {args.robust:g}")
    if not 1 <= args.harmonics <= 20:
        raise ValueError(f"--harmonics must be from 1 to 20, got {args.harmonics}")
    if args.max_iterations < 1:
        raise ValueError(f"--max-iterations must be ≥ 1, got {args.max_iterations}")


def _limits(text: str | None, name: str) -> list[float] | None:
    if text is None:
        return None
    try:
        return [float(v) for v in text.split(",")]
    except ValueError:
        raise ValueError(f"--{name}: expected numbers separated by commas, got {text!r}") from None


def run_optimize(args: argparse.Namespace) -> int:
    worker = _start_figures(args)
    try:
        _start_up_imports(args)
        return _optimize_command(args, worker)
    finally:
        if worker is not None:
            worker.close()


def _start_figures(args: argparse.Namespace) -> Any:
    """A forked worker that imports matplotlib while this process optimises and draws the
    figures while it finishes its runs and writes (`experiment.figure_worker`), or None: no
    figures, a bad call, or no fork. Forked before the heavy imports."""
    if args.no_figures or args.paper == (args.scenario is not None):
        return None
    from ..experiment.figure_worker import FigureWorker

    return FigureWorker.start(drawing="flexlink.shaping.figures")


def _start_up_imports(args: argparse.Namespace) -> None:
    """Import what the command uses within the block `cli.main` gives (``args.start_up``:
    optional modules of numba and scipy withheld), with the start-up measures of the
    command's own process (`flexlink._light_start`), the Lawson loop's compiled code loading
    meanwhile; then resume the garbage collector, as `flexlink fit` does (ARCHITECTURE.md,
    "Start-up of `flexlink run`"). Without ``start_up`` (a caller of the handler itself):
    nothing, the command imports as it goes."""
    if not hasattr(args, "start_up"):
        return
    block, imports_done = args.start_up
    with block:
        if getattr(args, "own_process", False):  # pool workers fork from it: theirs too
            from .._light_start import start_command_process

            start_command_process()
        preload = None
        try:
            from ..solvers.lawson import preload_compiled_loop

            preload = preload_compiled_loop()
            import scipy.linalg
            import scipy.optimize  # noqa: F401

            from ..results import writers  # noqa: F401
            from ..scenario import toml_writer  # noqa: F401
            from . import compare, optimize  # noqa: F401
        except ImportError:
            pass  # a library needs a withheld module after all: imported again on use
        finally:
            if preload is not None:
                preload.join()  # compiled code must not run while it loads, nor a fork
    imports_done()


def _optimize_command(args: argparse.Namespace, worker: Any) -> int:
    from ..results.writers import OutputFolderError, check_output_dir
    from ..scenario import (
        ScenarioError,
        paper_experiment_path,
        resolve_scenario_dict,
        scenario_from_dict,
    )
    from .optimize import InfeasibleMove, Limits, check_request, optimize_move

    if args.paper == (args.scenario is not None):
        print("flexlink optimize: give a scenario file or --paper (exactly one)", file=sys.stderr)
        return 2
    source = paper_experiment_path() if args.paper else args.scenario
    try:
        check_output_dir(args.output, args.overwrite)
        _check_arguments(args)
        check_request(args.duration, args.harmonics, args.robust / 100.0, args.workers,
                      args.max_iterations)
        limits = Limits(_limits(args.rate_limit, "rate-limit"),
                        _limits(args.acceleration_limit, "acceleration-limit"),
                        _limits(args.torque_limit, "torque-limit"))
        resolved = resolve_scenario_dict(source)
        scenario = scenario_from_dict(resolved, source=str(source))
        check_run_length(scenario, args.duration)
        models = args.model or [scenario.settings.model]
        keys, calls = ([], []) if scenario.is_forward else early_report_runs(
            scenario, args.duration, args.shaper, models, not args.no_figures)
        result = optimize_move(scenario, args.duration, limits, args.harmonics,
                               args.robust / 100.0, args.seed, args.workers,
                               max_iterations=args.max_iterations, stiffening=args.stiffening,
                               idle_work=calls)
    except ScenarioError as exc:
        print(str(exc), file=sys.stderr)
        return 2
    except (InfeasibleMove, OutputFolderError, ValueError, OSError) as exc:
        print(f"flexlink optimize: {exc}", file=sys.stderr)
        return 2
    from ..errors import SimulationError
    from ..results.writers import atomic_folder

    try:
        with atomic_folder(args.output, args.overwrite) as partial:  # nothing left by a failure
            try:
                early = {k: r for k, r in zip(keys, result.idle_results, strict=True)
                         if r is not None}
                summary = write_outputs(result, resolved, partial, limits, args.shaper,
                                        models, not args.no_figures, figure_worker=worker,
                                        early=early)
            finally:
                if worker is not None:  # never remove the folder under a drawing child
                    worker.close()
    except SimulationError as exc:
        print(f"flexlink optimize: a simulation failed: {exc}", file=sys.stderr)
        return 1
    except (ValueError, OSError) as exc:
        print(f"flexlink optimize: could not write {args.output}: {exc}", file=sys.stderr)
        return 2
    print(summary_text(summary, Path(args.output)))
    return 0


# Output samples of one trial run (the moves' end over simulation.dt_out): the optimiser runs
# each trial hundreds of times, so a longer move is refused before it starts.
MAX_TRIAL_SAMPLES = 100_000


def check_run_length(scenario: Any, duration: float | None) -> None:
    """OptionError, before any run, when the moves (of ``duration`` s, or their own) end
    too late for the trial runs the optimiser makes."""
    from .optimize import joint_moves

    if scenario.is_forward:
        return  # refused by optimize_move, which says why
    dt_out = scenario.settings.dt_out
    end = max((m.start + m.duration for m in joint_moves(scenario, duration)), default=0.0)
    check_size("--duration" if duration is not None else "the moves' duration",
               end / dt_out, MAX_TRIAL_SAMPLES,
               f"output samples per trial run (moves ending at {end:g} s, "
               f"simulation.dt_out = {dt_out:g} s)",
               f"moves ending by {MAX_TRIAL_SAMPLES * dt_out:g} s fit at this dt_out")


def optimized_scenario_dict(result: Any, resolved: dict[str, Any]) -> dict[str, Any]:
    """The resolved scenario with every optimised joint as a ``harmonic`` profile."""
    import copy

    out = copy.deepcopy(resolved)
    out.pop("flexlink_version", None)
    for m in result.moves:
        cosine, sine = result.coefficients[m.joint]
        out["joints"][m.joint] = {"motion": [{
            "profile": "harmonic", "from_deg": m.from_deg, "to_deg": m.to_deg,
            "start": m.start, "duration": m.duration, "cosine": list(cosine),
            "sine": list(sine)}]}
    out["simulation"]["name"] = f"{out['simulation'].get('name') or 'scenario'}-optimized"
    end = result.move_end
    out["simulation"]["t_end"] = max(out["simulation"]["t_end"], end)
    return out


PlanKey = tuple[str, str, float]  # (model, version's label, frequency error %)


def report_plan(labels: list[str], models: list[str], figures: bool
                ) -> list[tuple[str, str, float, bool]]:
    """The report's runs in order, (model, version's label, frequency error %, keep the tip
    trace): per model, each version on the nominal plant (the residual; the first model's
    traces for the figure) and off it (the robustness: the first model's curves of every
    version for the figure, else the band of the cycloidal and optimised moves), 0 % being
    the nominal."""
    plan = []
    for i, model in enumerate(models):
        drawn = figures and i == 0
        plan += [(model, label, 0.0, drawn) for label in labels]
        plan += [(model, label, e, False) for label in (labels if drawn else BAND_PAIR)
                 for e in (ERRORS_PCT if drawn else BAND_PCT) if e != 0.0]
    return plan


def reference_versions(scenario: Any, moves: list[Any], shaper: str
                       ) -> tuple[dict[str, Any], Any, str]:
    """({label: scenario} of the cycloidal and the shaped moves, the shaper's impulse
    sequence or None, why there is no shaped move or "") of the moves of ``scenario``."""
    from . import compare

    versions = {"cycloidal": compare.cycloidal_version(scenario, moves)}
    try:
        versions[f"shaped ({shaper.upper()})"], sequence = compare.shaped_version(
            scenario, moves, shaper)
    except ValueError as exc:
        return versions, None, str(exc)
    return versions, sequence, ""


def early_report_runs(scenario: Any, duration: float | None, shaper: str, models: list[str],
                      figures: bool) -> tuple[list[PlanKey], list[Any]]:
    """The report's runs that do not depend on the optimiser's answer — the cycloidal and
    shaped moves' — as (their `report_plan` keys, picklable calls returning their
    `compare.Residual`), for the optimiser's pool to run while it waits (`optimize_move`'s
    ``idle_work``). The moves are those `optimize_move` makes of ``scenario``; the versions
    are made from it with each moved joint a `Harmonic` of the move, so that they equal
    those made from the answer, whatever its coefficients (the same end angles)."""
    import functools

    import numpy as np

    from ..errors import SimulationError
    from ..motion import Harmonic
    from . import compare
    from .optimize import joint_moves
    from .plants import scale_frequencies

    try:
        moves = joint_moves(scenario, duration)
        stand_in = compare.with_moves(scenario, {m.joint: Harmonic(
            m.from_deg, m.to_deg, m.start, m.duration) for m in moves})
        versions = reference_versions(stand_in, moves, shaper)[0]
    except (ValueError, SimulationError, np.linalg.LinAlgError):
        return [], []  # none early: the optimiser or the report says why; a defect is raised
    end = max(m.end for m in moves)
    keys, calls = [], []
    for model, label, e, keep in report_plan([*versions, "optimised"], models, figures):
        if label in versions:
            sc = versions[label] if e == 0.0 else scale_frequencies(versions[label],
                                                                      1.0 + e / 100.0)
            keys.append((model, label, e))
            calls.append(functools.partial(compare.check_residual, (sc, model, keep), end))
    return keys, calls


def write_outputs(result: Any, resolved: dict[str, Any], out_dir: Path, limits: Any,
                  shaper: str, models: list[str], figures: bool,
                  figure_worker: Any = None,
                  early: dict[PlanKey, Any] | None = None) -> dict[str, Any]:
    """Run the comparisons, then write DIR (module docstring); return the summary.
    ``figure_worker``: an `experiment.figure_worker.FigureWorker` that draws the figures
    while the other runs and files are done (the caller closes it); drawn here if it fails.
    ``early``: the `compare.Residual` of report runs made already, by their `report_plan`
    key (`early_report_runs`)."""
    import numpy as np

    from ..errors import SimulationError
    from ..results.writers import RESOLVED_NAME, resolved_toml
    from ..scenario import scenario_from_dict
    from ..scenario.toml_writer import dump_toml
    from . import compare
    from .plants import scale_frequencies

    data = optimized_scenario_dict(result, resolved)
    optimised = scenario_from_dict(data)  # what the file reproduces
    t = np.arange(0.0, result.move_end + 0.5 + 1e-9, 1e-3)
    columns = {"t": t}
    for k, joint in enumerate(optimised.chain.joints):
        angle, rate, acc = joint.evaluate(t)
        columns[f"joint{k + 1}_angle_deg"] = np.degrees(angle)
        columns[f"joint{k + 1}_rate_deg_s"] = np.degrees(rate)
        columns[f"joint{k + 1}_acceleration_deg_s2"] = np.degrees(acc)

    start = min(m.start for m in result.moves)
    versions, sequence, shaped_note = reference_versions(result.scenario, result.moves, shaper)
    versions["optimised"] = optimised
    # every run of the report at once, on the optimiser's number of processes, but those
    # run already (``early``)
    plan = report_plan(list(versions), models, figures)
    early = early or {}
    checks = [(versions[label] if e == 0.0 else scale_frequencies(versions[label],
                                                                  1.0 + e / 100.0),
               model, keep) for model, label, e, keep in plan]
    rest = [i for i, (model, label, e, _) in enumerate(plan) if (model, label, e) not in early]
    ran = compare.residual_runs([checks[i] for i in rest], result.move_end, result.workers)
    done = [early.get(key[:3]) for key in plan]
    for i, residual in zip(rest, ran, strict=True):
        done[i] = residual
    where = {key[:3]: i for i, key in enumerate(plan)}
    for model in models:
        failed = done[where[model, "optimised", 0.0]]
        if failed.error is not None:
            raise SimulationError(failed.error)
    residual = {model: {label: done[where[model, label, 0.0]].peak for label in versions}
                for model in models}
    band: dict[str, Any] = {}
    curves: dict[str, Any] = {}
    for i, model in enumerate(models):
        if figures and i == 0:
            curves = {label: np.array([done[where[model, label, e]].peak for e in ERRORS_PCT])
                      for label in versions}
        band[model] = compare.band_summary(
            BAND_PCT, *(np.array([done[where[model, label, e]].peak for e in BAND_PCT])
                        for label in BAND_PAIR))
    pictures = None
    if figures:
        model = models[0]
        traces = {label: (r.time, r.tip, r.peak) for label in versions
                  if (r := done[where[model, label, 0.0]]).error is None}
        pictures = _figures(traces, curves, start, result.move_end, model,
                            resolved["simulation"].get("name"),
                            optimised.settings.geometric_stiffening)
        out_dir.mkdir(parents=True, exist_ok=True)
        if figure_worker is not None:
            figure_worker.submit(pictures, out_dir)
    summary = {
        "scenario": resolved["simulation"].get("name"),
        "model": _model_label(optimised),
        "geometric_stiffening": optimised.settings.geometric_stiffening,
        "moves": [vars(m) for m in result.moves],
        "limits": {"rate_deg_s": limits.rate_deg_s, "acceleration_deg_s2":
                   limits.acceleration_deg_s2, "torque_Nm": limits.torque_Nm},
        "peaks": result.peaks,
        "peaks_note": "rate and acceleration: continuous-time maxima of the profiles; torque: "
                      "at the optimiser's torque instants",
        "plants": [{"frequency_factor": f, "geometric_stiffening": s} for f, s in result.plants],
        "plants_left_out": list(result.notes),
        "residual_energy_J": {"cycloidal": result.energy_cycloidal.tolist(),
                              "optimised": result.energy.tolist()},
        "residual_tip_deflection_m": residual,
        "residual_window_s": [result.move_end, result.move_end + compare.DEFAULT_WINDOW_S],
        "robustness_band": band,
        "robustness_band_note": "residual tip deflection (m) of the cycloidal and optimised "
                                "moves on plants with every frequency off by errors_pct "
                                "(every EI scaled by (1 + error)²), in each model, with the "
                                "scenario's geometric stiffening setting",
        "shaper": None if sequence is None else {
            "kind": shaper, "amplitudes": list(sequence.amplitudes),
            "times_s": list(sequence.times)},
        "shaper_note": shaped_note,
        "optimiser": {"gradient": "forward differences of the energy residual vector, step "
                      "fd_step, runs in parallel processes",
                      "iterations": result.iterations, "evaluations": result.evaluations,
                      "workers": result.workers, "wall_time_s": result.wall_time_s,
                      "success": result.success, "message": result.message,
                      "stopped_at_iteration_limit": result.stopped_at_limit, **result.info,
                      "coefficients": [list(result.coefficients[m.joint][0])
                                       + list(result.coefficients[m.joint][1])
                                       for m in result.moves]},
        "machine": {"python": platform.python_version(), "processor": platform.processor()
                    or platform.machine(), "system": platform.platform()},
    }
    if figures:
        summary["robustness"] = {"model": models[0], "errors_pct": list(ERRORS_PCT),
                                 **{k: v.tolist() for k, v in curves.items()}}
    # everything computed: write the folder (with the scenario as given, resolved: what
    # --overwrite recognises a flexlink folder by)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / RESOLVED_NAME).write_text(resolved_toml(resolved), encoding="utf-8")
    (out_dir / "optimized.toml").write_text(
        "# written by flexlink optimize: run it with flexlink run optimized.toml\n"
        + dump_toml(data), encoding="utf-8")
    np.savetxt(out_dir / "trajectory.csv", np.column_stack(list(columns.values())),
               delimiter=",", header=",".join(columns), comments="", fmt="%.10g")
    (out_dir / "summary.json").write_text(json_text(summary), encoding="utf-8")
    if pictures is not None and (figure_worker is None or not figure_worker.wait()):
        pictures.write(out_dir)
    return summary


def _figures(traces: dict[str, Any], curves: dict[str, Any], start: float, end: float,
             model: str, name: str | None, stiffening: bool) -> Any:
    """The figures' data (`figures.OptimizeFigures`) of the tip traces (`figures.Trace`) and
    robustness curves in ``model``: the moves from ``start`` to ``end`` s."""
    from .figures import OptimizeFigures

    text = _model_text(model, stiffening)
    return OptimizeFigures(
        traces=traces,
        move_start=start, move_end=end, residual_title=f"{name}: residual vibration ({text})",
        errors=[e / 100.0 for e in ERRORS_PCT], curves=curves, reference="cycloidal",
        robustness_title=text)


def _model_label(scenario: Any) -> str:
    return _model_text(scenario.settings.model, scenario.settings.geometric_stiffening)


def _model_text(model: str, stiffening: bool) -> str:
    if model == "nonlinear":
        return "nonlinear model"
    return f"first-order model {'with' if stiffening else 'without'} geometric stiffening"


def _design_text(summary: dict[str, Any]) -> str:
    factors = sorted({p["frequency_factor"] for p in summary["plants"]})
    stiff = {p["geometric_stiffening"] for p in summary["plants"]}
    spread = ("the nominal plant only" if factors == [1.0] else
              "plants at " + ", ".join(f"{f:g}" for f in factors) + " × every frequency")
    return spread + (", each with and without geometric stiffening" if len(stiff) == 2 else "")


def summary_text(summary: dict[str, Any], out_dir: Path) -> str:
    opt = summary["optimiser"]
    lines = [(f"flexlink optimize: {summary['scenario']}, {opt['iterations']} iterations, "
              f"{opt['evaluations']} evaluations of {len(summary['plants'])} plants on "
              f"{opt['workers']} processes, {opt['wall_time_s']:.1f} s"),
             f"designed for {_design_text(summary)}"]
    if opt.get("stopped_at_iteration_limit"):
        lines.append(f"warning: the optimiser {opt['message']}; more iterations "
                     "(--max-iterations) may lower the residual")
    for note in summary.get("plants_left_out", []):
        lines.append(f"note: {note}")
    for model, values in summary["residual_tip_deflection_m"].items():
        base = values["cycloidal"]
        name = _model_text(model, summary["geometric_stiffening"])
        lines.append(f"residual tip deflection after the move ({name}):")
        for label, value in values.items():
            if math.isnan(value):
                lines.append(f"  {label:<16} diverges in this model")
                continue
            ratio = f"  ({base / value:.3g}× smaller)" if label != "cycloidal" and value else ""
            lines.append(f"  {label:<16} {1e3 * value:.4g} mm{ratio}")
    for model, band in summary["robustness_band"].items():
        errors = band["errors_pct"]
        opt_mm = [1e3 * v for v in band["optimised_m"] if not math.isnan(v)]
        head = (f"robustness ({_model_text(model, summary['geometric_stiffening'])}), every "
                f"frequency {errors[0]:+g} … {errors[-1]:+g} %: ")
        if band["worst_ratio"] is None or not opt_mm:
            lines.append(head + "no residual to compare (the runs diverge)")
            continue
        lines.append(head + f"optimised {min(opt_mm):.3g} … {max(opt_mm):.3g} mm; cycloid ÷ "
                     f"optimised ≥ {band['worst_ratio']:.3g}× (least at "
                     f"{band['worst_at_pct']:+g} %)")
        lines.append("  " + ", ".join(
            f"{e:+g} %: " + ("diverges" if math.isnan(r) else f"{r:.3g}×")
            for e, r in zip(errors, band["ratio"], strict=True)))
    lines.append(f"files in {out_dir}: optimized.toml, trajectory.csv, summary.json, "
                 "scenario.resolved.toml"
                 + (", residual.png, robustness.png" if "robustness" in summary else ""))
    return "\n".join(lines)


__all__ = ["add_commands", "optimized_scenario_dict", "run_optimize", "write_outputs"]
