"""A slider inside a chain: flexlink's first-order and nonlinear forward models against a
geometrically exact FE model (Exudyn), timed side by side in one run.

    python benchmarks/slider_vs_fe.py
    python benchmarks/slider_vs_fe.py --before /path/to/old/src --repeat 5
    python benchmarks/slider_vs_fe.py --only case23 --model first_order   # some rows

Two cases. Case 23 (tests/validation/test_prismatic.py `slider_fe_case`): a rigid link turned
by a bang-bang moment carries, at its tip, a block sliding along its axis under a bang-bang
force, and on the block a flexible beam with a tip mass; 2 s, undamped; the beam's tip
deflects by 1% of its length. The large-deflection case
(tests/validation/test_nonlinear_prismatic.py `large_slider_case`): the same with a beam 8×
softer and a moment 10/3× larger, the tip deflecting by 36% of the beam's length. flexlink:
the stiffened first-order model and the nonlinear model, at several mode counts and
tolerances (rtol None: the model's default). Exudyn (tests/validation/exudyn_slider_reference.py:
Simo–Reissner beams, generalized-α without numerical damping): the reference is 64 elements
with steps of 0.125 ms; the cheapest of the coarser meshes and steps within 1% of it (hub
angle, travel and tip deflection, max error / peak) is the one flexlink's time is compared
with. Times: CPU (process) seconds, flexlink's whole ``simulate`` call (median of
``--repeat`` after a warm-up: numba's compilation excluded), Exudyn's solver only.

``--before`` is the ``src`` folder of another checkout (e.g. ``git worktree add /tmp/old
<commit>``): each flexlink row then runs in two fresh child processes, one importing flexlink
from that folder and one from this tree's ``src``, one after the other, so that both columns
share the machine's load of the moment.
"""

from __future__ import annotations

import argparse
import dataclasses
import multiprocessing
import os
import platform
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from _timing import median_cpu, use_tree

ROOT = Path(__file__).resolve().parents[1]

# flexlink channel → Exudyn signal, compared for the error columns and the mesh choice
SIGNALS = (("joint1_angle", "angle"), ("joint2_position", "travel"), ("tip", "tip_deflection"))
REFERENCE = (64, 1.25e-4)  # elements, step (s)
MESHES = ((8, 5e-4), (16, 5e-4), (16, 2.5e-4), (32, 5e-4))


def _case(name: str, modes: int) -> tuple[Any, dict]:
    if name == "case23":
        from tests.validation.test_prismatic import slider_fe_case

        return slider_fe_case(modes)
    from tests.validation.test_nonlinear_prismatic import large_slider_case

    return large_slider_case(modes, rtol=None)


def _flexlink(name: str, model: str, modes: int, rtol: float | None,
              repeat: int) -> tuple[float, dict[str, np.ndarray]]:
    """CPU seconds (median of ``repeat`` after a warm-up) and the compared signals of one
    flexlink row (rtol None: the model's default)."""
    from flexlink import simulate

    scenario, _ = _case(name, modes)
    scenario = dataclasses.replace(scenario, settings=dataclasses.replace(
        scenario.settings, model=model, rtol=rtol))
    cpu, r = median_cpu(lambda: simulate(scenario, shapes=False), repeat)
    return cpu, {a: np.asarray(r[a]) for a, _ in SIGNALS}


def _exudyn(name: str, elements: int, dt: float) -> dict[str, Any]:
    from tests.validation.exudyn_slider_reference import simulate_slider_exudyn

    _, args = _case(name, 4)
    return simulate_slider_exudyn(**args, elements=elements, dt=dt)


def _child(src: str, what: str, *args: Any) -> Any:
    context = multiprocessing.get_context("spawn")  # nothing of the parent's flexlink
    with ProcessPoolExecutor(1, mp_context=context, initializer=use_tree,
                             initargs=(src,)) as pool:
        return pool.submit(globals()[what], *args).result()


def error_of_peak(ours: dict[str, np.ndarray], reference: dict[str, Any]) -> float:
    """The largest max |signal − reference| / peak |reference| over SIGNALS."""
    return max(float(np.abs(np.asarray(ours[a]) - reference[b]).max()
                     / np.abs(reference[b]).max()) for a, b in SIGNALS)


def compare(title: str, name: str, rows: list[tuple[str, int, float | None]],
            trees: list[tuple[str, str]], repeat: int, only: str | None = None) -> None:
    """Exudyn's meshes of case ``name`` and flexlink's ``rows`` (model, modes, rtol; None:
    the model's default) of each tree, timed in this run (only model ``only``'s rows if set)."""
    rows = [row for row in rows if only in (None, row[0])]
    print(f"\n== {title}")
    here = str(ROOT / "src")
    fine = _child(here, "_exudyn", name, *REFERENCE)
    print(f"Exudyn reference: {REFERENCE[0]} elements, steps {REFERENCE[1]:g} s, "
          f"{fine['cpu_time_s']:.2f} s of CPU")
    print("Exudyn: elements, step s, coordinates, solver CPU s, error of peak against the "
          "reference")
    chosen = None
    for elements, dt in MESHES:
        out = _child(here, "_exudyn", name, elements, dt)
        err = max(float(np.abs(out[b] - fine[b]).max() / np.abs(fine[b]).max())
                  for _, b in SIGNALS)
        print(f"  {elements:3d} {dt:8.2e} {out['coordinates']:5d} {out['cpu_time_s']:8.3f} "
              f"{err:9.2e}")
        if err < 0.01 and (chosen is None or out["cpu_time_s"] < chosen[1]):
            chosen = (f"{elements} elements, steps {dt:g} s", out["cpu_time_s"])
    if chosen is None:
        chosen = ("the reference", fine["cpu_time_s"])
    print(f"compared with the cheapest within 1%: {chosen[0]}, {chosen[1]:.3f} s of CPU")
    print("flexlink: tree, model, modes, rtol, CPU s (median), error of peak against the "
          "reference, speed-up (CPU) against that mesh")
    for model, modes, rtol in rows:
        for label, src in trees:
            cpu, signals = _child(src, "_flexlink", name, model, modes, rtol, repeat)
            print(f"  {label:6s} {model:11s} {modes} {rtol or 'default':>8} {cpu:8.4f} "
                  f"{error_of_peak(signals, fine):9.2e} {chosen[1] / cpu:6.1f}x", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--before", help="src folder of the tree to compare with")
    parser.add_argument("--only", choices=("case23", "large"), help="one case")
    parser.add_argument("--model", choices=("first_order", "nonlinear"),
                        help="only this model's rows")
    args = parser.parse_args()
    trees = ([("before", args.before)] if args.before else []) + [("after", str(ROOT / "src"))]
    print(f"# python {platform.python_version()}, {platform.processor() or platform.machine()}"
          f", load average {os.getloadavg()[0]:.1f}")
    if args.only in (None, "case23"):
        first = [("first_order", modes, rtol) for modes in (4, 6) for rtol in (None, 1e-6)]
        compare("Case 23: tip deflection 1% of the beam's length", "case23",
                first + [("nonlinear", modes, rtol) for modes in (3, 4, 6)
                         for rtol in (None, 1e-3)], trees, args.repeat, args.model)
    if args.only in (None, "large"):
        compare("large deflection (tip 36% of the beam's length)", "large",
                [("nonlinear", modes, rtol) for modes in (3, 4, 6) for rtol in (1e-3, None)]
                + [("nonlinear", 6, 1e-6), ("first_order", 6, 1e-6)], trees, args.repeat,
                args.model)


if __name__ == "__main__":
    main()
