"""The nonlinear model against the geometrically exact finite-element model (Exudyn), side by side:
wall time and accuracy on the paper's arm (undamped; β₁ 0→90°, β₂ 90→170° cycloidal over D
seconds; 3 s simulated, output every 2 ms), or on a light beam at 39% tip deflection.

    python benchmarks/nonlinear_vs_fe.py [--duration 2.0] [--repeat 3]
    python benchmarks/nonlinear_vs_fe.py --case light_beam

``light_beam``: a 1 m beam (0.5 kg/m, EI = 8 N·m², 4 modes, undamped) turned 90° by a
cycloidal move in 0.64 s, 3 s simulated; its tip deflects 39% of its length. Reference: Exudyn
with 64 elements, dt 0.25 ms; signal: the tip deflection. flexlink runs with its default
settings (adaptive steps at the nonlinear model's default rtol) and at other tolerances; its
CPU time (process time of ``simulate``) is printed beside the wall time.

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
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the tests' Exudyn helpers
sys.path.insert(0, str(ROOT / "benchmarks"))  # the light beam of nonlinear_tolerance.py

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


def _flexlink_rtol(duration: float, modes: int, rtol: float | None) -> tuple[float, dict]:
    links = paper_links(modes=modes, damping=False)
    scenario = Scenario(Chain(links, tuple(_motions(duration))), SENSORS,
                        SimulationSettings(T_END, DT_OUT, model="nonlinear", rtol=rtol))
    start = time.perf_counter()
    r = simulate(scenario)
    wall = time.perf_counter() - start
    return wall, {"acc": r["acc"], "w1": r["w1"], "w2": r["w2"],
                  "piezo": r["s_end"] - r["s_start"]}


def _light_flexlink(rtol: float | None, step: float | None = None) -> tuple[float, dict]:
    from nonlinear_tolerance import light_beam

    scenario = light_beam(1e-5)
    scenario = replace(scenario, settings=replace(scenario.settings, rtol=rtol, step=step))
    start = time.perf_counter()
    r = simulate(scenario)
    return time.perf_counter() - start, {"tip": r["tip"]}


def _light_exudyn(elements: int, dt: float) -> tuple[float, dict]:
    from nonlinear_tolerance import light_beam_fe

    signals, wall = light_beam_fe(elements, dt)
    return wall, signals


def _timed(run, repeat: int) -> tuple[float, float, dict]:
    """Median wall time, median CPU time (s) and the signals of the last run."""
    run()  # warm-up (imports, compiled kernels)
    walls, cpus, signals = [], [], None
    for _ in range(repeat):
        cpu = time.process_time()
        wall, signals = run()
        walls.append(wall)
        cpus.append(time.process_time() - cpu)
    return statistics.median(walls), statistics.median(cpus), signals


def _light_beam(repeat: int) -> None:
    print("light beam, 90° in 0.64 s, 3 s simulated (39% tip deflection), reference Exudyn "
          "64 elements, dt 0.25 ms")
    _, reference = _light_exudyn(64, 2.5e-4)
    cases = {f"Exudyn FE, {e} elements, dt {dt * 1e3:g} ms": (lambda e=e, dt=dt:
                                                            _light_exudyn(e, dt))
             for e, dt in ((8, 2e-3), (16, 1e-3), (24, 1e-3), (32, 5e-4))}
    cases.update({
        "flexlink nonlinear, 4 modes, default settings": lambda: _light_flexlink(None),
        **{f"flexlink nonlinear, 4 modes, rtol {r:g}": (lambda r=r: _light_flexlink(r))
           for r in (1e-3, 1e-4, 1e-6)},
        "flexlink nonlinear, 4 modes, fixed step 5 ms": lambda: _light_flexlink(None, 5e-3),
    })
    _table(cases, reference, repeat, exudyn_once=True)


def _table(cases: dict, reference: dict, repeat: int, exudyn_once: bool = False) -> None:
    print(f"{'case':48s} {'wall [s]':>9s} {'CPU [s]':>8s}  "
          + "  ".join(f"{k:>7s}" for k in reference) + "   (error / peak)")
    for label, run in cases.items():
        try:
            if exudyn_once and label.startswith("Exudyn"):
                wall, signals = run()  # its solver's own wall time, one run
                cpu = float("nan")
            else:
                wall, cpu, signals = _timed(run, repeat)
        except RuntimeError as error:  # Exudyn's Newton fails on coarse meshes of the fast swing
            print(f"{label:48s}    failed: {type(error).__name__}")
            continue
        errors = [np.abs(signals[k] - reference[k]).max() / np.abs(reference[k]).max()
                  for k in reference]
        print(f"{label:48s} {wall:9.3f} {cpu:8.3f}  " + "  ".join(f"{e:7.2%}" for e in errors),
              flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=2.0, help="manoeuvre duration D, s")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--case", choices=("paper_arm", "light_beam"), default="paper_arm")
    args = parser.parse_args()
    print(f"{platform.machine()}, python {platform.python_version()}")
    if args.case == "light_beam":
        _light_beam(args.repeat)
        return
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
        "flexlink nonlinear, 4 modes, default settings": lambda: _flexlink_rtol(D, 4, None),
        "flexlink nonlinear, 4 modes, rtol 1e-6": lambda: _flexlink_rtol(D, 4, 1e-6),
    }
    print(f"paper arm, D = {D} s, {T_END} s simulated")
    _table(cases, reference, args.repeat)


if __name__ == "__main__":
    main()
