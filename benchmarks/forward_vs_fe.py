"""Driven runs: flexlink's forward dynamics against a geometrically exact FE model (Exudyn),
timed side by side in one run (issue 14, item 4).

    python benchmarks/forward_vs_fe.py                    # every case
    python benchmarks/forward_vs_fe.py --cases hub_beam_small --repeat 1

Cases (tests/validation/forward_fe_cases.py), each at a small (tip ≈ 3% of the length) and a
large (≥ 30%) deflection, undamped:

- ``hub_beam``: rigid hub (J_h = 1 kg·m²) on a fixed pin, a 1 m beam clamped to it, a
  bang-bang torque over 2 s, 4 s simulated; flexlink: joint 1 ``drive = "torque"`` with the hub
  as its motor inertia;
- ``free_hub``: a 100 kg / 20 kg·m² hub free in the plane, two 3 m appendages, a bang-bang
  moment on the hub over 4 s, 8 s simulated; flexlink: ``[base] type = "free"`` with a load;
- ``elastic_joint``: the hub–beam's beam on an elastic joint (spring, gear, rotor), a
  bang-bang motor torque over 2 s, 4 s simulated (docs/elastic_joints.md).
- ``cart_hanging``: examples/cart_beam.toml undamped, a beam hanging from a cart pushed by
  ±4 N for 1 s, 2 s simulated; flexlink: ``[base] type = "cart"`` with a force drive;
  ``cart_inverted``, ``cart_horizontal``: the same beam standing on the cart and held level
  (released undeformed under its weight: ≈ 20% tip deflection);
- ``pendulum``: a hub–beam with a tip mass released level under gravity;
- ``arm``: a gravity-loaded arm on a pinned hub swung up 70° from hanging, rest to rest, by
  the rigid arm's inverse-dynamics torque.

flexlink runs its default forward integrator, first order with geometric stiffening, 4 and 6
modes per link (at rtol 1e-6, or ``--rtol``), and the nonlinear model with its default settings (docs/nonlinear.md §4, §7:
Gauss collocation with error-controlled steps at the nonlinear model's default rtol), 4 and
6 modes.
Exudyn
(tests/validation/exudyn_forward_reference.py: Simo–Reissner beams, generalized-α without
numerical damping) runs on 4…64 elements per appendage; the finest mesh is the reference, and
the coarsest mesh within 1% of it (tip deflection and hub angle, max error / peak) is the one
flexlink's time is compared with. Wall times: flexlink's whole ``simulate`` call, median of
``--repeat`` runs after a warm-up (numba's compilation excluded); Exudyn's solver only (model
building excluded), one run per mesh; flexlink's CPU (process) time beside its wall time,
and the ratio to both (on a loaded machine the wall time of a short run is mostly waiting).
Errors: max |signal − finest FE| / peak of the finest FE.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the Exudyn model lives with the validation tests

from flexlink import simulate
from tests.validation.forward_fe_cases import (
    CASES,
    THIN_ROTARY,
    THIN_SHEAR,
    DrivenCase,
    error_of_peak,
    exudyn_signals,
    flexlink_scenario,
    flexlink_signals,
)

# elements per appendage → generalized-α step (s); finer meshes carry faster modes
MESHES = {4: 2e-3, 8: 1e-3, 16: 1e-3, 32: 5e-4, 64: 2.5e-4}
MODES = (4, 6)
CONVERGED = ("tip", "hub_angle", "cart_travel")  # those a case has: resolved within 1%


def _flexlink(case: DrivenCase, modes: int, repeat: int, model: str = "first_order",
              rtol: float = 1e-6) -> tuple[float, float, dict[str, np.ndarray], str]:
    """Median wall and CPU (process) time (s) of ``simulate``, the comparison signals and the
    run's validity warning ("" if none); ``rtol``: the first-order runs' tolerance."""
    scenario = flexlink_scenario(case, modes, rtol=rtol)
    if model == "nonlinear":  # its default settings: adaptive steps at its default rtol
        scenario = replace(scenario, settings=replace(scenario.settings, model="nonlinear",
                                                      rtol=None))
    simulate(replace(scenario, settings=replace(scenario.settings, t_end=0.1)))  # warm-up
    walls, cpus, results = [], [], None
    for _ in range(repeat):
        start, cpu = time.perf_counter(), time.process_time()
        results = simulate(scenario)
        walls.append(time.perf_counter() - start)
        cpus.append(time.process_time() - cpu)
    return (statistics.median(walls), statistics.median(cpus), flexlink_signals(case, results),
            str(results.metadata.get("validity_warning", "")))


def _fmt(errors: dict[str, float]) -> str:
    return " ".join(f"{k} {100 * v:.3g}%" for k, v in errors.items())


def _case(case: DrivenCase, repeat: int, rtol: float = 1e-6, thin: bool = False
          ) -> dict[str, Any]:
    """Every row of one case, printed as it runs; returns the summary numbers (``thin``:
    Exudyn's beams near the Euler–Bernoulli limit, `thin_section`)."""
    fe: dict[int, tuple[float, dict[str, np.ndarray], int]] = {}
    for elements, dt in MESHES.items():
        try:
            signals, out = exudyn_signals(case, elements, dt, thin)
        except RuntimeError as error:  # Newton may fail on a coarse mesh of a violent slew
            print(f"| {case.name} | Exudyn, {elements} el., dt {dt * 1e3:g} ms | failed: "
                  f"{error} | | |", flush=True)
            continue
        fe[elements] = (out["wall_time_s"], signals, out["coordinates"])
    finest = max(fe)
    reference = fe[finest][1]
    length = {"hub_beam": 1.0, "elastic_joint": 1.0, "free_hub": 3.0, "cart": 1.2,
              "pendulum": 1.0, "arm": 1.0}[case.kind]
    peak_tip = float(np.abs(reference["tip"]).max()) / length
    chosen = None
    for elements in sorted(fe):
        wall, signals, coords = fe[elements]
        errors = error_of_peak(signals, reference)
        within = max(errors[k] for k in CONVERGED if k in errors) <= 0.01
        if chosen is None and within:
            chosen = elements
        mark = " ← coarsest within 1%" if elements == chosen else ""
        label = "reference" if elements == finest else _fmt(errors)
        print(f"| {case.name} | Exudyn, {elements} el. ({coords} coordinates), dt "
              f"{MESHES[elements] * 1e3:g} ms{mark} | {wall:.3g} | {label} | |", flush=True)
    summary: dict[str, Any] = {"case": case.name, "peak_tip": peak_tip, "fe_mesh": chosen,
                               "fe_wall": fe[chosen][0] if chosen else float("nan")}
    for model, label in (("first_order", "first order stiffened"), ("nonlinear", "nonlinear")):
        for modes in MODES:
            name = f"flexlink {label}, {modes} modes"
            name += ", default settings" if model == "nonlinear" else f", rtol {rtol:g}"
            try:
                wall, cpu, ours, warning = _flexlink(case, modes, repeat, model, rtol)
            except Exception as error:  # noqa: BLE001 — a refused run is a result to report
                print(f"| {case.name} | {name} | refused: {error} | | |", flush=True)
                continue
            errors = error_of_peak(ours, reference)
            ratio = summary["fe_wall"] / wall
            warned = f" (warns: {warning})" if warning else ""
            print(f"| {case.name} | {name} | {wall:.3g} (CPU {cpu:.3g}) | {_fmt(errors)}{warned} | "
                  f"{ratio:.2g}× (CPU {summary['fe_wall'] / cpu:.2g}×) |", flush=True)
            summary[f"{model}{modes}"] = (wall, errors, ratio)
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed flexlink runs (median)")
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=list(CASES))
    parser.add_argument("--rtol", type=float, default=1e-6,
                        help="first-order runs' tolerance (1e-4: flexlink's default)")
    parser.add_argument("--thin", action="store_true",
                        help="Exudyn's sections near the Euler-Bernoulli beam flexlink models "
                             f"(shear stiffness x{THIN_SHEAR:g}, rotary inertia "
                             f"x{THIN_ROTARY:g}): flexlink's own error, without the section's")
    args = parser.parse_args()
    print(f"# {platform.machine()} {os.cpu_count()} cores, {platform.processor() or ''} "
          f"Python {platform.python_version()}, numpy {np.__version__}")
    print("| case | model | wall [s] | error / peak vs. finest FE | Exudyn (coarsest within 1%)"
          " / flexlink |")
    print("|---|---|---|---|---|")
    print("# Exudyn's sections: EA = 12 EI/h², GA (ν = 0.3) and ρI from the depth h"
          + (f", then GA x{THIN_SHEAR:g}, ρI x{THIN_ROTARY:g}" if args.thin else ""))
    summaries = [_case(CASES[name], args.repeat, args.rtol, args.thin) for name in args.cases]
    print()
    for s in summaries:
        print(f"{s['case']}: peak tip deflection {100 * s['peak_tip']:.3g}% of the length "
              f"(finest FE); coarsest FE mesh within 1%: {s['fe_mesh']} elements, "
              f"{s['fe_wall']:.3g} s")


if __name__ == "__main__":
    main()
