"""The first run after installing: ``pip install`` into a new virtual environment, then
``flexlink run --paper`` there, both timed.

    python benchmarks/install.py [--source .] [--kernels prescribed] [--runs 3]

Prints the wall and CPU time (user + system of all processes) of ``pip install SOURCE``
(FLEXLINK_BUILD_KERNELS=--kernels, setup.py), of the first ``flexlink run --paper`` and the
median of ``--runs`` later ones, and how many functions numba compiled in the first run
(``NUMBA_DEBUG_CACHE``'s "data saved" lines; 0 when the wheel carried every kernel it needs).
Packages come from pip's configured index and cache; a source older than the cache at
installation (no setup.py) gives the "before" row.
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
from pathlib import Path


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def timed(argv: list[str], env: dict[str, str], cwd: str) -> tuple[float, float, str]:
    """(wall s, CPU s of all its processes, standard output) of one command."""
    cpu = _children_cpu()
    start = time.perf_counter()
    done = subprocess.run(argv, check=True, env=env, cwd=cwd, capture_output=True, text=True)
    return time.perf_counter() - start, _children_cpu() - cpu, done.stdout


def measure(source: Path, kernels: str = "prescribed", runs: int = 3,
            ) -> list[tuple[str, float, float]]:
    """(what, wall s, CPU s): ``pip install source`` into a new virtual environment, the first
    ``flexlink run --paper`` there (with how many functions numba compiled) and the median of
    ``runs`` later ones."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("NUMBA_", "PYTHONPATH", "VIRTUAL_ENV"))}
    env["FLEXLINK_BUILD_KERNELS"] = kernels
    with tempfile.TemporaryDirectory() as tmp:
        venv = Path(tmp) / "venv"
        subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True)
        pip = [str(venv / "bin" / "python"), "-m", "pip", "install", "-q"]
        wall, cpu, _ = timed(pip + [str(source.resolve())], env, tmp)
        rows = [("pip install", wall, cpu)]
        run = [str(venv / "bin" / "flexlink"), "run", "--paper", "-o", "out", "-q",
               "--overwrite"]
        wall, cpu, log = timed(run, dict(env, NUMBA_DEBUG_CACHE="1"), tmp)
        compiled = sum("data saved" in line for line in log.splitlines())
        rows.append((f"first flexlink run --paper ({compiled} functions compiled)", wall, cpu))
        later = [timed(run, env, tmp) for _ in range(runs)]
        rows.append((f"later runs (median of {runs})",
                     statistics.median(w for w, _, _ in later),
                     statistics.median(c for _, c, _ in later)))
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=Path(__file__).resolve().parents[1])
    parser.add_argument("--kernels", default="prescribed",
                        help="FLEXLINK_BUILD_KERNELS for the build: all, none or run paths")
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    rows = measure(args.source, args.kernels, args.runs)
    width = max(len(label) for label, _, _ in rows)
    print(f"{'what':<{width}}  wall [s]  CPU [s]")
    for label, wall, cpu in rows:
        print(f"{label:<{width}}  {wall:8.2f}  {cpu:7.2f}")
    print(f"source {args.source}, kernels {args.kernels!r}; load average "
          f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
