"""Batch throughput: N variants of the paper experiment through `flexlink.sweep` on all cores.

    python benchmarks/batch.py [--cases 1000] [--workers N] [--channels a,b] [--scheduler ADDR]
                               [--vary model|numbers|sensors] [--summaries-only]
                               [--output FILE] [--before SRC [--vary model,numbers,sensors]]
    python benchmarks/batch.py --command [--cases 1000] [--workers N] [--repeat 2]
                               [--vary model,numbers,sensors] [--before SRC]

The variants draw link 1's unknown modulus E (20-40 GPa, the paper gives none) and both joint
move durations (0.8-1.2 s) at random (seed 1), variants advanced together 32 at a time, each
on its own coefficient table; ``--vary numbers`` draws the model's numbers but not its
motion's timing (E, link 1's tip mass, both damping ratios, the PZT amplifier's capacitance
and joint 1's end angle), variants that also share their tables' layout; ``--vary sensors`` draws the sensors' numbers instead (the
accelerometer's position 1.0-1.37 m, the PZT amplifier's capacitance 0.5-2 µF), cases that
share one motion. Prints one line per quantity: wall time of the
whole sweep (validation, worker start-up, runs, collection), runs per second, the sum of the
cases' own run times (their serial cost), the parallel efficiency, the median wall and CPU
time of one case (on a shared machine CPU time shows the work, wall time the wait), and the
peak resident memory of the sweep process and of its largest worker process.
``--machinery-only`` replaces every run by a stored result, which leaves the sweep's own
cost: the throughput it can reach at best. ``--summaries-only`` keeps per-case metrics (peak
and residual link-2 tip deflection, peak joint torques) instead of the histories: the memory
of a large study. ``--output FILE`` writes the sweep's file too (end to end, as the command
does). ``--before SRC`` runs the same benchmark first with the flexlink found in the source
folder SRC (another checkout's ``src``), then this one, each in a fresh process, and prints
the two side by side, adding each process's wall and CPU time from start to exit (start-up,
imports and writing included) and the 1-minute load average when it started; ``--vary
model,sensors`` then does so for both kinds of variant in one run. ``--command`` times the
``flexlink sweep`` command itself instead (the same variants and summaries, no histories,
a file written): each command's process CPU, its workers' included, and wall time from start
to exit, ``--repeat`` times each, alternating with the flexlink of ``--before`` if given.
"""

from __future__ import annotations

import argparse
import platform
import time

import numpy as np

from flexlink import sweep
from flexlink.batch.executors import available_cores
from flexlink.scenario import paper_experiment_path

RANDOM = {
    "links[0].E": "uniform:20e9:40e9",
    "joints[0].motion[0].duration": "uniform:0.8:1.2",
    "joints[1].motion[0].duration": "uniform:0.8:1.2",
}
NUMBERS = {
    "links[0].E": "uniform:20e9:40e9",
    "links[0].tip_mass": "uniform:0.1:0.16",
    "links[0].damping_ratio": "uniform:0.01:0.03",
    "links[1].damping_ratio": "uniform:0.005:0.02",
    "sensors[pzt].capacitance": "uniform:0.5e-6:2e-6",
    "joints[0].motion[0].to_deg": "uniform:80:100",
}
SENSORS = {
    "sensors[0].x": "uniform:1.0:1.37",
    "sensors[pzt].capacitance": "uniform:0.5e-6:2e-6",
}
SUMMARIES = ["peak:link2_tip_deflection", "residual:link2_tip_deflection:after=3",
             "peak:joint1_torque", "peak:joint2_torque"]
SENSOR_SUMMARIES = ["peak:link1_tip_acceleration", "residual:link1_tip_acceleration:after=3",
                    "peak:pzt", "rms:pzt"]


KINDS = {"model": (RANDOM, SUMMARIES, "model"), "numbers": (NUMBERS, SUMMARIES, "number"),
         "sensors": (SENSORS, SENSOR_SUMMARIES, "sensor")}


def peak_memory_mb() -> tuple[float, float]:
    """Peak resident memory (MB) of this process and of its largest finished child process
    (Linux and macOS report ru_maxrss in KiB and bytes)."""
    import resource
    import sys

    scale = 1.0 if sys.platform == "darwin" else 1024.0
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * scale / 1e6
    child = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * scale / 1e6
    return own, child


def cpu_seconds() -> float:
    """CPU time (user + system, s) of this process and its finished children: on a shared
    machine, the work a sweep did whatever the wait for a core."""
    import resource

    own = resource.getrusage(resource.RUSAGE_SELF)
    children = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + children.ru_utime + children.ru_stime


def machinery_only() -> None:
    """Replace every run by a stored result of the paper experiment: what is left is the
    sweep's own cost (validation, transfer, collection) — its throughput ceiling. Local
    workers are then forked so that they inherit the replacement."""
    import multiprocessing

    import flexlink.simulation
    from flexlink import load_paper_experiment
    from flexlink.batch import executors

    stored = flexlink.simulation.run_scenario(load_paper_experiment(), shapes=False)
    flexlink.simulation.run_scenario = lambda scenario, *args, **kwargs: stored
    executors._start_context = lambda: multiprocessing.get_context("fork")


def side_by_side(before_src: str, argv: list[str], varied: list[str]) -> None:
    """This benchmark run in fresh processes for each kind of variant in ``varied``, first
    with ``before_src`` and then with this checkout's flexlink on the path; their reports in
    two columns, with each process's own wall and CPU time from its start to its exit
    (interpreter start-up and imports included) and the machine's load when it started."""
    import os
    import resource
    import subprocess
    import sys
    from pathlib import Path

    here = str(Path(__file__).resolve().parents[1] / "src")
    cases = int(argv[argv.index("--cases") + 1]) if "--cases" in argv else 1000
    for vary in varied:
        reports = []
        for src in (before_src, here):
            env = {**os.environ, "PYTHONPATH": src}
            load = os.getloadavg()[0]
            usage = resource.getrusage(resource.RUSAGE_CHILDREN)
            started = time.perf_counter()
            done = subprocess.run([sys.executable, __file__, *argv, "--vary", vary], env=env,
                                  check=True, capture_output=True, text=True)
            wall = time.perf_counter() - started
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpu = (after.ru_utime + after.ru_stime) - (usage.ru_utime + usage.ru_stime)
            lines = done.stdout.splitlines()
            lines += [f"{'process wall, start to exit [s]':34s} {wall:.3f}",
                      f"{'runs per second, start to exit':34s} {cases / wall:.1f}",
                      f"{'process CPU, start to exit [s]':34s} {cpu:.3f}",
                      f"{'load average (1 min) at start':34s} {load:.1f}"]
            reports.append(lines)
        print(reports[1][0])
        print(f"{'':34s} {'before':>12s} {'after':>12s}   (before: {before_src})")
        for old, new in zip(reports[0][1:], reports[1][1:], strict=True):
            print(f"{new[:34]} {old[35:].strip():>12s} {new[35:].strip():>12s}")
        print()


def command_arguments(vary: str, cases: int, workers: int, output: str) -> list[str]:
    """``flexlink sweep`` of ``cases`` variants of the kind ``vary`` keeping its summaries."""
    random, summaries, _ = KINDS[vary]
    args = ["sweep", "--paper", "--samples", str(cases), "--seed", "1", "--no-histories",
            "--workers", str(workers), "-q", "--overwrite", "-o", output]
    for path, spec in random.items():
        args += ["--random", f"{path}={spec}"]
    for summary in summaries:
        args += ["--summary", summary]
    return args


def time_commands(sources: list[str], cases: int, workers: int, varied: list[str],
                  repeats: int) -> None:
    """The sweep command of each kind in ``varied`` run ``repeats`` times with the flexlink
    of each folder in ``sources`` in turn; each process's CPU (its workers' included) and
    wall time from start to exit, and the median CPU per source."""
    import os
    import resource
    import subprocess
    import sys
    import tempfile

    for vary in varied:
        cpu: dict[str, list[float]] = {src: [] for src in sources}
        with tempfile.TemporaryDirectory() as folder:
            output = os.path.join(folder, "sweep.nc")
            for repeat in range(repeats):
                for src in sources:
                    env = {**os.environ, "PYTHONPATH": src}
                    load = os.getloadavg()[0]
                    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
                    started = time.perf_counter()
                    subprocess.run([sys.executable, "-m", "flexlink",
                                    *command_arguments(vary, cases, workers, output)],
                                   env=env, check=True, capture_output=True)
                    wall = time.perf_counter() - started
                    after = resource.getrusage(resource.RUSAGE_CHILDREN)
                    cpu[src].append((after.ru_utime + after.ru_stime)
                                    - (usage.ru_utime + usage.ru_stime))
                    print(f"flexlink sweep, {cases} {KINDS[vary][2]} variants, {src}: "
                          f"CPU {cpu[src][-1]:.3f} s, wall {wall:.2f} s (load {load:.1f}, "
                          f"repeat {repeat + 1})", flush=True)
        for src, values in cpu.items():
            print(f"median CPU {float(np.median(values)):.3f} s ({vary}, {src})")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=None, help="default: every core")
    parser.add_argument("--channels", default=None, help="comma-separated (default: all)")
    parser.add_argument("--scheduler", default=None, help="Dask scheduler address")
    parser.add_argument("--vary", default="model",
                        help="draw link 1's E and the durations (model), the model's numbers "
                             "but not its timing (numbers) or the sensors' numbers (sensors); "
                             "with --before a comma-separated list, each side by side")
    parser.add_argument("--summaries-only", action="store_true",
                        help="keep summary metrics instead of the histories")
    parser.add_argument("--machinery-only", action="store_true",
                        help="replace the runs by a stored result: the sweep's own ceiling")
    parser.add_argument("--output", default=None, help="write the sweep's file (netCDF)")
    parser.add_argument("--checkpoint-interval", type=float, default=60.0, metavar="S",
                        help="with --output, rewrite the file every S s while running (as the "
                             "command does; a large S times the sweep without checkpoints)")
    parser.add_argument("--before", default=None, metavar="SRC",
                        help="also run with the flexlink in SRC and print both")
    parser.add_argument("--command", action="store_true",
                        help="time the flexlink sweep command (summaries, file) instead")
    parser.add_argument("--repeat", type=int, default=2, help="with --command: runs of each")
    args = parser.parse_args()
    if args.command:
        from pathlib import Path

        here = str(Path(__file__).resolve().parents[1] / "src")
        varied = args.vary.split(",")
        if not set(varied) <= set(KINDS):
            parser.error(f"--vary: some of {', '.join(KINDS)}, got {args.vary!r}")
        time_commands([*([args.before] if args.before else []), here], args.cases,
                      args.workers or available_cores(), varied, args.repeat)
        return
    if args.before:
        import sys

        argv = sys.argv[1:]
        for option in ("--before", "--vary"):
            if option in argv:
                at = argv.index(option)
                argv = argv[:at] + argv[at + 2:]
        varied = args.vary.split(",")
        if not set(varied) <= set(KINDS):
            parser.error(f"--vary: some of {', '.join(KINDS)}, got {args.vary!r}")
        side_by_side(args.before, argv, varied)
        return
    if args.vary not in KINDS:
        parser.error(f"--vary: one of {', '.join(KINDS)}, got {args.vary!r}")
    if args.machinery_only:
        machinery_only()
    channels = args.channels.split(",") if args.channels else None
    workers = args.workers or available_cores()

    import os

    load = os.getloadavg()[0]
    started = time.perf_counter()
    random, summaries, drawn = KINDS[args.vary]
    dataset = sweep(paper_experiment_path(), random=random, samples=args.cases, seed=1,
                    channels=channels, workers=None if args.scheduler else workers,
                    scheduler=args.scheduler, progress=True,
                    summaries=summaries if args.summaries_only else (),
                    histories=not args.summaries_only, output=args.output,
                    checkpoint_interval=args.checkpoint_interval)
    wall = time.perf_counter() - started
    own, child = peak_memory_mb()
    ok = int(dataset.attrs["cases_ok"])
    serial = float(dataset.wall_time.sum())
    where = args.scheduler or f"{workers} local worker processes"
    if args.machinery_only:
        where += " (machinery only: runs replaced by a stored result)"
    kept = (f"{len(SUMMARIES)} summary metrics" if args.summaries_only else
            f"{dataset.sizes['time']} samples of "
            f"{sum(1 for v in dataset.data_vars.values() if v.dims == ('case', 'time'))} "
            "channels")
    print(f"batch of {args.cases} paper-experiment {drawn} variants ({kept} a case) on {where}; "
          f"{platform.processor() or platform.machine()}, python {platform.python_version()}")
    print(f"{'cases ok / failed':34s} {ok} / {int(dataset.attrs['cases_failed'])}")
    print(f"{'wall time, whole sweep [s]':34s} {wall:.3f}")
    print(f"{'runs per second':34s} {args.cases / wall:.1f}")
    print(f"{'sum of case run times [s]':34s} {serial:.3f}")
    print(f"{'parallel efficiency':34s} {serial / (wall * workers):.2f}")
    print(f"{'median case run time [ms]':34s} {1e3 * float(np.median(dataset.wall_time)):.1f}")
    print(f"{'median case CPU time [ms]':34s} {1e3 * float(np.median(dataset.cpu_time)):.1f}")
    print(f"{'CPU time, sweep + workers [s]':34s} {cpu_seconds():.3f}")
    print(f"{'peak memory, sweep process [MB]':34s} {own:.0f}")
    print(f"{'peak memory, largest worker [MB]':34s} {child:.0f}")
    print(f"{'load average (1 min): start, end':34s} {load:.1f}, {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
