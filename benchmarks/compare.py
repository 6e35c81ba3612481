"""Speed and accuracy of flexlink against the alternatives: one table from one run.

    python benchmarks/compare.py                  # everything (Exudyn rows need '.[reference]')
    python benchmarks/compare.py --quick          # skip the slow rows (10-link solve_ivp, Exudyn)

Rows, all for the same arm and manoeuvre as the built-in paper experiment (5 s simulated,
output every 1 ms) unless marked:

- flexlink: the Lawson integrator (the default) and fourth-order Magnus, each at the default
  tolerance and a loose one;
- scipy ``solve_ivp`` (DOP853) of the same first-order equations with a Python right-hand side;
- Exudyn, geometrically exact 2D beams (Simo–Reissner elements, generalized-α), on the coarsest
  mesh that agrees with its own finest mesh within 1% of each signal's peak (undamped: the
  reference model has no modal damping);
- a chain of ten links with 4 modes each (3 s simulated, one timed run);
- a batch of paper-experiment variants (E of link 1 and both move durations drawn at random,
  as in ``benchmarks/batch.py``) on all cores through ``flexlink.sweep``.

Every row runs in a fresh process: wall time is the median of ``--repeat`` runs after a warm-up
(start-up excluded; the batch row is one sweep, worker start-up included), peak memory is that
process's maximum resident set size (for the batch: the largest of sweep and worker processes). Accuracy is the
largest difference of any signal from the row's reference, relative to that signal's peak:
for the first-order solvers a Magnus run at rtol 1e-10 (1e-9 for ten links; the DOP853 row, a
different method on the same equations, checks that reference), for Exudyn its finest mesh.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import platform
import resource
import statistics
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the Exudyn model lives with the validation tests

PAPER_SIGNALS = ("link1_tip_acceleration", "link2_tip_deflection", "pzt", "link2_root_strain")
EXUDYN_MESHES = (4, 8, 12, 16, 24, 32, 48)  # 64 stalls in Newton (step collapse, > 5 min)


# -- runs (each executed in a child process) ---------------------------------------------------
def _peak_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _paper(**settings: Any):
    from flexlink import load_paper_experiment

    paper = load_paper_experiment()
    return replace(paper, settings=replace(paper.settings, **settings))


def _ten_links(**settings: Any):
    from flexlink.model import Chain, Link, PointSensor, Scenario, SimulationSettings
    from flexlink.motion import Cycloidal

    # A 10 m arm of ten 1 m links (first clamped frequencies 2.5 Hz, like the paper's link 2).
    links = tuple(Link(f"link{k + 1}", 1.0, 0.5, 10.0, damping_ratio=0.01, modes=4)
                  for k in range(10))
    joints = tuple(Cycloidal(0.0, 5.0, 0.2, 2.0) for _ in range(10))
    sensors = tuple(PointSensor(f"tip{k + 1}", "deflection", k, 1.0) for k in range(10))
    base = SimulationSettings(t_end=3.0, dt_out=1e-3, geometric_stiffening=True)
    return Scenario(Chain(links, joints), sensors, replace(base, **settings), name="ten-links")


def _flexlink_row(build: str, repeat: int, settings: dict[str, Any]) -> dict[str, Any]:
    from flexlink import simulate

    scenario = {"paper": _paper, "ten": _ten_links}[build](**settings)
    result = simulate(scenario)  # warm-up: imports, caches
    walls = []
    for _ in range(repeat):
        start = time.perf_counter()
        result = simulate(scenario)
        walls.append(time.perf_counter() - start)
    names = [s.name for s in scenario.sensors]
    return {"wall": statistics.median(walls), "t_end": scenario.settings.t_end,
            "signals": {n: result[n] for n in names}, "peak_mb": _peak_mb()}


def _exudyn_row(elements: int, repeat: int, duration: float) -> dict[str, Any]:
    from flexlink.motion import Cycloidal
    from tests.helpers import paper_links
    from tests.validation.exudyn_reference import simulate_chain_exudyn

    links = paper_links(damping=False)
    motions = [Cycloidal(0.0, 90.0, 0.5, duration), Cycloidal(90.0, 170.0, 0.5, duration)]
    walls, out = [], {}
    for _ in range(repeat):
        out = simulate_chain_exudyn(links, motions, 5.0, 1e-3, elements,
                                    slope_positions={1: [0.01, 0.04]})
        walls.append(out["wall_time_s"])
    signals = {"link1_tip_acceleration": np.asarray(out["tip_acceleration_normal"][0]),
               "link2_tip_deflection": np.asarray(out["tip_deflection"][1]),
               "pzt_slope_difference": np.asarray(out["slope"][1][0.04])
               - np.asarray(out["slope"][1][0.01])}
    return {"wall": statistics.median(walls), "t_end": 5.0, "signals": signals,
            "peak_mb": _peak_mb(), "coordinates": out["coordinates"]}


def _batch_row(cases: int) -> dict[str, Any]:
    from batch import RANDOM  # benchmarks/batch.py: E of link 1 and both move durations

    from flexlink import sweep
    from flexlink.scenario import paper_experiment_path

    start = time.perf_counter()
    data = sweep(paper_experiment_path(), random=RANDOM, samples=cases, seed=1)
    wall = time.perf_counter() - start
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0
    return {"wall": wall, "t_end": 5.0 * cases, "peak_mb": max(_peak_mb(), children),
            "failed": int(data.attrs["cases_failed"])}


def _in_child(fn: Callable[..., dict[str, Any]], *args: Any,
              timeout: float | None = None) -> dict[str, Any] | None:
    """fn(*args) in a fresh process; None if it takes longer than ``timeout`` seconds."""
    with multiprocessing.get_context("spawn").Pool(1) as pool:
        try:
            return pool.apply_async(fn, args).get(timeout)
        except multiprocessing.TimeoutError:
            return None


# -- table ---------------------------------------------------------------------------------------
def _error(signals: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> float:
    return max(float(np.abs(signals[n] - reference[n]).max() / np.abs(reference[n]).max())
               for n in reference)


def _row(label: str, run: dict[str, Any], error: float | str, runs: int = 1) -> str:
    wall = run["wall"]
    err = error if isinstance(error, str) else f"{100 * error:.3g} %"
    return (f"| {label} | {wall:.3g} | {run['t_end'] / wall:.3g} | {runs / wall:.3g} | "
            f"{run['peak_mb']:.0f} | {err} |")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per row (median)")
    parser.add_argument("--quick", action="store_true", help="skip the slow rows")
    parser.add_argument("--batch", type=int, default=1000, help="cases in the batch row")
    args = parser.parse_args()
    rows: list[str] = []
    summary: list[str] = []

    def add(label: str, run: dict[str, Any], error: float | str, runs: int = 1) -> None:
        rows.append(_row(label, run, error, runs))
        print(rows[-1], flush=True)

    print(f"# {platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numpy {np.__version__}")
    print("| case | wall [s] | real-time factor | runs/s | peak memory [MB] | error / peak |")
    print("|---|---|---|---|---|---|")
    ref = _in_child(_flexlink_row, "paper", 1, {"method": "magnus", "rtol": 1e-10, "atol": 1e-16})
    fastest: dict[str, Any] | None = None
    for label, settings in [("paper: flexlink Lawson, rtol 1e-6 (default)", {}),
                            ("paper: flexlink Lawson, rtol 1e-3", {"rtol": 1e-3}),
                            ("paper: flexlink Magnus, rtol 1e-6", {"method": "magnus"}),
                            ("paper: flexlink Magnus, rtol 1e-3",
                             {"method": "magnus", "rtol": 1e-3})]:
        run = _in_child(_flexlink_row, "paper", args.repeat, settings)
        add(label, run, _error(run["signals"], ref["signals"]))
        if fastest is None or run["wall"] < fastest["wall"]:
            fastest = run
    run = _in_child(_flexlink_row, "paper", 1, {"method": "DOP853", "rtol": 1e-6, "atol": 1e-12})
    add("paper: scipy solve_ivp DOP853, rtol 1e-6, Python RHS", run,
        _error(run["signals"], ref["signals"]))

    if not args.quick:
        try:
            import exudyn  # noqa: F401
        except ImportError:
            print("(Exudyn not installed: pip install -e '.[reference]' for its rows)")
        else:
            # One run stalled once for over 9 minutes (alone it takes 1 s): bound every row.
            meshes = {e: _in_child(_exudyn_row, e, args.repeat, 1.0, timeout=600)
                      for e in EXUDYN_MESHES}
            finest = meshes[EXUDYN_MESHES[-1]]["signals"]
            chosen = next((e for e in EXUDYN_MESHES if meshes[e] is not None
                           and _error(meshes[e]["signals"], finest) <= 0.01), None)
            if chosen is not None and fastest is not None:
                summary.append(f"fastest flexlink paper run against Exudyn's coarsest mesh "
                               f"within 1%: {meshes[chosen]['wall'] / fastest['wall']:.0f}×")
            for e in EXUDYN_MESHES[:-1]:
                label = f"paper arm (undamped): Exudyn, {e} elements/link"
                if meshes[e] is None:
                    print(f"| {label} | timed out after 600 s | | | | |", flush=True)
                    rows.append(f"| {label} | timed out | | | | |")
                    continue
                add(label + (" ← coarsest within 1%" if e == chosen else ""),
                    meshes[e], _error(meshes[e]["signals"], finest))

    ten_ref = _in_child(_flexlink_row, "ten", 1, {"method": "magnus", "rtol": 1e-9})
    for label, settings in [("10 links × 4 modes: flexlink Lawson, rtol 1e-6", {}),
                            ("10 links × 4 modes: flexlink Magnus, rtol 1e-6",
                             {"method": "magnus"})]:
        run = _in_child(_flexlink_row, "ten", args.repeat, settings)
        add(label, run, _error(run["signals"], ten_ref["signals"]))
    if not args.quick:
        run = _in_child(_flexlink_row, "ten", 1, {"method": "DOP853", "rtol": 1e-6, "atol": 1e-12})
        add("10 links × 4 modes: scipy solve_ivp DOP853, rtol 1e-6", run,
            _error(run["signals"], ten_ref["signals"]))

    # Not a Pool child: the sweep starts worker processes, which a daemonic process may not.
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn")) as pool:
        run = pool.submit(_batch_row, args.batch).result()
    add(f"batch of {args.batch} paper variants, all cores ({run['failed']} failed)", run, "-",
        runs=args.batch)
    for line in summary:
        print(line)

if __name__ == "__main__":
    main()
