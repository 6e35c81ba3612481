"""``flexlink linearize`` and ``flexlink modes``: argument definitions and handlers (cli.py only
registers them). Exit status: 0 written, 1 the run failed, 2 invalid input. The folder is
written atomically (results.writers.atomic_folder), with the resolved scenario beside the
files (so ``--overwrite`` recognises it later)."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..options import (
    NonFiniteResult,
    OptionError,
    check_finite,
    check_size,
    check_unique,
    positive_int,
)

PLANT_NPZ, PLANT_MAT, BODE_PNG, POLES_CSV = "plant.npz", "plant.mat", "bode.png", "modes.csv"
MODES_CSV, MODES_NPZ = "frequencies.csv", "modes.npz"
FREQUENCY_PNG, SHAPES_PNG = "frequencies.png", "shapes.png"


def add_commands(commands: Any, output: argparse.ArgumentParser) -> None:
    """Register ``linearize`` and ``modes`` on the subparsers ``commands``; ``output``: the
    shared -o/--overwrite/--no-figures/-q options."""
    lin = commands.add_parser(
        "linearize", parents=[output], help="linear state-space plant about a configuration "
                                             "or a time of a run",
        description="Linearise a scenario about a rest configuration (--at joint2=45) or a "
                    "time of its run (--at 1.2): A, B, C, D with named inputs (joint torques, "
                    "servo references, base force and moment, piezo voltages) and outputs "
                    f"(sensors, joints, base, tips) in DIR/{PLANT_NPZ} and DIR/{PLANT_MAT}, "
                    f"its modes in DIR/{POLES_CSV}, a Bode plot. docs/control.md.")
    _scenario_arguments(lin)
    lin.add_argument("--at", default="0", metavar="T|jointK=DEG,…",
                     help="a time in s of the run, or joint angles in degrees "
                          "(joint1=0,joint2=45; base_x, base_y in m, base_attitude in deg); "
                          "default: t = 0")
    lin.add_argument("--inputs", metavar="NAME,…", help="keep only these inputs")
    lin.add_argument("--outputs", metavar="NAME,…", help="keep only these outputs")
    lin.add_argument("--bode", metavar="INPUT:OUTPUT,…",
                     help="pairs in the Bode plot (default: the first input the scenario "
                          "acts through to up to four outputs it reaches, sensors first; "
                          "docs/control.md)")
    lin.set_defaults(handler=run_linearize)

    modes = commands.add_parser(
        "modes", parents=[output], help="frozen-time frequencies and mode shapes along a run "
                                         "or a grid of joint angles",
        description="Natural frequencies, damping ratios and mode shapes of the linearised "
                    "plant at times of the run (--times) or at rest over a grid of joint "
                    f"angles (--grid joint2=0:90:10). Writes {MODES_CSV}, {MODES_NPZ}, "
                    f"{FREQUENCY_PNG}, {SHAPES_PNG}. docs/control.md.")
    _scenario_arguments(modes)
    modes.add_argument("--times", metavar="T0:T1:DT|T,…",
                       help="times in s (default: 101 over the run)")
    modes.add_argument("--grid", metavar="jointK=A0:A1:DA|A,…",
                       help="joint angles in degrees (ends included); other joints at t = 0")
    modes.add_argument("--count", type=positive_int, default=None,
                       help="lowest modes kept (default all)")
    modes.set_defaults(handler=run_modes)


def _scenario_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("scenario", nargs="?", type=Path, metavar="SCENARIO.toml",
                        help="scenario file (default: the built-in paper experiment)")


def _fail(message: str, status: int = 2) -> int:
    print(message, file=sys.stderr)
    return status


def _names(text: str | None, option: str) -> list[str] | None:
    if text is None:
        return None
    names = [s.strip() for s in text.split(",") if s.strip()]
    check_unique(option, names)
    return names


def parse_at_text(text: str) -> float | dict[str, float]:
    """``1.5`` → 1.5 s; ``joint2=45,base_x=0.1`` → a mapping."""
    text = text.strip()
    if "=" not in text:
        try:
            return float(text)
        except ValueError:
            raise ValueError(f"--at {text!r}: a time in s or jointK=DEG,… pairs") from None
    out = {}
    for part in text.split(","):
        key, _sep, value = part.partition("=")
        try:
            out[key.strip()] = float(value)
        except ValueError:
            raise ValueError(f"--at: {part!r} is not NAME=NUMBER") from None
    check_unique("--at", [part.partition("=")[0].strip() for part in text.split(",")])
    return out


def parse_range(text: str, what: str) -> list[float]:
    """``0:90:10`` (ends included) or ``0,45,90``: finite numbers, at most
    `modes.MAX_POINTS` of them."""
    import math

    from .modes import MAX_POINTS

    try:
        if ":" in text:
            a, b, step = (float(v) for v in text.split(":"))
            if not (math.isfinite(a) and math.isfinite(b) and math.isfinite(step)
                    and step > 0 and b >= a):
                raise ValueError
            n = math.floor((b - a) / step + 1e-9) + 1
            check_size(f"{what} {text}", n, MAX_POINTS, "points",
                       f"a step of {(b - a) / max(MAX_POINTS - 1, 1):.3g} or coarser fits")
            return [a + i * step for i in range(n)]
        values = [float(v) for v in text.split(",") if v.strip()]
        if not values or not all(math.isfinite(v) for v in values):
            raise ValueError
        check_size(f"{what} {text[:40]}", len(values), MAX_POINTS, "points")
        return values
    except OptionError:
        raise
    except ValueError:
        raise ValueError(f"{what} {text!r}: give START:STOP:STEP (finite numbers, STOP ≥ START, "
                         "STEP > 0) or a list A,B,C") from None


def _load(args: argparse.Namespace) -> tuple[Any, dict[str, Any]]:
    from ..scenario import paper_experiment_path, resolve_scenario_dict, scenario_from_dict

    source = paper_experiment_path() if args.scenario is None else args.scenario
    resolved = resolve_scenario_dict(source)
    return scenario_from_dict(resolved, source=str(source)), resolved


def _default_dir(args: argparse.Namespace, suffix: str) -> Path:
    stem = "paper" if args.scenario is None else args.scenario.stem
    return args.output or Path(f"{stem}_{suffix}")


def run_linearize(args: argparse.Namespace) -> int:
    from ..results.writers import OutputFolderError, check_output_dir
    from ..scenario import ScenarioError
    from .convergence import estimate_for_command
    from .linearization import linearize

    try:
        scenario, resolved = _load(args)
        out = _default_dir(args, "plant")
        check_output_dir(out, args.overwrite)
        at = parse_at_text(args.at)
        inputs, outputs = _names(args.inputs, "--inputs"), _names(args.outputs, "--outputs")
        plant = linearize(scenario, at=at, inputs=inputs, outputs=outputs)
        check_finite({"A": plant.A, "B": plant.B, "C": plant.C, "D": plant.D},
                     f"the plant at {args.at}")
        pairs = _pairs(args.bode, plant, scenario)
        estimate, failure = estimate_for_command(scenario, at)
    except ScenarioError as exc:
        return _fail(str(exc))
    except NonFiniteResult as exc:
        return _fail(f"linearisation failed: {exc}", status=1)
    except (OutputFolderError, ValueError, OSError) as exc:
        return _fail(f"error: {exc}")
    except _run_failures() as exc:  # a failed run up to --at
        return _fail(f"linearisation failed: {exc}", status=1)
    with _folder(out, args, resolved) as partial:
        plant.to_npz(partial / PLANT_NPZ)
        plant.to_mat(partial / PLANT_MAT)
        _write_poles(plant, partial / POLES_CSV, estimate)
        if not args.no_figures and pairs:
            from .figures import bode_figure

            bode_figure(plant, pairs, partial / BODE_PNG)
    if not args.quiet:
        f, _zeta, _ = plant.modes()
        print(f"{len(plant.state_names)} states, inputs: {', '.join(plant.input_names) or '-'}; "
              f"{len(plant.output_names)} outputs; "
              + ("equilibrium" if plant.equilibrium else "frozen time (not an equilibrium)"))
        print("modes (Hz): " + ", ".join(f"{v:.4g}" for v in f[:8]))
        _print_estimate(estimate, failure)
    print(out)
    return 0


def _pairs(text: str | None, plant: Any, scenario: Any = None) -> list[tuple[str, str]]:
    if text is None:
        from .figures import default_pairs

        return default_pairs(plant, scenario)
    pairs = []
    for part in text.split(","):
        u, sep, y = part.partition(":")
        if not sep:
            raise ValueError(f"--bode: {part!r} is not INPUT:OUTPUT")
        plant.select([u.strip()], [y.strip()])  # names checked here
        pairs.append((u.strip(), y.strip()))
    return pairs


def _write_poles(plant: Any, path: Path, estimate: Any) -> None:
    """mode, frequency, damping ratio and the estimated relative error of the frequency in
    the assumed modes (control/convergence.py; nan where there is no estimate)."""
    import numpy as np

    f, zeta, _ = plant.modes()
    error = np.full(f.size, np.nan)
    if estimate is not None and estimate.error.size == f.size:
        error = estimate.error
    np.savetxt(path, np.column_stack([np.arange(1, f.size + 1), f, zeta, error]),
               delimiter=",", header="mode,frequency_Hz,damping_ratio,estimated_error",
               comments="", fmt=["%d", "%.10g", "%.6g", "%.3g"])


def _run_failures() -> tuple[type[BaseException], ...]:
    """How a run up to the operating point fails (imported only when one does); anything
    else is a defect, not caught."""
    import numpy as np

    from ..errors import SimulationError

    return (SimulationError, FloatingPointError, np.linalg.LinAlgError)


def _print_estimate(estimate: Any, failure: str | None) -> None:
    """The mode-convergence line and, where a frequency moves by 1% or more, its warning;
    the warning naming the estimate's failure (`estimate_for_command`)."""
    if failure is not None:
        print(f"warning: {failure}", file=sys.stderr)
    if estimate is None:
        return
    from .convergence import modes_line

    print(modes_line(estimate.metadata()))
    if estimate.warning():
        print(f"warning: {estimate.warning()}")


def _folder(out: Path, args: argparse.Namespace, resolved: dict[str, Any]) -> Any:
    from contextlib import contextmanager

    from ..results.folder import RESOLVED_NAME
    from ..results.writers import atomic_folder, resolved_toml

    @contextmanager
    def folder():  # type: ignore[no-untyped-def]
        with atomic_folder(out, args.overwrite) as partial:
            (partial / RESOLVED_NAME).write_text(resolved_toml(resolved), encoding="utf-8")
            yield partial

    return folder()


def run_modes(args: argparse.Namespace) -> int:
    from ..results.writers import OutputFolderError, check_output_dir
    from ..scenario import ScenarioError
    from .convergence import estimate_for_command
    from .modes import frozen_modes

    try:
        scenario, resolved = _load(args)
        out = _default_dir(args, "modes")
        check_output_dir(out, args.overwrite)
        if args.times and args.grid:
            raise ValueError("give --times or --grid, not both")
        times = parse_range(args.times, "--times") if args.times else None
        angles = None
        if args.grid:
            angles = {}
            parts = args.grid.split(";")
            check_unique("--grid", [part.partition("=")[0].strip() for part in parts])
            for part in parts:
                key, sep, text = part.partition("=")
                if not sep:
                    raise ValueError(f"--grid: {part!r} is not jointK=START:STOP:STEP")
                angles[key.strip()] = parse_range(text, f"--grid {key.strip()}")
        modes = frozen_modes(scenario, times=times, angles=angles, count=args.count)
        check_finite({"frequency": modes.frequency_hz, "damping ratio": modes.damping_ratio,
                      "mode shapes": modes.shapes}, "the frozen-time modes")
        estimate, failure = estimate_for_command(
            scenario, {k: v[0] for k, v in angles.items()} if angles else 0.0)
    except ScenarioError as exc:
        return _fail(str(exc))
    except NonFiniteResult as exc:
        return _fail(f"modes failed: {exc}", status=1)
    except (OutputFolderError, ValueError, OSError) as exc:
        return _fail(f"error: {exc}")
    except _run_failures() as exc:  # a failed run up to --times
        return _fail(f"modes failed: {exc}", status=1)
    import numpy as np

    with _folder(out, args, resolved) as partial:
        header, table = modes.table()
        np.savetxt(partial / MODES_CSV, table, delimiter=",", header=",".join(header),
                   comments="", fmt="%.10g")
        modes.to_npz(partial / MODES_NPZ, {"scenario": scenario.name})
        if not args.no_figures:
            from .figures import frequency_figure, shapes_figure

            frequency_figure(modes, partial / FREQUENCY_PNG)
            shapes_figure(modes, partial / SHAPES_PNG)
    if not args.quiet:
        print(f"{modes.values.size} points of {modes.coordinate}, "
              f"{modes.frequency_hz.shape[1]} modes; lowest: "
              f"{modes.frequency_hz[:, 0].min():.4g}–{modes.frequency_hz[:, 0].max():.4g} Hz")
        _print_estimate(estimate, failure)
    print(out)
    return 0
