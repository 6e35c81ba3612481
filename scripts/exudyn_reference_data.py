"""Regenerate the stored geometrically exact references of the paper's arm
(tests/validation/data/exudyn_paper_arm_D*.npz) with Exudyn.

    python scripts/exudyn_reference_data.py --duration 0.5 --elements 64 --dt 2.5e-4

Undamped Table 1 arm, β₁ 0→90° and β₂ 90→170° cycloidal over D seconds, 3 s simulated, output
every 2 ms; Exudyn Simo–Reissner beams (tests/validation/exudyn_reference.py), generalized-α
with spectral radius 1 (no numerical damping). Stored arrays: t, acc (link-1 tip acceleration
along the deformed normal, m/s²), w1, w2 (tip deflections in the clamped frames, m), piezo
(slope difference ψ(0.04) − ψ(0.01) on link 2, rad). A run takes 5–30 min (64 elements).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from flexlink.motion import Cycloidal
from tests.helpers import paper_links
from tests.validation.exudyn_reference import simulate_chain_exudyn


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, required=True, help="manoeuvre duration D, s")
    parser.add_argument("--elements", type=int, default=64)
    parser.add_argument("--dt", type=float, default=2.5e-4)
    args = parser.parse_args()
    D = args.duration
    motions = [Cycloidal(0.0, 90.0, 0.5, D), Cycloidal(90.0, 170.0, 0.5, D)]
    out = simulate_chain_exudyn(paper_links(damping=False), motions, 3.0, 0.002, args.elements,
                                dt=args.dt, spectral_radius=1.0,
                                slope_positions={1: [0.01, 0.04]})
    data = {"t": out["t"], "acc": out["tip_acceleration_normal"][0],
            "w1": out["tip_deflection"][0], "w2": out["tip_deflection"][1],
            "piezo": np.asarray(out["slope"][1][0.04]) - np.asarray(out["slope"][1][0.01])}
    path = ROOT / "tests" / "validation" / "data" / f"exudyn_paper_arm_D{D:g}.npz"
    np.savez_compressed(path, **{k: np.asarray(v, dtype=float) for k, v in data.items()})
    print(f"{path}: {args.elements} elements per link, dt {args.dt} s, "
          f"{out['wall_time_s']:.0f} s wall")


if __name__ == "__main__":
    main()
