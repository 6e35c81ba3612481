"""A slider inside a chain: flexlink's first-order and nonlinear forward models against a
geometrically exact FE model (Exudyn), timed side by side in one run.

    python benchmarks/slider_vs_fe.py
    python benchmarks/slider_vs_fe.py --repeat 5 --elements 4 8 16 32
    python benchmarks/slider_vs_fe.py --before /path/to/old/src --only first_order

Two cases. Case 23 (tests/validation/test_prismatic.py `slider_fe_case`): a rigid link turned
by a bang-bang moment carries, at its tip, a block sliding along its axis under a bang-bang
force, and on the block a flexible beam with a tip mass; 2 s, undamped; the beam's tip
deflects by 1% of its length. The large-deflection case
(tests/validation/test_nonlinear_prismatic.py `large_slider_case`): the same with a beam 8×
softer and a moment 10/3× larger, the tip deflecting by 36% of the beam's length. flexlink:
the stiffened first-order model and the nonlinear model, at several mode counts and
tolerances (rtol None: the model's default). Exudyn (tests/validation/exudyn_slider_reference.py:
Simo–Reissner beams, generalized-α without numerical damping) on each mesh; the finest is
the reference, and the coarsest within 1% of it (tip deflection and travel, max error /
peak) is the one flexlink's time is compared with. Times: CPU (process) seconds,
flexlink's whole ``simulate`` call (median of ``--repeat`` after a warm-up: numba's
compilation excluded), Exudyn's solver only. ``--before``: the ``src`` folder of another
checkout; each flexlink row then runs in a fresh child process for each tree, the old one
first, in the same run as Exudyn (``--only``: only that model's rows).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the Exudyn model lives with the validation tests

from tests.validation.exudyn_slider_reference import simulate_slider_exudyn
from tests.validation.test_nonlinear_prismatic import large_slider_case
from tests.validation.test_prismatic import slider_fe_case

SIGNALS = (("joint2_position", "travel"), ("tip", "tip_deflection"))


def error_of_peak(ours: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> float:
    """The largest max |signal − reference| / peak |reference| over SIGNALS."""
    return max(float(np.abs(np.asarray(ours[a]) - reference[b]).max()
                     / np.abs(reference[b]).max()) for a, b in SIGNALS)


def run_row(case_name: str, model: str, modes: int, rtol: float | None, repeat: int
            ) -> tuple[float, dict[str, np.ndarray]]:
    """CPU median (s) of ``simulate`` on the row's scenario and the last run's signals."""
    from flexlink import simulate

    case = {"slider_fe_case": slider_fe_case, "large_slider_case": large_slider_case}[case_name]
    scenario, _ = case(modes)
    scenario = dataclasses.replace(scenario, settings=dataclasses.replace(
        scenario.settings, model=model, rtol=rtol))
    simulate(scenario, shapes=False)  # warm-up
    cpus = []
    for _ in range(repeat):
        cpu = time.process_time()
        r = simulate(scenario, shapes=False)
        cpus.append(time.process_time() - cpu)
    return statistics.median(cpus), {a: np.asarray(r[a]) for a, _ in SIGNALS}


def row_in_child(src: str, *row: Any) -> tuple[float, dict[str, np.ndarray]]:
    """`run_row` in a fresh process that imports flexlink from ``src``."""
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "row.npz"
        subprocess.run([sys.executable, __file__, "--row", out, *map(str, row)], check=True,
                       env={**os.environ, "PYTHONPATH": src})
        with np.load(out) as saved:
            return float(saved["cpu"]), {a: saved[a] for a, _ in SIGNALS}


def compare(title: str, case: Callable[..., tuple[Any, dict]], rows: list[tuple[str, int,
            float | None]], elements: list[int], repeat: int,
            trees: tuple[tuple[str, str | None], ...] = (("", None),)) -> None:
    """Exudyn on each mesh of ``case`` (its finest the reference) and flexlink's ``rows``
    (model, modes, rtol; None: the model's default), timed in this run; ``trees``: (label,
    src folder; None: in this process) of the flexlink runs."""
    print(f"\n== {title}")
    fe = {}
    for count in sorted(elements):
        _, fe_args = case()
        fe[count] = simulate_slider_exudyn(**fe_args, elements=count)
    finest = fe[max(fe)]
    print("Exudyn: elements, coordinates, solver CPU s, error of peak against the finest")
    chosen = None
    for count, out in fe.items():
        error = max(float(np.abs(out[b] - finest[b]).max() / np.abs(finest[b]).max())
                    for _, b in SIGNALS)
        print(f"  {count:3d} {out['coordinates']:5d} {out['cpu_time_s']:8.3f} {error:9.2e}")
        if chosen is None and error < 0.01 and count != max(fe):
            chosen = count
    chosen = chosen or max(fe)
    print(f"compared with the coarsest mesh within 1%: {chosen} elements, "
          f"{fe[chosen]['cpu_time_s']:.3f} s of CPU")
    print("flexlink: model, modes, rtol, CPU s (median), error of peak against the finest, "
          "speed-up (CPU) against that mesh")
    for model, modes, rtol in rows:
        for label, src in trees:
            if src is None:
                cpu, r = run_row(case.__name__, model, modes, rtol, repeat)
            else:
                cpu, r = row_in_child(src, case.__name__, model, modes, rtol, repeat)
            print(f"  {label}{model:11s} {modes} {rtol or 'default':>8} {cpu:8.4f} "
                  f"{error_of_peak(r, finest):9.2e} {fe[chosen]['cpu_time_s'] / cpu:6.1f}x",
                  flush=True)


def main() -> None:
    if sys.argv[1:2] == ["--row"]:  # a child of row_in_child: out, case, model, modes, rtol,
        out, case, model, modes, rtol, repeat = sys.argv[2:]  # repeat
        cpu, signals = run_row(case, model, int(modes), None if rtol == "None" else float(rtol),
                               int(repeat))
        np.savez(out, cpu=cpu, **signals)
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--elements", type=int, nargs="+", default=[4, 8, 16, 32])
    parser.add_argument("--before", help="src folder of the tree to compare with")
    parser.add_argument("--only", choices=("first_order", "nonlinear"),
                        help="only this model's rows")
    args = parser.parse_args()
    print(f"python {platform.python_version()}, {platform.processor() or platform.machine()}")
    trees = ((("before ", args.before), ("after  ", str(ROOT / "src"))) if args.before
             else (("", None),))

    def chosen(rows: list[tuple[str, int, float | None]]) -> list:
        return [row for row in rows if args.only in (None, row[0])]

    first = [("first_order", modes, rtol) for modes in (4, 6) for rtol in (None, 1e-6)]
    compare("Case 23: tip deflection 1% of the beam's length", slider_fe_case,
            chosen(first + [("nonlinear", 4, None), ("nonlinear", 4, 1e-3)]), args.elements,
            args.repeat, trees)
    large = chosen([("nonlinear", modes, rtol) for modes in (3, 4, 6) for rtol in (1e-3, None)]
                   + [("nonlinear", 6, 1e-6), ("first_order", 6, 1e-6)])
    if args.only != "first_order":
        compare("large deflection (tip 36% of the beam's length)", large_slider_case, large,
                args.elements, args.repeat, trees)


if __name__ == "__main__":
    main()
