"""The kernel build's cost: setup.py's build step (`flexlink._build_kernels.main`) on a fresh
copy of the package, with numba's own caches pointed at an empty folder.

    python benchmarks/build_kernels.py [--source .] [--workers 2] [--opt N] [--keep DIR]
        [--profile RUNS]

Prints the wall time of the build, the CPU seconds of each worker (the sum of its warm-up
runs, each with the run's CPU seconds, from the build's record ``_compiled/build.json``) and
of the last pass; on a loaded machine the CPU seconds are the figures to compare, the
longest worker plus the last pass is the wall time on an idle machine with one core per
worker. Each worker's runs are listed in the order it ran them, with the wall time at which
each started (s after the workers started). ``--profile prescribed,forward,...`` instead
runs those warm-up runs in this order in one process on an empty cache and lists the
functions numba compiled by their CPU seconds, exclusive of the functions compiled inside
them (numba's "numba:compile" events). ``--opt N`` sets numba's LLVM optimisation level (NUMBA_OPT) for the whole build (default:
numba's own, 3); ``--keep DIR`` keeps the built package as ``DIR/flexlink`` (its kernels in
``DIR/flexlink/_compiled``), to time the runs of kernels built that way with
``PYTHONPATH=DIR``.
The last line records the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

_PROFILE = r"""
import sys, time
from numba.core import event

stack, own, total = [], {}, {}


class Listener(event.Listener):
    def on_start(self, ev):
        stack.append([time.process_time(), 0.0])

    def on_end(self, ev):
        start, inner = stack.pop()
        spent = time.process_time() - start
        function = ev.data["dispatcher"].py_func
        key = (f"{function.__module__.split('.')[-1]}.{function.__qualname__}",
               str(ev.data["args"])[:50])
        own[key] = own.get(key, 0.0) + spent - inner
        total[key] = total.get(key, 0.0) + spent
        if stack:
            stack[-1][1] += spent


event.register("numba:compile", Listener())
from flexlink._build_kernels import run_warmups

for name in sys.argv[1].split(","):
    print(name, run_warmups([name])[name], flush=True)
print(f"compiling: {sum(own.values()):.1f} s of CPU; by function (own, with inner), "
      "types abridged:")
for key, spent in sorted(own.items(), key=lambda kv: -kv[1])[:40]:
    print(f"{spent:7.1f} {total[key]:7.1f}  {key[0]}  {key[1]}")
"""


_BUILD = ("import os, json; from flexlink._build_kernels import build; "
          "print(json.dumps(build(workers=int(os.environ['FLEXLINK_BENCH_WORKERS']))))")


def fresh_copy(source: Path, into: Path) -> Path:
    """A copy of `source`'s package folder ``src/flexlink`` without compiled files."""
    target = into / "flexlink"
    shutil.copytree(source / "src" / "flexlink", target,
                    ignore=shutil.ignore_patterns("__pycache__", "_compiled"))
    return target


def environment(package_parent: Path, cache: Path) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("NUMBA_", "PYTHONPATH", "FLEXLINK_"))}
    env.update(PYTHONPATH=str(package_parent), NUMBA_CACHE_DIR=str(cache))
    return env


def build(source: Path, workers: int, opt: int | None = None, keep: Path | None = None) -> None:
    with tempfile.TemporaryDirectory(prefix="flexlink-build-bench-") as tmp:
        package = fresh_copy(source, Path(tmp))
        env = environment(package.parent, Path(tmp) / "numba-cache")
        env["FLEXLINK_BENCH_WORKERS"] = str(workers)
        if opt is not None:
            env["NUMBA_OPT"] = str(opt)
        start = time.perf_counter()
        done = subprocess.run(
            [sys.executable, "-c", _BUILD],
            cwd=tmp, env=env, capture_output=True, text=True, check=False)
        wall = time.perf_counter() - start
        if done.returncode != 0:
            raise RuntimeError(done.stderr)
        record = json.loads(done.stdout.strip().splitlines()[-1])
        if keep is not None:
            shutil.rmtree(keep / package.name, ignore_errors=True)
            shutil.copytree(package, keep / package.name,
                            ignore=shutil.ignore_patterns("__pycache__"))
    per_worker: dict[int, list[tuple[float, str, float]]] = {}
    last_pass = 0.0
    compiles = [(name, run.get("compile") or {}) for name, run in record["runs"].items()]
    compiles += list(record.get("build_only", {}).items())
    for name, compiled in compiles:
        per_worker.setdefault(compiled.get("worker", -1), []).append(
            (compiled.get("start", 0.0), name, compiled.get("cpu", 0.0)))
    for run in record["runs"].values():
        last_pass += run["last_pass"]["cpu"]
    level = "numba's default" if opt is None else opt
    print(f"build: {wall:.1f} s wall, {record['workers']} workers, NUMBA_OPT {level}")
    total = last_pass
    for worker, runs in sorted(per_worker.items()):
        cpu = sum(c for _, _, c in runs)
        total += cpu
        listed = ", ".join(f"{n} {c:.1f} (at {s:.0f} s)" for s, n, c in sorted(runs))
        print(f"worker {worker}: {cpu:.1f} s of CPU ({listed})")
    print(f"last pass: {last_pass:.1f} s of CPU; all runs {total:.1f} s of CPU")
    print(f"failed: {record['failed']}, uncompiled: {record['uncompiled']}")


def profile(source: Path, runs: str) -> None:
    with tempfile.TemporaryDirectory(prefix="flexlink-build-bench-") as tmp:
        package = fresh_copy(source, Path(tmp))
        env = environment(package.parent, Path(tmp) / "numba-cache")
        subprocess.run([sys.executable, "-c", _PROFILE, runs], cwd=tmp, env=env, check=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=Path(__file__).resolve().parents[1])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--profile", default=None,
                        help="comma-separated warm-up runs to profile in one process")
    parser.add_argument("--opt", type=int, default=None, choices=range(4),
                        help="numba's LLVM optimisation level (NUMBA_OPT) for the build")
    parser.add_argument("--keep", type=Path, default=None,
                        help="keep the built package in this folder")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    if args.profile:
        profile(args.source.resolve(), args.profile)
    else:
        build(args.source.resolve(), args.workers, args.opt, args.keep)
    print(f"source {args.source}; {platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} cores, Python {platform.python_version()}; load average "
          f"{load:.2f} before, {os.getloadavg()[0]:.2f} after")


if __name__ == "__main__":
    main()
