"""Trajectory optimisation of the paper arm's 90° / 80° manoeuvre in 1.2 s (issues 18, 27).

    python benchmarks/optimize.py [--robust PCT[,PCT…]] [--workers N]

For each design (default: the nominal one, --robust 0, and the default, --robust 10) runs
`flexlink.shaping.optimize_move` with the fixed seed and limits of `flexlink.shaping.paper`
and prints its wall time (numba's compilation excluded: one warm-up run first), the
iterations and runs, how it stopped, the continuous-time peaks, and the residual link-2 tip
deflection (peak over 2 s after the move) of the cycloidal, ZVD-shaped (same total duration)
and optimised moves with every frequency off by −10 … +10 % (EI scaled by (1 + error)²) in the
first-order model without stiffening (the paper's), with stiffening, and the nonlinear model,
with the machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))

import flexlink
from flexlink.scenario import load_scenario, paper_experiment_path
from flexlink.shaping import optimize_move
from flexlink.shaping.compare import cycloidal_version, residuals, shaped_version
from flexlink.shaping.paper import DURATION_S, LIMITS, SEED

ERRORS = (-0.10, -0.05, 0.0, 0.05, 0.10)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robust", default="0,10", metavar="PCT[,PCT…]")
    parser.add_argument("--workers", type=int)
    args = parser.parse_args()
    scenario = load_scenario(paper_experiment_path())
    flexlink.simulate(scenario, shapes=False)  # load the compiled loop
    print(f"flexlink {flexlink.__version__}, Python {platform.python_version()}, "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"{platform.platform()}")
    for pct in (float(v) for v in args.robust.split(",")):
        start = time.perf_counter()
        result = optimize_move(scenario, DURATION_S, LIMITS, seed=SEED, robust=pct / 100,
                               workers=args.workers)
        wall = time.perf_counter() - start
        print(f"\n--robust {pct:g}: optimize_move {wall:.1f} s wall, {result.iterations} "
              f"iterations, {result.evaluations} evaluations of {len(result.plants)} plants on "
              f"{result.workers} processes, seed {SEED}; {result.message}")
        print("peaks:", {k: [round(v, 4) for v in vals] for k, vals in result.peaks.items()})
        versions = {"cycloidal": cycloidal_version(result.scenario, result.moves),
                    "shaped (ZVD)": shaped_version(result.scenario, result.moves, "zvd")[0],
                    "optimised": result.scenario}
        for label, model, stiff in (("first order (paper's)", "first_order", False),
                                    ("first order, stiffened", "first_order", True),
                                    ("nonlinear", "nonlinear", False)):
            runs = {k: dataclasses.replace(v, settings=dataclasses.replace(
                v.settings, geometric_stiffening=stiff)) for k, v in versions.items()}
            peaks = residuals(runs, result.move_end, ERRORS, model)
            base = peaks["cycloidal"]
            print(f"{label}:")
            for k, values in peaks.items():
                print(f"  {k:<13} " + ", ".join(
                    f"{100 * e:+.0f} %: {1e3 * v:.3g} mm ({b / v:.3g}×)"
                    for e, v, b in zip(ERRORS, values, base, strict=True)))


if __name__ == "__main__":
    main()
