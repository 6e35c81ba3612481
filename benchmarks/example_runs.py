"""CPU time of ``simulate`` on examples, one row each: the median of ``--repeat`` runs after a
first run (numba's compilation or cache loading excluded), with the largest state value as
a check that two versions compute the same run.

    PYTHONPATH=src python benchmarks/example_runs.py [--examples paper_servo four_bar ...]
        [--repeat 7]

CPU seconds (this process) rather than wall time: the figures to compare on a loaded machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

import flexlink
from flexlink.simulation import simulate

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def cpu_ms(name: str, repeat: int) -> tuple[float, float]:
    """(median CPU ms of `simulate`, the largest |value| of any channel) of one example."""
    scenario = flexlink.load_scenario(EXAMPLES / f"{name}.toml")
    results = simulate(scenario, shapes=False)
    times = []
    for _ in range(repeat):
        start = time.process_time()
        results = simulate(scenario, shapes=False)
        times.append(1e3 * (time.process_time() - start))
    peak = max(float(np.nanmax(np.abs(np.asarray(results[c], dtype=float))))
               for c in results.channels)
    return statistics.median(times), peak


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--examples", nargs="+",
                        default=["paper_servo", "four_bar", "slider_crank"])
    parser.add_argument("--repeat", type=int, default=7)
    args = parser.parse_args()
    load = os.getloadavg()[0]
    for name in args.examples:
        ms, peak = cpu_ms(name, args.repeat)
        print(f"{name:<20} {ms:8.1f} ms of CPU (median of {args.repeat})  largest channel "
              f"value {peak:.12g}")
    print(f"flexlink from {Path(flexlink.__file__).parent}; "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores; load "
          f"average {load:.2f} before, {os.getloadavg()[0]:.2f} after")


if __name__ == "__main__":
    main()
