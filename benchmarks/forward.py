"""Forward dynamics (driven joints, free base): before and after the compiled integrator, one
table from one run (issue 14).

    python benchmarks/forward.py              # every row (the "before" rows take minutes)
    python benchmarks/forward.py --quick      # skip the "before" row of the torque replay

Rows, for each case — ``examples/paper_servo.toml`` (3 s), ``examples/satellite_slew.toml``
(30 s), the torque replay of the paper arm (tests/validation/test_forward.py, 1.6 s, output
every 0.5 ms) and ``examples/vertical_arm.toml`` (3 s in gravity, started in equilibrium):

- before: scipy ``solve_ivp`` (DOP853) at the scenario's tolerance over the numpy
  ForwardSystem (the path before issue 14);
- solve_ivp (DOP853) at the scenario's tolerance over the compiled kernel;
- after: the default, the compiled Radau IIA integrator (`solvers/radau.py`).

Wall time is ``simulate`` (the whole run: integration and channel values) in a fresh
process, the median of ``--repeat`` runs after a warm-up run (numba's compilation, cached on
disk, excluded). Error: the largest difference of any channel from the reference — solve_ivp
DOP853 at rtol 1e-10 over the compiled kernel (the kernel equals the numpy equations to
round-off, tests/unit/test_forward_kernel.py) — relative to that channel's peak.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import platform
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CASES = ("paper_servo", "satellite_slew", "torque_replay", "vertical_arm")


def _scenario(case: str) -> Any:
    import flexlink
    from flexlink.model import Chain, PointSensor, Scenario, SimulationSettings, Table, TorqueDrive
    from flexlink.motion import Cycloidal

    if case != "torque_replay":
        return flexlink.load_scenario(ROOT / "examples" / f"{case}.toml")
    sys.path.insert(0, str(ROOT))
    from tests.helpers import paper_links

    # As tests/validation/test_forward.py: the torques a prescribed run reported, replayed.
    links = paper_links(3)
    sensors = (PointSensor("acc", "acceleration", 0, 1.37),
               PointSensor("deflection", "deflection", 1, 0.6))
    settings = SimulationSettings(t_end=1.6, dt_out=5e-4, rtol=1e-8, geometric_stiffening=True)
    prescribed = Scenario(Chain(links, (Cycloidal(0, 90, 0.1, 1.0), Cycloidal(90, 170, 0.1, 1.0))),
                          sensors, settings)
    first = flexlink.simulate(prescribed)
    drives = tuple(TorqueDrive(Table(tuple(first.time), tuple(first[f"joint{k + 1}_torque"])),
                               initial_angle=math.radians(a)) for k, a in enumerate((0, 90)))
    return dataclasses.replace(prescribed, chain=Chain(links, drives),
                               settings=dataclasses.replace(settings, rtol=1e-6, atol=1e-9))


def _run(case: str, variant: str, repeat: int) -> dict[str, Any]:
    """One row in this (child) process: wall times and the channels of the last run."""
    import flexlink
    import flexlink.simulation.forward as path
    from flexlink.solvers.forward import integrate_forward

    scenario = _scenario(case)
    settings = scenario.settings
    if variant == "reference":
        settings = dataclasses.replace(settings, method="DOP853", rtol=1e-10, atol=1e-12)
    elif variant in ("before", "ivp_compiled"):
        settings = dataclasses.replace(settings, method="DOP853")
    if variant == "before":
        def numpy_rhs(*args: Any, **kwargs: Any) -> Any:
            return integrate_forward(*args, **kwargs, compiled=False)
        path.integrate_forward = numpy_rhs  # type: ignore[assignment]
    scenario = dataclasses.replace(scenario, settings=settings)
    short = dataclasses.replace(scenario, settings=dataclasses.replace(settings, t_end=0.05))
    flexlink.simulate(short)  # warm-up: imports, numba's cache
    walls = []
    for _ in range(repeat):
        start = time.perf_counter()
        results = flexlink.simulate(scenario)
        walls.append(time.perf_counter() - start)
    return {"wall": statistics.median(walls), "t_end": settings.t_end,
            "method": results.metadata.get("method"),
            "steps": results.metadata.get("steps_per_output_interval", results.metadata.get("steps", "")),
            "signals": {n: np.asarray(results[n]) for n in results.names}}


def _in_child(*args: Any) -> dict[str, Any]:
    with ProcessPoolExecutor(1) as pool:
        return pool.submit(_run, *args).result()


def _error(signals: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> tuple[float, str]:
    """Largest difference / peak over the channels, and the channel where it is."""
    worst, name = 0.0, ""
    for key, ref in reference.items():
        peak = np.abs(ref).max()
        # A channel that stays at round-off (the free hub's centre of mass: 1e-17 m) has no
        # relative error to speak of.
        if key not in signals or peak < 1e-12 or not np.all(np.isfinite(ref)):
            continue
        err = float(np.abs(signals[key] - ref).max() / peak)
        if err > worst:
            worst, name = err, key
    return worst, name


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per row (median)")
    parser.add_argument("--quick", action="store_true",
                        help="skip the slowest 'before' row (torque replay, minutes)")
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=CASES)
    args = parser.parse_args()
    print(f"# {platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numpy {np.__version__}")
    print("| case | integrator | wall [s] | steps (per output or in all) | error / peak (channel) |")
    print("|---|---|---|---|---|")
    labels = {"before": "before: solve_ivp DOP853, numpy RHS",
              "ivp_compiled": "solve_ivp DOP853, compiled RHS",
              "after": "after: compiled default (Radau IIA)"}
    for case in args.cases:
        reference = _in_child(case, "reference", 1)
        for variant in ("before", "ivp_compiled", "after"):
            if variant == "before" and args.quick and case == "torque_replay":
                print(f"| {case} | {labels[variant]} | skipped (--quick) | | |", flush=True)
                continue
            run = _in_child(case, variant, 1 if variant == "before" else args.repeat)
            err, where = _error(run["signals"], reference["signals"])
            print(f"| {case} | {labels[variant]} | {run['wall']:.3g} | {run['steps']} | "
                  f"{err:.2g} ({where}) |", flush=True)


if __name__ == "__main__":
    main()
