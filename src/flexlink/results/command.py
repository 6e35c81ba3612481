"""``flexlink animate`` and ``flexlink report``: argument definitions and handlers (cli.py only
registers them). Exit status: 0 written, 2 invalid input (not a run folder or sweep file, a
missing channel, a bad option); nothing is left half-written (files are written under a
temporary name and renamed).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from ..options import check_output_file, check_unique, check_writable
from .folder import ANIMATION_GIF, REPORT_NAME


def add_commands(commands: Any) -> None:
    """Register ``animate`` and ``report`` on the subparsers ``commands``."""
    animate = commands.add_parser(
        "animate", help="animate a run folder (or a sweep file) as GIF or MP4",
        description="Draw the moving, deforming arm of a run folder from its stored link "
                    "shapes (no simulation): joint frames, the tips' trails, the time, chosen "
                    "channels under the arm. A sweep file (.nc): its cases overlaid. "
                    "docs/animation.md.")
    animate.add_argument("source", type=Path, metavar="DIR|SWEEP.nc",
                         help="a run folder (flexlink run) or a sweep file (flexlink sweep)")
    animate.add_argument("-o", "--output", type=Path, metavar="FILE.gif|FILE.mp4",
                         help=f"file to write (default: DIR/{ANIMATION_GIF}, or "
                              "SWEEP_animation.gif beside a sweep file)")
    animate.add_argument("--channels", metavar="NAME,…",
                         help="channels drawn under the arm (default: the sensors, up to 4; "
                              "'' for none)")
    animate.add_argument("--magnify", type=float, default=1.0, metavar="M",
                         help="draw deflections M times larger (default 1: true scale; "
                              "stated on every frame otherwise)")
    animate.add_argument("--fps", type=float, default=20.0, help="frames per second (20)")
    animate.add_argument("--speed", type=float, default=1.0, metavar="S",
                         help="simulated seconds per second of video: 1 real time (default), "
                              "0.25 four times slower")
    animate.add_argument("--trail", type=float, default=1.0, metavar="SECONDS",
                         help="length of the tip trails (default 1 s; 0: none)")
    animate.set_defaults(handler=run_animate)

    report = commands.add_parser(
        "report", help="(re)write report.html of a run folder or a sweep file",
        description="Write the self-contained report page of a run folder (DIR/report.html) "
                    "or a sweep file (SWEEP.html beside it). flexlink run writes it already.")
    report.add_argument("source", type=Path, metavar="DIR|SWEEP.nc")
    report.add_argument("--animate", action="store_true",
                        help="also write the animation (a few seconds) and show it")
    report.set_defaults(handler=run_report)


def _fail(message: str) -> int:
    print(message, file=sys.stderr)
    return 2


def _input_errors() -> tuple[type[BaseException], ...]:
    from .arm_tracks import AnimationInputError
    from .reading import NotARunFolderError

    return AnimationInputError, NotARunFolderError, ValueError, OSError


def _check_sweep_file(source: Path) -> None:
    """ValueError for a sweep written as MATLAB (-o sweep.mat): readable, but not by these
    commands, which read the netCDF layout (a .mat file is not damaged)."""
    if source.suffix.lower() == ".mat":
        raise ValueError(f"{source} is a MATLAB file; animate and report read a sweep's "
                         "netCDF file: run the sweep again with -o NAME.nc")


def run_animate(args: argparse.Namespace) -> int:
    from .animation import animate, animate_sweep
    from .arm_tracks import AnimationInputError

    source: Path = args.source
    try:
        if source.is_file():
            _check_sweep_file(source)
            out = args.output or source.with_name(f"{source.stem}_animation.gif")
            check_output_file(out)
            animate_sweep(source, out, fps=args.fps, speed=args.speed, trail=args.trail)
        else:
            from .reading import read_run

            channels = None if args.channels is None else [
                c.strip() for c in args.channels.split(",") if c.strip()]
            check_unique("--channels", channels or [])
            out = args.output or source / ANIMATION_GIF
            if source.is_dir():
                check_output_file(out)
            results = read_run(source)
            if not results.shapes:
                raise AnimationInputError(
                    f"{source} holds no link shapes (the shape variables of results.nc, "
                    "which flexlink run writes): run the scenario again to animate it")
            animate(results, out, channels=channels, magnification=args.magnify,
                    fps=args.fps, speed=args.speed, trail=args.trail)
    except _input_errors() as exc:
        return _fail(f"error: {exc}")
    print(out)
    return 0


def run_report(args: argparse.Namespace) -> int:
    source: Path = args.source
    try:
        if source.is_file():
            from .report_html import write_sweep_report

            _check_sweep_file(source)
            check_writable(source.with_suffix(".html"))
            out = write_sweep_report(source, animation=args.animate)
        else:
            from .reading import read_run
            from .report_html import write_run_report

            if source.is_dir():
                check_writable(source / REPORT_NAME)

            results = read_run(source, shapes=args.animate)  # the page draws no shapes
            if args.animate:
                from .animation import animate, page_speed

                animate(results, source / ANIMATION_GIF, speed=page_speed(results.time))
            out = write_run_report(source, results)
    except _input_errors() as exc:
        return _fail(f"error: {exc}")
    print(out)
    return 0
