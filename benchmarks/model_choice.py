"""Which model by default: the first-order models' error against the nonlinear model, and the
cost of each, as the deflection grows.

    python benchmarks/model_choice.py

A 1 m hub–beam (EI = 8 N·m², 0.5 kg/m, 4 modes, 1% damping) turned 90° by a cycloidal move
of shrinking duration, then the paper's arm (built-in scenario). For each: the peak tip
deflection per length, the largest difference of the tip deflection from the nonlinear
model's relative to its peak, for the paper's model (no geometric stiffening) and the
stiffened one, and each model's `simulate` time (best of three, warm compiled code).
"""

from __future__ import annotations

import dataclasses
import platform
import time

import numpy as np

from flexlink.model import Chain, Link, PointSensor, Scenario, SimulationSettings
from flexlink.motion import Cycloidal
from flexlink.scenario.builtin import load_paper_experiment
from flexlink.simulation import simulate

MODELS = {"paper": {"model": "first_order", "geometric_stiffening": False},
          "stiffened": {"model": "first_order", "geometric_stiffening": True},
          "nonlinear": {"model": "nonlinear"}}


def hub_beam(duration: float) -> tuple[Scenario, str]:
    link = Link("beam", 1.0, 0.5, 8.0, modes=4, damping_ratio=0.01, thickness=0.005)
    chain = Chain((link,), (Cycloidal(0.0, 90.0, 0.0, duration),))
    settings = SimulationSettings(t_end=duration + 1.0, dt_out=1e-3)
    return Scenario(chain, (PointSensor("tip", "deflection", 0, 1.0),), settings), "tip"


def best_run(scenario: Scenario, **settings: object) -> tuple[np.ndarray | None, float]:
    """The channel values of each model (None if the run fails) and the best of three times."""
    scenario = dataclasses.replace(scenario,
                                   settings=dataclasses.replace(scenario.settings, **settings))
    best = np.inf
    results = None
    for _ in range(3):
        start = time.perf_counter()
        try:
            results = simulate(scenario, shapes=False)
        except Exception:  # noqa: BLE001 — a diverging first-order run is a row too
            return None, np.nan
        best = min(best, time.perf_counter() - start)
    return results, best


def row(label: str, scenario: Scenario, channel: str) -> str:
    runs = {name: best_run(scenario, **s) for name, s in MODELS.items()}
    exact = runs["nonlinear"][0][channel]
    peak = float(np.abs(exact).max())
    cells = []
    for name in ("paper", "stiffened"):
        res = runs[name][0]
        cells.append("diverged" if res is None else
                     f"{np.abs(res[channel] - exact).max() / peak:.2%}")
    times = " / ".join(f"{1e3 * runs[n][1]:.0f}" for n in MODELS)
    deflection = runs["stiffened"][0].metadata["peak_tip_deflection_per_length"]
    return f"| {label} | {deflection:.1%} | {cells[0]} | {cells[1]} | {times} |"


def main() -> None:
    print(f"{platform.processor() or platform.machine()}, {platform.python_version()}")
    print("| case | peak tip deflection / length | paper's model error | stiffened error "
          "| time paper / stiffened / nonlinear [ms] |")
    print("|---|---|---|---|---|")
    for duration in (2.0, 1.5, 1.2, 1.0, 0.9, 0.8):
        scenario, channel = hub_beam(duration)
        print(row(f"hub–beam, 90° in {duration} s", scenario, channel))
    paper = load_paper_experiment()
    print(row("paper experiment (link 2 tip)", paper, "link2_tip_deflection"))


if __name__ == "__main__":
    main()
