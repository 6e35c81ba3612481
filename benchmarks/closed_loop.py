"""Closed-loop cost: examples/active_damping.toml with its PPF loop against the same
scenario without controllers (the open-loop run, on the prescribed path). Target: the
closed-loop run costs at most 2× the open-loop one.

    PYTHONPATH=src python benchmarks/closed_loop.py [--repeat 5]

Wall time is ``simulate`` (integration and channels, shapes left out), the median of
``--repeat`` runs after a warm-up run (numba's compilation, cached on disk, excluded). A
second row runs the same loop as a Python callable (the integrator returns to Python at
every sample) to show what the compiled loop saves.
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
from pathlib import Path

import numpy as np

from flexlink.model import FunctionController
from flexlink.scenario import load_scenario
from flexlink.simulation import simulate

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "active_damping.toml"


def wall(scenario, repeat: int) -> float:
    simulate(scenario, shapes=False)  # warm-up
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        simulate(scenario, shapes=False)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def python_ppf(scenario):
    """The example's PPF as a Python callable with the same discrete filter."""
    from flexlink.dynamics.controllers import discretize

    ppf = scenario.controllers[0]
    A, B, C, D = discretize(ppf)

    class Law:  # deep-copied afresh for each integration pass
        def __init__(self) -> None:
            self.x = np.zeros(A.shape[0])

        def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
            v = C @ self.x + D @ y
            self.x = A @ self.x + B @ y
            return v

    return dataclasses.replace(scenario, controllers=(FunctionController(
        "ppf", (ppf.sensor,), (ppf.actuator,), Law(), ppf.sample_rate),))


def forward_case():
    """The clamped strip of tests/validation/test_ppf.py (2 modes, 3 s) on a torque-driven
    hub (motor inertia 0.01 kg·m², no torque), open loop and with PPF on its first mode: the
    first-order forward path (compiled Radau IIA, stopping at every sample)."""
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from flexlink.scenario import scenario_from_dict
    from tests.validation.test_controllers_forward import hub, plant
    from tests.validation.test_ppf import ppf

    d, w, unit = plant()
    d["joints"] = hub(0.01)
    opened = scenario_from_dict(d)
    d["controllers"] = [ppf(w / (2 * np.pi), 0.3 * unit)]
    return opened, scenario_from_dict(d)


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    closed = load_scenario(EXAMPLE)
    opened = dataclasses.replace(closed, controllers=())
    t_open = wall(opened, args.repeat)
    t_closed = wall(closed, args.repeat)
    t_python = wall(python_ppf(closed), max(1, args.repeat // 2))
    print("| run | wall time (s) | / open loop |\n|---|---|---|")
    print(f"| open loop (prescribed path) | {t_open:.3f} | 1 |")
    print(f"| PPF, compiled in the loop | {t_closed:.3f} | {t_closed / t_open:.2f} |")
    print(f"| PPF as a Python callable | {t_python:.3f} | {t_python / t_open:.2f} |")
    f_open, f_closed = forward_case()
    t_f = wall(f_open, args.repeat)
    print(f"| forward: strip on a torque-driven hub, open loop | {t_f:.3f} | 1 (forward) |")
    t_fc = wall(f_closed, args.repeat)
    print(f"| forward: the same with PPF (2 kHz) | {t_fc:.3f} | {t_fc / t_f:.2f} × forward open |")


if __name__ == "__main__":
    main()
