"""Single-run speed and accuracy of the paper experiment: flexlink's Magnus integrator against
scipy's solve_ivp (DOP853) on the same equations with a per-step Python right-hand side.

    python benchmarks/single_run.py [--repeat 3]

Prints one table: wall time (median of the repeats, after a warm-up run), real-time factor
(simulated seconds per wall second) and the error of each signal relative to its peak, against
a DOP853 reference at rtol 1e-11.
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
from dataclasses import replace

import numpy as np

from flexlink import load_paper_experiment, simulate


def _timed(scenario, repeat: int):
    simulate(scenario)  # warm-up: imports, caches
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = simulate(scenario)
        times.append(time.perf_counter() - start)
    return statistics.median(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    paper = load_paper_experiment()
    sensors = [s.name for s in paper.sensors]
    ref_settings = replace(paper.settings, method="DOP853", rtol=1e-11, atol=1e-14)
    reference = simulate(replace(paper, settings=ref_settings))

    cases = {
        "flexlink magnus rtol=1e-6 (default)": paper.settings,
        "flexlink magnus rtol=1e-4": replace(paper.settings, rtol=1e-4),
        "scipy DOP853 rtol=1e-6": replace(paper.settings, method="DOP853", rtol=1e-6, atol=1e-12),
        "scipy RK45 rtol=1e-6": replace(paper.settings, method="RK45", rtol=1e-6, atol=1e-12),
    }
    print(f"paper experiment, t_end = {paper.settings.t_end} s, "
          f"{platform.processor() or platform.machine()}, python {platform.python_version()}")
    print(f"{'method':40s} {'wall [s]':>9s} {'real-time x':>12s} {'max err/peak':>13s}")
    for label, settings in cases.items():
        wall, result = _timed(replace(paper, settings=settings), args.repeat)
        err = max(np.abs(result[n] - reference[n]).max() / np.abs(reference[n]).max()
                  for n in sensors)
        print(f"{label:40s} {wall:9.3f} {paper.settings.t_end / wall:12.1f} {err:13.2e}")


if __name__ == "__main__":
    main()
