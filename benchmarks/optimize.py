"""Trajectory optimisation of the paper arm's 90° / 80° manoeuvre in 1.2 s (issues 18, 27).

    python benchmarks/optimize.py [--robust PCT[,PCT…]] [--workers N] [--fe]

For each design (default: the nominal one, --robust 0, and the default, --robust 10) runs
`flexlink.shaping.optimize_move` with the fixed seed and limits of `flexlink.shaping.paper`
and prints its wall time (numba's compilation excluded: one warm-up run first), the
iterations and runs, how it stopped, the continuous-time peaks, and the residual link-2 tip
deflection (peak over 2 s after the move) of the cycloidal, ZVD-shaped (same total duration)
and optimised moves with every frequency off by −10 … +10 % (EI scaled by (1 + error)²) in the
first-order model without stiffening (the paper's), with stiffening, and the nonlinear model,
with the machine. ``--fe`` adds the same residuals in an independent geometrically exact
finite-element model (Exudyn, 8 beam elements per link, undamped:
tests/validation/exudyn_reference.py; `pip install 'flexlink[reference]'`) with every EI
scaled by 0.81, 0.9, 1, 1.1 and 1.21.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

import flexlink
from flexlink.scenario import load_scenario, paper_experiment_path
from flexlink.shaping import optimize_move
from flexlink.shaping.compare import cycloidal_version, residuals, shaped_version
from flexlink.shaping.paper import DURATION_S, LIMITS, SEED

ERRORS = (-0.10, -0.05, 0.0, 0.05, 0.10)
FE_EI_SCALES = (0.81, 0.9, 1.0, 1.1, 1.21)


def fe_residuals(versions: dict, move_end: float) -> None:
    """Peak |link-2 tip deflection| over 2 s after the move in the Exudyn reference."""
    import numpy as np

    sys.path.insert(0, str(ROOT))
    from tests.validation.exudyn_reference import simulate_chain_exudyn

    print("finite elements (Exudyn, 8 elements per link, undamped), EI scaled by:")
    base = {}
    for label, scenario in versions.items():
        values = []
        for scale in FE_EI_SCALES:
            links = [dataclasses.replace(link, EI=link.EI * scale)
                     for link in scenario.chain.links]
            run = simulate_chain_exudyn(links, list(scenario.chain.joints), move_end + 2.0,
                                        0.002, 8)
            after = run["t"] >= move_end - 1e-9
            values.append(float(np.abs(run["tip_deflection"][-1][after]).max()))
        base.setdefault("cycloidal", values)
        print(f"  {label:<13} " + ", ".join(
            f"×{s:g}: {1e3 * v:.3g} mm ({b / v:.3g}×)"
            for s, v, b in zip(FE_EI_SCALES, values, base["cycloidal"], strict=True)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robust", default="0,10", metavar="PCT[,PCT…]")
    parser.add_argument("--workers", type=int)
    parser.add_argument("--fe", action="store_true", help="also the Exudyn reference")
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
        if args.fe:
            fe_residuals({k: versions[k] for k in ("cycloidal", "optimised")}, result.move_end)


if __name__ == "__main__":
    main()
