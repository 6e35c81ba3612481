"""The nonlinear model against the geometrically exact finite-element model (Exudyn), side by side:
wall time and accuracy on the paper's arm (undamped; β₁ 0→90°, β₂ 90→170° cycloidal over D
seconds; 3 s simulated, output every 2 ms).

    python benchmarks/nonlinear_vs_fe.py [--duration 2.0] [--repeat 3]

Needs Exudyn (`pip install '.[reference]'`). The reference is the stored 64-element solution
where there is one (D = 0.5 s), else a fine Exudyn run (48 elements per link, dt 0.25 ms, no
numerical damping); every case is then timed (median of the repeats after a
warm-up) and its error reported as max |signal − reference| / peak of the reference, for the
link-1 tip accelerometer, both tip deflections and the PZT slope difference. Exudyn's wall time
is its solver only (model set-up excluded); flexlink's is the whole `simulate` call (model
set-up, integration, sensors, results).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the tests' Exudyn helpers

from flexlink import simulate
from flexlink.model import Chain, PointSensor, Scenario, SimulationSettings
from flexlink.motion import Cycloidal
from tests.helpers import paper_links
from tests.validation.exudyn_reference import simulate_chain_exudyn

T_END, DT_OUT = 3.0, 0.002
SENSORS = (PointSensor("acc", "acceleration", 0, 1.37), PointSensor("w1", "deflection", 0, 1.37),
           PointSensor("w2", "deflection", 1, 0.6),
           PointSensor("s_start", "slope", 1, 0.01), PointSensor("s_end", "slope", 1, 0.04))


def _motions(duration: float):
    return [Cycloidal(0.0, 90.0, 0.5, duration), Cycloidal(90.0, 170.0, 0.5, duration)]


def _exudyn(duration: float, elements: int, dt: float, rho: float = 1.0) -> tuple[float, dict]:
    out = simulate_chain_exudyn(paper_links(damping=False), _motions(duration), T_END, DT_OUT,
                                elements, dt=dt, spectral_radius=rho,
                                slope_positions={1: [0.01, 0.04]})
    signals = {"acc": out["tip_acceleration_normal"][0], "w1": out["tip_deflection"][0],
               "w2": out["tip_deflection"][1],
               "piezo": np.asarray(out["slope"][1][0.04]) - np.asarray(out["slope"][1][0.01])}
    return out["wall_time_s"], {k: np.asarray(v) for k, v in signals.items()}


def _flexlink(duration: float, modes: int, step: float) -> tuple[float, dict]:
    links = paper_links(modes=modes, damping=False)
    scenario = Scenario(Chain(links, tuple(_motions(duration))), SENSORS,
                        SimulationSettings(T_END, DT_OUT, model="nonlinear", step=step))
    start = time.perf_counter()
    r = simulate(scenario)
    wall = time.perf_counter() - start
    return wall, {"acc": r["acc"], "w1": r["w1"], "w2": r["w2"],
                  "piezo": r["s_end"] - r["s_start"]}


def _timed(run, repeat: int) -> tuple[float, dict]:
    run()  # warm-up (imports, compiled kernels)
    results = [run() for _ in range(repeat)]
    return statistics.median(r[0] for r in results), results[-1][1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=2.0, help="manoeuvre duration D, s")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    D = args.duration
    stored = ROOT / "tests" / "validation" / "data" / f"exudyn_paper_arm_D{D:g}.npz"
    if stored.exists():  # a converged 64-element solution (tests/validation/data/README.md)
        data = np.load(stored)
        reference = {k: data[k] for k in ("acc", "w1", "w2", "piezo")}
    else:
        _, reference = _exudyn(D, 48, 2.5e-4)
    cases = {
        "Exudyn FE, 8 elements/link, dt 2 ms": lambda: _exudyn(D, 8, 2e-3),
        "Exudyn FE, 12 elements/link, dt 2 ms": lambda: _exudyn(D, 12, 2e-3),
        "Exudyn FE, 16 elements/link, dt 2 ms": lambda: _exudyn(D, 16, 2e-3),
        "Exudyn FE, 16 elements/link, dt 1 ms": lambda: _exudyn(D, 16, 1e-3),
        "Exudyn FE, 32 elements/link, dt 0.5 ms": lambda: _exudyn(D, 32, 5e-4),
        "Exudyn FE, 48 elements/link, dt 0.25 ms": lambda: _exudyn(D, 48, 2.5e-4),
        "flexlink nonlinear, 3 modes, step 20 ms": lambda: _flexlink(D, 3, 0.02),
        "flexlink nonlinear, 4 modes, step 20 ms": lambda: _flexlink(D, 4, 0.02),
        "flexlink nonlinear, 4 modes, step 10 ms": lambda: _flexlink(D, 4, 0.01),
        "flexlink nonlinear, 4 modes, step 5 ms": lambda: _flexlink(D, 4, 0.005),
        "flexlink nonlinear, 4 modes, step 2.5 ms": lambda: _flexlink(D, 4, 0.0025),
        "flexlink nonlinear, 8 modes, step 5 ms": lambda: _flexlink(D, 8, 0.005),
        "flexlink nonlinear, 8 modes, step 2.5 ms": lambda: _flexlink(D, 8, 0.0025),
    }
    print(f"paper arm, D = {D} s, {T_END} s simulated, {platform.machine()}, "
          f"python {platform.python_version()}")
    print(f"{'case':42s} {'wall [s]':>9s}  " + "  ".join(f"{k:>7s}" for k in reference)
          + "   (error / peak)")
    for label, run in cases.items():
        try:
            wall, signals = _timed(run, args.repeat)
        except RuntimeError as error:  # Exudyn's Newton fails on coarse meshes of the fast swing
            print(f"{label:42s}    failed: {type(error).__name__}")
            continue
        errors = [np.abs(signals[k] - reference[k]).max() / np.abs(reference[k]).max()
                  for k in reference]
        print(f"{label:42s} {wall:9.3f}  " + "  ".join(f"{e:7.2%}" for e in errors))


if __name__ == "__main__":
    main()
