"""Start-up of the command line: whole `flexlink` commands timed in fresh processes.

    python benchmarks/startup.py [--runs 7] [--cold] [--baseline OTHER/src]

Each command runs ``--runs`` times in a new Python process (``time.perf_counter`` around
``subprocess.run``, the numba cache warm); prints the median, minimum and maximum wall time of
each, and the median CPU time (user + system) of the command's processes together: on a
machine whose cores are busy with other work the wall time of a command that spreads over two
processes approaches its CPU time. ``--cold`` also times the first run after installing: the numba cache of flexlink's
compiled loops is pointed at an empty folder (``NUMBA_CACHE_DIR``) for each of those runs, so
that every kernel the command needs is compiled again. ``--baseline`` times the same commands
of another source tree (its ``src`` folder, e.g. an earlier commit exported with ``git
archive``) run by run in alternation with this one, so that both see the same load, and
prints both.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time

COMMANDS = {
    "python -c pass": [sys.executable, "-c", "pass"],
    "flexlink --version": [sys.executable, "-m", "flexlink", "--version"],
    "run --paper (figures, report)": [sys.executable, "-m", "flexlink", "run", "--paper",
                                      "-o", "{out}", "--overwrite", "-q"],
    "run --paper --no-figures --no-report": [sys.executable, "-m", "flexlink", "run",
                                             "--paper", "-o", "{out}", "--overwrite", "-q",
                                             "--no-figures", "--no-report"],
}


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def time_command(argv: list[str], env: dict[str, str]) -> tuple[float, float]:
    """(wall, CPU) seconds of one run of the command (CPU of all its processes)."""
    cpu = _children_cpu()
    start = time.perf_counter()
    subprocess.run(argv, check=True, env=env, stdout=subprocess.DEVNULL)
    return time.perf_counter() - start, _children_cpu() - cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=7)
    parser.add_argument("--cold", action="store_true",
                        help="also time runs with an empty numba cache (compiles everything)")
    parser.add_argument("--baseline", metavar="SRC",
                        help="another source tree's src folder, timed in alternation")
    args = parser.parse_args()
    here = os.path.join(os.path.dirname(os.path.abspath(__file__)), os.pardir, "src")
    trees = {"": os.path.normpath(here)}
    if args.baseline:
        trees = {"baseline: ": os.path.abspath(args.baseline), "this tree: ": trees[""]}
    envs = {name: dict(os.environ, PYTHONPATH=os.pathsep.join(
        [src, *filter(None, [os.environ.get("PYTHONPATH")])])) for name, src in trees.items()}
    env = envs[next(reversed(envs))]
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "run")
        rows = []
        for label, argv in COMMANDS.items():
            argv = [a.replace("{out}", out) for a in argv]
            times: dict[str, list[tuple[float, float]]] = {name: [] for name in envs}
            for tree_env in envs.values():
                time_command(argv, tree_env)  # warm the file cache and numba's disk cache
            for _ in range(args.runs):
                for name, tree_env in envs.items():
                    times[name].append(time_command(argv, tree_env))
            rows.extend((name + label, times[name]) for name in envs)
        if args.cold:
            argv = [a.replace("{out}", out) for a in COMMANDS["run --paper (figures, report)"]]
            times = []
            for i in range(max(2, args.runs // 2)):
                cold_env = dict(env, NUMBA_CACHE_DIR=os.path.join(tmp, f"numba-cache-{i}"))
                times.append(time_command(argv, cold_env))
            rows.append(("run --paper, empty numba cache (first run)", times))
    width = max(len(label) for label, _ in rows)
    print(f"{'command':<{width}}  median [s]  min [s]  max [s]  CPU median [s]  runs")
    for label, runs in rows:
        wall = [w for w, _ in runs]
        cpu = statistics.median(c for _, c in runs)
        print(f"{label:<{width}}  {statistics.median(wall):10.3f}  {min(wall):7.3f}  "
              f"{max(wall):7.3f}  {cpu:14.3f}  {len(runs):4d}")
    print(f"load average before the last run: {os.getloadavg()[0]:.2f} on "
          f"{os.cpu_count()} cores")


if __name__ == "__main__":
    main()
