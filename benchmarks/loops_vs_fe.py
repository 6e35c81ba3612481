"""Closed loops: flexlink's first-order model against the geometrically exact FE model
(Exudyn) on the two cases of tests/validation/test_closed_loops_exact.py, in one run: CPU
time of the whole ``simulate`` call (median of ``--repeat`` runs after a warm-up, numba's
compilation excluded) and of Exudyn's solver, and the error of flexlink's deflection
channel relative to its peak.

    python benchmarks/loops_vs_fe.py [--repeat 3]
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _cpu(fn, repeat: int) -> tuple[float, object]:
    fn()
    times, out = [], None
    for _ in range(repeat):
        start = time.process_time()
        out = fn()
        times.append(time.process_time() - start)
    return statistics.median(times), out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    import copy

    from flexlink import simulate
    from flexlink.model import Link
    from flexlink.scenario import load_scenario, scenario_from_dict
    from tests.validation.exudyn_loops_reference import (
        simulate_four_bar_exudyn,
        simulate_slider_crank_exudyn,
    )
    from tests.validation.test_closed_loops import FOUR_BAR, L1, L2, L3, D, _four_bar_angles

    scenario = load_scenario(ROOT / "examples" / "slider_crank.toml")
    rod = scenario.chain.links[1]
    s = scenario.settings
    cpu, run = _cpu(lambda: simulate(scenario), args.repeat)
    start = time.process_time()
    ref = simulate_slider_crank_exudyn(scenario.chain.links[0].length, rod,
                                       scenario.chain.joints[0], 2e11 * math.pi * 0.003**2,
                                       s.t_end, s.dt_out, elements=32, dt=2.5e-5)
    fe = time.process_time() - start
    err = np.abs(run["rod_mid"] - ref["mid_deflection"]).max() / np.abs(ref["mid_deflection"]).max()
    print(f"slider-crank: flexlink {cpu:.3f} s CPU, Exudyn {fe:.2f} s CPU ({fe / cpu:.0f}x), "
          f"rod midpoint error {err:.2%} of peak")

    d = copy.deepcopy(FOUR_BAR)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 2.0,
                     "modes": 4}
    d["joints"][0] = {"motion": [{"profile": "spinup", "to_rate_deg_s": 1200.0, "start": 0.0,
                                  "duration": 0.2, "from_deg": 90.0}]}
    d["sensors"] = [{"name": "mid", "kind": "deflection", "link": "coupler", "x": L2 / 2}]
    d["simulation"] = {"name": "four-bar", "t_end": 0.6, "dt_out": 5e-4}
    four_bar = scenario_from_dict(d)
    cpu, run = _cpu(lambda: simulate(four_bar), args.repeat)
    start = time.process_time()
    ref = simulate_four_bar_exudyn(L1, Link("coupler", L2, 0.3, 2.0),
                                   Link("rocker", L3, 2.0, math.inf), (D, 0.0),
                                   four_bar.chain.joints[0], _four_bar_angles(math.radians(90)),
                                   1e6, 0.6, 5e-4, elements=32, dt=2.5e-5)
    fe = time.process_time() - start
    err = np.abs(run["mid"] - ref["mid_deflection"]).max() / np.abs(ref["mid_deflection"]).max()
    print(f"four-bar: flexlink {cpu:.3f} s CPU, Exudyn {fe:.2f} s CPU ({fe / cpu:.0f}x), "
          f"coupler midpoint error {err:.2%} of peak")


if __name__ == "__main__":
    main()
