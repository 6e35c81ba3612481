"""Closed loops: flexlink's first-order and nonlinear models against the geometrically exact
FE model (Exudyn) on the two cases of tests/validation/test_closed_loops_exact.py (and
test_closed_loops_nonlinear_exact.py), in one run: CPU time of the whole ``simulate`` call
(median of ``--repeat`` runs after a warm-up, numba's compilation excluded; without the
animation's shapes, as benchmarks/slider_vs_fe.py, and the nonlinear default with them too)
and of Exudyn's solver on a ladder of meshes and steps. The finest (64 elements, steps
1.25e-5 s) is the reference; flexlink is compared with the cheapest rung whose deflection is
within 1% of the reference's peak (the "comparable" mesh). Errors: max |channel − reference|
/ reference peak of the deflection channel.

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
    from flexlink.scenario import resolve_scenario_dict, scenario_from_dict
    from tests.validation.exudyn_loops_reference import (
        simulate_four_bar_exudyn,
        simulate_slider_crank_exudyn,
    )
    from tests.validation.test_closed_loops import FOUR_BAR, L1, L2, L3, D, _four_bar_angles

    reference = (64, 1.25e-5)
    ladder = ((32, 2.5e-5), (32, 5e-5), (24, 5e-5), (16, 5e-5), (16, 1e-4), (8, 1e-4))

    def report(case: str, runs: dict, channel: str, fe: dict, key: str) -> None:
        ref = fe[reference][1][key]
        peak = np.abs(ref).max()
        print(f"{case}: Exudyn, elements, step, solver CPU s, error of peak against "
              f"{reference[0]} elements, {reference[1]:g} s ({fe[reference][0]:.2f} s)")
        chosen = reference
        for rung in ladder:
            cpu, out = fe[rung]
            err = np.abs(out[key] - ref).max() / peak
            print(f"  {rung[0]:3d} {rung[1]:8.2e} {cpu:6.2f} {err:8.2%}")
            if err < 0.01 and cpu < fe[chosen][0]:
                chosen = rung
        fe_cpu = fe[chosen][0]
        print(f"  comparable (cheapest within 1%): {chosen[0]} elements, {chosen[1]:g} s, "
              f"{fe_cpu:.2f} s")
        for model, (cpu, run) in runs.items():
            err = np.abs(run[channel] - ref).max() / peak
            print(f"  {model}: {cpu:.4f} s CPU, {fe_cpu / cpu:.1f}x the comparable mesh; "
                  f"error {err:.2%} of peak")

    def both(d: dict) -> dict:
        """Both models at the scenario's default rtol, the nonlinear one also at rtol 1e-5
        and 1e-3, and its default with the shapes."""
        out = {}
        for label, model, rtol, shapes in (
                ("first_order", "first_order", None, False),
                ("nonlinear", "nonlinear", None, False),
                ("nonlinear, with shapes", "nonlinear", None, True),
                ("nonlinear, rtol 1e-5", "nonlinear", 1e-5, False),
                ("nonlinear, rtol 1e-3", "nonlinear", 1e-3, False)):
            e = copy.deepcopy(d)
            e["simulation"]["model"] = model
            if rtol is not None:
                e["simulation"]["rtol"] = rtol
            scenario = scenario_from_dict(e)
            out[label] = _cpu(lambda scenario=scenario, shapes=shapes:
                              simulate(scenario, shapes=shapes), args.repeat)
        return out

    def exudyn(fn) -> dict:
        out = {}
        for elements, dt in (reference, *ladder):
            start = time.process_time()
            ref = fn(elements, dt)
            out[(elements, dt)] = (time.process_time() - start, ref)
        return out

    d = resolve_scenario_dict(ROOT / "examples" / "slider_crank.toml")
    scenario = scenario_from_dict(d)
    rod = scenario.chain.links[1]
    s = scenario.settings
    runs = both(d)
    fe = exudyn(lambda elements, dt: simulate_slider_crank_exudyn(
        scenario.chain.links[0].length, rod, scenario.chain.joints[0],
        2e11 * math.pi * 0.003**2, s.t_end, s.dt_out, elements=elements, dt=dt))
    report("slider-crank, rod midpoint", runs, "rod_mid", fe, "mid_deflection")

    d = copy.deepcopy(FOUR_BAR)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 2.0,
                     "modes": 4}
    d["joints"][0] = {"motion": [{"profile": "spinup", "to_rate_deg_s": 1200.0, "start": 0.0,
                                  "duration": 0.2, "from_deg": 90.0}]}
    d["sensors"] = [{"name": "mid", "kind": "deflection", "link": "coupler", "x": L2 / 2}]
    d["simulation"] = {"name": "four-bar", "t_end": 0.6, "dt_out": 5e-4}
    four_bar = scenario_from_dict(d)
    runs = both(d)
    fe = exudyn(lambda elements, dt: simulate_four_bar_exudyn(
        L1, Link("coupler", L2, 0.3, 2.0), Link("rocker", L3, 2.0, math.inf), (D, 0.0),
        four_bar.chain.joints[0], _four_bar_angles(math.radians(90)), 1e6, 0.6, 5e-4,
        elements=elements, dt=dt))
    report("four-bar, coupler midpoint", runs, "mid", fe, "mid_deflection")

if __name__ == "__main__":
    main()
