"""Trajectory optimisation of the paper arm's 90° / 80° manoeuvre in 1.2 s (issue 18).

    python benchmarks/optimize.py [--robust PCT] [--workers N]

Runs `flexlink.shaping.optimize_move` with the fixed seed and limits of
`flexlink.shaping.paper` and prints its wall time (numba's compilation excluded: one warm-up
run first), the iterations and runs, and the residual link-2 tip deflection (peak over 2 s
after the move) of the cycloidal, ZVD-shaped (same total duration) and optimised moves in
the first-order (paper's) and nonlinear models, with the machine.
"""

from __future__ import annotations

import argparse
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import flexlink
from flexlink.scenario import load_scenario, paper_experiment_path
from flexlink.shaping import optimize_move
from flexlink.shaping.compare import cycloidal_version, run_residual, shaped_version
from flexlink.shaping.paper import DURATION_S, LIMITS, SEED


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robust", type=float, default=0.0, metavar="PCT")
    parser.add_argument("--workers", type=int)
    args = parser.parse_args()
    scenario = load_scenario(paper_experiment_path())
    flexlink.simulate(scenario, shapes=False)  # load the compiled loop
    start = time.perf_counter()
    result = optimize_move(scenario, DURATION_S, LIMITS, seed=SEED, robust=args.robust / 100,
                           workers=args.workers)
    wall = time.perf_counter() - start
    print(f"flexlink {flexlink.__version__}, Python {platform.python_version()}, "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"{platform.platform()}")
    print(f"optimize_move: {wall:.1f} s wall, {result.iterations} iterations, "
          f"{result.evaluations} runs on {result.workers} processes, seed {SEED}, "
          f"robust ±{args.robust:g} %, {result.message}")
    print("peaks:", {k: [round(v, 4) for v in vals] for k, vals in result.peaks.items()})
    versions = {"cycloidal": cycloidal_version(result.scenario, result.moves),
                "shaped (ZVD)": shaped_version(result.scenario, result.moves, "zvd")[0],
                "optimised": result.scenario}
    for model in ("first_order", "nonlinear"):
        peaks = {k: run_residual(v, result.move_end, model)[1] for k, v in versions.items()}
        base = peaks["cycloidal"]
        print(f"{model}: " + ", ".join(f"{k} {1e3 * v:.4g} mm ({base / v:.3g}×)"
                                       for k, v in peaks.items()))


if __name__ == "__main__":
    main()
