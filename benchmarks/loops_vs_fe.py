"""Closed loops: flexlink's first-order and nonlinear models against the geometrically exact
FE model (Exudyn) on the two cases of tests/validation/test_closed_loops_exact.py (and
test_closed_loops_nonlinear_exact.py), in one run: CPU time of the whole ``simulate`` call
(median of ``--repeat`` runs after a warm-up, numba's compilation excluded; without the
animation's shapes, as benchmarks/slider_vs_fe.py, and each model's default with them too)
and of Exudyn's solver on a ladder of meshes and steps. The finest (64 elements, steps
1.25e-5 s) is the reference; flexlink is compared with the cheapest rung whose deflection is
within 1% of the reference's peak (the "comparable" mesh). Errors: max |channel − reference|
/ reference peak of the deflection channel; "closure": the largest closure residual of the
run relative to the loop's size.

    python benchmarks/loops_vs_fe.py [--repeat 3]
    python benchmarks/loops_vs_fe.py --before /path/to/old/src   # an old tree's rows too
    python benchmarks/loops_vs_fe.py --cases four-bar            # one case

``--before`` is the ``src`` folder of another checkout (e.g. ``git archive <commit> src |
tar -x -C /tmp/old``): its rows (each model's default) run in a spawned process that
imports flexlink from there, this tree's in another, before the same Exudyn runs.
"""

from __future__ import annotations

import argparse
import copy
import math
import multiprocessing
import os
import platform
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from _timing import median_cpu, use_tree

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

REFERENCE = (64, 1.25e-5)
LADDER = ((32, 2.5e-5), (32, 5e-5), (24, 5e-5), (16, 5e-5), (16, 1e-4), (8, 1e-4))
# (label, model, rtol (None: the default), with the animation's shapes)
ROWS = (("first_order", "first_order", None, False),
        ("first_order, with shapes", "first_order", None, True),
        ("first_order, rtol 1e-5", "first_order", 1e-5, False),
        ("first_order, rtol 1e-3", "first_order", 1e-3, False),
        ("nonlinear", "nonlinear", None, False),
        ("nonlinear, with shapes", "nonlinear", None, True),
        ("nonlinear, rtol 1e-5", "nonlinear", 1e-5, False),
        ("nonlinear, rtol 1e-3", "nonlinear", 1e-3, False))
BEFORE_ROWS = ("first_order", "nonlinear")


def _slider_crank() -> dict:
    from flexlink.scenario import resolve_scenario_dict

    return resolve_scenario_dict(ROOT / "examples" / "slider_crank.toml")


def _four_bar() -> dict:
    from tests.validation.test_closed_loops import FOUR_BAR, L2

    d = copy.deepcopy(FOUR_BAR)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 2.0,
                     "modes": 4}
    d["joints"][0] = {"motion": [{"profile": "spinup", "to_rate_deg_s": 1200.0, "start": 0.0,
                                  "duration": 0.2, "from_deg": 90.0}]}
    d["sensors"] = [{"name": "mid", "kind": "deflection", "link": "coupler", "x": L2 / 2}]
    d["simulation"] = {"name": "four-bar", "t_end": 0.6, "dt_out": 5e-4}
    return d


CASES = {"slider-crank": (_slider_crank, "rod_mid"), "four-bar": (_four_bar, "mid")}


def _runs(case: str, labels: tuple[str, ...], repeat: int) -> dict[str, tuple]:
    """CPU (s), the deflection channel and the relative closure residual of each row."""
    from flexlink import simulate
    from flexlink.scenario import scenario_from_dict

    build, channel = CASES[case]
    d = build()
    out = {}
    for label, model, rtol, shapes in ROWS:
        if label not in labels:
            continue
        e = copy.deepcopy(d)
        e["simulation"]["model"] = model
        if rtol is not None:
            e["simulation"]["rtol"] = rtol
        scenario = scenario_from_dict(e)
        cpu, run = median_cpu(lambda scenario=scenario, shapes=shapes:
                              simulate(scenario, shapes=shapes), repeat)
        out[label] = (cpu, np.asarray(run[channel]),
                      float(run.metadata.get("closure_residual_relative", math.nan)))
    return out


def _child(src: str, *args: Any) -> Any:
    # spawned, not forked: a fork would inherit the flexlink this process has imported
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                             initializer=use_tree, initargs=(src,)) as pool:
        return pool.submit(_runs, *args).result()


def _exudyn(case: str) -> dict:
    """Exudyn's solver CPU (s) and output on the reference and every rung of the ladder."""
    from flexlink.model import Link
    from flexlink.scenario import scenario_from_dict
    from tests.validation.exudyn_loops_reference import (
        simulate_four_bar_exudyn,
        simulate_slider_crank_exudyn,
    )
    from tests.validation.test_closed_loops import L1, L2, L3, D, _four_bar_angles

    scenario = scenario_from_dict(CASES[case][0]())
    if case == "slider-crank":
        rod, s = scenario.chain.links[1], scenario.settings

        def fn(elements: int, dt: float) -> dict:
            return simulate_slider_crank_exudyn(
                scenario.chain.links[0].length, rod, scenario.chain.joints[0],
                2e11 * math.pi * 0.003**2, s.t_end, s.dt_out, elements=elements, dt=dt)
    else:
        def fn(elements: int, dt: float) -> dict:
            return simulate_four_bar_exudyn(
                L1, Link("coupler", L2, 0.3, 2.0), Link("rocker", L3, 2.0, math.inf), (D, 0.0),
                scenario.chain.joints[0], _four_bar_angles(math.radians(90)), 1e6, 0.6,
                5e-4, elements=elements, dt=dt)
    out = {}
    for elements, dt in (REFERENCE, *LADDER):
        start = time.process_time()
        result = fn(elements, dt)
        out[(elements, dt)] = (time.process_time() - start, result["mid_deflection"])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--before", help="src folder of the tree to compare with")
    parser.add_argument("--cases", nargs="+", choices=tuple(CASES), default=tuple(CASES))
    args = parser.parse_args()
    print(f"# {platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numpy {np.__version__}, load average {os.getloadavg()[0]:.1f}")
    for case in args.cases:
        runs = {}
        if args.before:
            before = _child(args.before, case, BEFORE_ROWS, args.repeat)
            runs.update({f"before: {k}": v for k, v in before.items()})
        runs.update(_child(str(ROOT / "src"), case, tuple(r[0] for r in ROWS), args.repeat))
        fe = _exudyn(case)
        ref = fe[REFERENCE][1]
        peak = np.abs(ref).max()
        print(f"{case}, midpoint deflection: Exudyn, elements, step, solver CPU s, error of "
              f"peak against {REFERENCE[0]} elements, {REFERENCE[1]:g} s "
              f"({fe[REFERENCE][0]:.2f} s)")
        chosen = REFERENCE
        for rung in LADDER:
            cpu, out = fe[rung]
            err = np.abs(out - ref).max() / peak
            print(f"  {rung[0]:3d} {rung[1]:8.2e} {cpu:6.2f} {err:8.2%}")
            if err < 0.01 and cpu < fe[chosen][0]:
                chosen = rung
        fe_cpu = fe[chosen][0]
        print(f"  comparable (cheapest within 1%): {chosen[0]} elements, {chosen[1]:g} s, "
              f"{fe_cpu:.2f} s")
        for label, (cpu, signal, closure) in runs.items():
            err = np.abs(signal - ref).max() / peak
            print(f"  {label}: {cpu:.4f} s CPU, {fe_cpu / cpu:.1f}x the comparable mesh; "
                  f"error {err:.2%} of peak; closure {closure:.1e} of the loop", flush=True)


if __name__ == "__main__":
    main()
