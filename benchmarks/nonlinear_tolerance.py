"""The nonlinear model's own error against its time-integration error, per rtol: what the
default tolerance of `model = "nonlinear"` rests on (docs/nonlinear.md §4).

    python benchmarks/nonlinear_tolerance.py [--cache DIR] [--rtol 1e-3 1e-4 1e-5 1e-6]

Cases (4 modes per link, undamped, 3–8 s), each against a converged geometrically exact FE
model (Exudyn, 64 elements per link, generalized-α without numerical damping, dt 0.25 ms):

- ``light_beam``: a 1 m beam (0.5 kg/m, EI = 8 N·m²) on a hub turned 90° by a cycloidal
  move in 0.64 s, 3 s simulated: 39% tip deflection (prescribed joint);
- ``paper_fast``: the paper's arm, β₁ 0→90°, β₂ 90→170° in 0.5 s (the stored 64-element
  solution of tests/validation; link 2 bends past 90°);
- ``hub_beam_large``, ``free_hub_large``: the driven cases of tests/validation/
  forward_fe_cases.py (bang-bang torque on a pinned hub; bang-bang moment on a free hub).

Model error: max |signal − FE| / peak of the FE signal of the nonlinear model integrated at
rtol 1e-9 (its integration error is then negligible). Integration error at each rtol:
max |signal − signal at rtol 1e-9| / peak. CPU time of the whole ``simulate`` call (process
time, median of 3 after a warm-up). Signals: the tip deflection (and the paper arm's link-1
accelerometer, link-2 tip and PZT slope difference; the hub angle of the driven cases).
``--cache DIR`` keeps the FE solutions as .npz files between runs.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the tests' Exudyn helpers and cases

from flexlink import simulate
from flexlink.model import Chain, Link, PointSensor, Scenario, SimulationSettings
from flexlink.motion import Cycloidal
from tests.helpers import paper_links
from tests.validation.forward_fe_cases import (
    CASES,
    exudyn_signals,
    flexlink_scenario,
    flexlink_signals,
)

TIGHT = 1e-9
LIGHT_BEAM = Link("beam", 1.0, 0.5, 8.0, modes=4, damping_ratio=0.0, thickness=0.005)
LIGHT_MOVE = Cycloidal(0.0, 90.0, 0.0, 0.64)
PAPER_SENSORS = (PointSensor("acc", "acceleration", 0, 1.37),
                 PointSensor("w1", "deflection", 0, 1.37), PointSensor("w2", "deflection", 1, 0.6),
                 PointSensor("s_start", "slope", 1, 0.01), PointSensor("s_end", "slope", 1, 0.04))


def light_beam(rtol: float) -> Scenario:
    """The light-beam case at ``rtol``."""
    return Scenario(Chain((LIGHT_BEAM,), (LIGHT_MOVE,)),
                    (PointSensor("tip", "deflection", 0, 1.0),),
                    SimulationSettings(3.0, 0.002, model="nonlinear", rtol=rtol),
                    name="light_beam")


def light_beam_fe(elements: int = 64, dt: float = 2.5e-4) -> tuple[dict[str, np.ndarray], float]:
    """The light beam in Exudyn: {"tip": …} and the solver's wall time (s)."""
    from tests.validation.exudyn_reference import simulate_chain_exudyn

    out = simulate_chain_exudyn([LIGHT_BEAM], [LIGHT_MOVE], 3.0, 0.002, elements, dt=dt,
                                spectral_radius=1.0)
    return {"tip": np.asarray(out["tip_deflection"][0])}, float(out["wall_time_s"])


def _paper(rtol: float) -> Scenario:
    motions = (Cycloidal(0.0, 90.0, 0.5, 0.5), Cycloidal(90.0, 170.0, 0.5, 0.5))
    return Scenario(Chain(paper_links(modes=4, damping=False), motions), PAPER_SENSORS,
                    SimulationSettings(3.0, 0.002, model="nonlinear", rtol=rtol),
                    name="paper_fast")


def _paper_signals(r) -> dict[str, np.ndarray]:
    return {"acc": r["acc"], "w1": r["w1"], "w2": r["w2"], "piezo": r["s_end"] - r["s_start"]}


def _driven(name: str):
    case = CASES[name]

    def scenario(rtol: float) -> Scenario:
        s = flexlink_scenario(case, 4, rtol=rtol)
        return replace(s, settings=replace(s.settings, model="nonlinear"))

    return scenario, lambda r: {k: v for k, v in flexlink_signals(case, r).items()
                                if k in ("tip", "hub_angle")}


def _reference(name: str, cache: Path | None) -> dict[str, np.ndarray]:
    path = cache / f"{name}_fe64.npz" if cache else None
    if path is not None and path.exists():
        return dict(np.load(path))
    if name == "light_beam":
        ref, _ = light_beam_fe()
    elif name == "paper_fast":
        data = np.load(ROOT / "tests" / "validation" / "data" / "exudyn_paper_arm_D0.5.npz")
        ref = {k: data[k] for k in ("acc", "w1", "w2", "piezo")}
    else:
        signals, _ = exudyn_signals(CASES[name], 64, 2.5e-4)
        ref = {k: v for k, v in signals.items() if k in ("tip", "hub_angle")}
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, **ref)
    return ref


def _error(ours: dict[str, np.ndarray], ref: dict[str, np.ndarray]) -> float:
    return max(float(np.abs(np.asarray(ours[k]) - ref[k]).max() / np.abs(ref[k]).max())
               for k in ref)


def _cpu(scenario: Scenario, repeat: int = 3):
    simulate(scenario)  # warm-up: compiled kernels loaded
    times, results = [], None
    for _ in range(repeat):
        start = time.process_time()
        results = simulate(scenario)
        times.append(time.process_time() - start)
    return statistics.median(times), results


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", type=Path, default=None)
    parser.add_argument("--rtol", type=float, nargs="*", default=[1e-3, 1e-4, 1e-5, 1e-6])
    args = parser.parse_args()
    cases = {"light_beam": (light_beam, lambda r: {"tip": r["tip"]}),
             "paper_fast": (_paper, _paper_signals),
             "hub_beam_large": _driven("hub_beam_large"),
             "free_hub_large": _driven("free_hub_large")}
    print("| case | model error (vs FE) | " + " | ".join(
        f"rtol {r:g}: integration error, CPU [s], estimate" for r in args.rtol) + " |")
    print("|---|---|" + "---|" * len(args.rtol))
    for name, (scenario, signals) in cases.items():
        ref = _reference(name, args.cache)
        tight = signals(simulate(scenario(TIGHT)))
        cells = []
        for rtol in args.rtol:
            cpu, r = _cpu(scenario(rtol))
            cells.append(f"{_error(signals(r), tight):.1e}, {cpu:.3f}, "
                         f"{r.metadata['error_estimate']:.1e}")
        print(f"| {name} | {_error(tight, ref):.1e} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
