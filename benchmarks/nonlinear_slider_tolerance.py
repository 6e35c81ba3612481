"""The nonlinear model's sliders: their own error per channel against their time-integration
error per rtol, what the default tolerance of nonlinear runs with a slider rests on
(docs/nonlinear.md §4, `model.settings.default_rtol`).

    python benchmarks/nonlinear_slider_tolerance.py [--cache DIR] [--modes 3 4 6]
        [--rtol 1e-3 3e-4 1e-4 5e-5 3e-5 1e-5]

Cases: Case 23 of docs/validation.md (tests/validation/test_prismatic.py `slider_fe_case`: a
rigid link turned by a bang-bang moment carries a block pushed along its axis by a bang-bang
force and on the block a flexible beam; tip 1% of the beam's length) and its large-deflection
variant (tests/validation/test_nonlinear_prismatic.py `large_slider_case`: tip 36%); 2 s,
undamped, on the nonlinear model (Gauss collocation).

Model error, per channel: max |signal − FE| / peak |FE| of the run at rtol 1e-10 against
Exudyn's Simo–Reissner beam with 64 elements and steps of 0.125 ms
(tests/validation/exudyn_slider_reference.py): the hub angle and its rate, the travel and its
rate, the beam's tip deflection. The FE reference's own change from 32 elements is printed
with it (its hub rate is converged to ~1e-2 only: it carries the beam's high modes), and the
change of the same run with 8 modes (mode truncation alone). The hub torque and the slider's
force are the drives' inputs (the same histories in both models: no model error); their
integration error is printed.

Integration error at each rtol: max |signal − signal at rtol 1e-10| / peak, and its ratio to
the model error (worst channel). CPU: process time of the whole ``simulate`` (median of 3
after a warm-up), steps as the run reports them. ``--cache DIR`` keeps the FE solutions.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from _timing import median_cpu

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the tests' Exudyn helper and cases

from flexlink import simulate
from tests.validation.test_nonlinear_prismatic import large_slider_case
from tests.validation.test_prismatic import slider_fe_case

TIGHT = 1e-10
# flexlink channel → the FE reference's signal
COMPARED = (("joint1_angle", "angle"), ("joint1_rate", "rate"), ("joint2_position", "travel"),
            ("joint2_velocity", "travel_rate"), ("tip", "tip_deflection"))
INPUTS = ("joint1_torque", "joint2_force")  # the drives' histories: integration error only


def _large(modes: int) -> tuple[Any, dict]:
    return large_slider_case(modes, rtol=None)


CASES: dict[str, Callable[[int], tuple[Any, dict]]] = {"case23": slider_fe_case,
                                                       "large": _large}


def exudyn(name: str, elements: int, dt: float, cache: Path | None) -> dict[str, np.ndarray]:
    """The FE solution of case ``name`` (from ``cache`` when there)."""
    path = cache / f"slider_{name}_{elements}_{dt:g}.npz" if cache else None
    if path is not None and path.exists():
        return dict(np.load(path))
    from tests.validation.exudyn_slider_reference import simulate_slider_exudyn

    _, args = CASES[name](4)
    out = {k: np.asarray(v) for k, v in
           simulate_slider_exudyn(**args, elements=elements, dt=dt).items()}
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        np.savez(path, **out)
    return out


def run(name: str, modes: int, rtol: float, repeat: int) -> tuple[Any, float]:
    """The nonlinear run of case ``name`` with ``modes`` at ``rtol`` and its CPU time
    (median of ``repeat`` after a warm-up; 0 if ``repeat`` is 0)."""
    scenario, _ = CASES[name](modes)
    scenario = dataclasses.replace(scenario, settings=dataclasses.replace(
        scenario.settings, model="nonlinear", rtol=rtol))
    cpu, r = median_cpu(lambda: simulate(scenario, shapes=False), repeat)
    return r, cpu


def error(ours: np.ndarray, reference: np.ndarray) -> float:
    return float(np.abs(np.asarray(ours) - reference).max() / np.abs(reference).max())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cache", type=Path, help="folder for the FE solutions")
    parser.add_argument("--modes", type=int, nargs="+", default=[3, 4, 6])
    parser.add_argument("--rtol", type=float, nargs="+",
                        default=[1e-3, 3e-4, 1e-4, 5e-5, 3e-5, 1e-5])
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"# python {platform.python_version()}, {platform.machine()}, load average "
          f"{os.getloadavg()[0]:.1f}")
    channels = [c for c, _ in COMPARED]
    for name in CASES:
        fine, coarse = exudyn(name, 64, 1.25e-4, args.cache), exudyn(name, 32, 1.25e-4,
                                                                      args.cache)
        print(f"\n== {name}: FE 64 elements against 32 (its own convergence): " + ", ".join(
            f"{c} {error(coarse[f], fine[f]):.1e}" for c, f in COMPARED))
        eight, _ = run(name, 8, TIGHT, 0)
        for modes in args.modes:
            tight, _ = run(name, modes, TIGHT, 0)
            model = {c: error(tight[c], fine[f]) for c, f in COMPARED}
            print(f"-- {modes} modes. model error (vs FE 64): " + ", ".join(
                f"{c} {v:.1e}" for c, v in model.items()))
            print("   change to 8 modes: " + ", ".join(
                f"{c} {error(tight[c], np.asarray(eight[c])):.1e}" for c in channels))
            print("   rtol, steps, CPU s, integration error per channel (ratio to the model "
                  "error), drives' torque and force, worst ratio")
            for rtol in args.rtol:
                r, cpu = run(name, modes, rtol, args.repeat)
                err = {c: error(r[c], np.asarray(tight[c])) for c in channels + list(INPUTS)}
                worst = max(err[c] / model[c] for c in channels)
                steps = r.metadata.get("steps", "?")
                print(f"   {rtol:7.0e} {steps!s:>5} {cpu:7.4f} " + " ".join(
                    f"{err[c]:.1e}(1/{model[c] / err[c]:.0f})" for c in channels)
                    + " " + " ".join(f"{err[c]:.1e}" for c in INPUTS)
                    + f"  worst 1/{1 / worst:.1f}", flush=True)


if __name__ == "__main__":
    main()
