"""A slider inside a chain: flexlink's first-order and nonlinear forward models against a
geometrically exact FE model (Exudyn), timed side by side in one run.

    python benchmarks/slider_vs_fe.py
    python benchmarks/slider_vs_fe.py --repeat 5 --elements 4 8 16 32

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
compilation excluded), Exudyn's solver only.
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the Exudyn model lives with the validation tests

from flexlink import simulate
from tests.validation.exudyn_slider_reference import simulate_slider_exudyn
from tests.validation.test_nonlinear_prismatic import large_slider_case
from tests.validation.test_prismatic import slider_fe_case

SIGNALS = (("joint2_position", "travel"), ("tip", "tip_deflection"))


def error_of_peak(ours: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> float:
    """The largest max |signal − reference| / peak |reference| over SIGNALS."""
    return max(float(np.abs(np.asarray(ours[a]) - reference[b]).max()
                     / np.abs(reference[b]).max()) for a, b in SIGNALS)


def compare(title: str, case: Callable[..., tuple[Any, dict]], rows: list[tuple[str, int,
            float | None]], elements: list[int], repeat: int) -> None:
    """Exudyn on each mesh of ``case`` (its finest the reference) and flexlink's ``rows``
    (model, modes, rtol; None: the model's default), timed in this run."""
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
        scenario, _ = case(modes)
        scenario = dataclasses.replace(scenario, settings=dataclasses.replace(
            scenario.settings, model=model, rtol=rtol))
        simulate(scenario, shapes=False)  # warm-up
        cpus = []
        for _ in range(repeat):
            cpu = time.process_time()
            r = simulate(scenario, shapes=False)
            cpus.append(time.process_time() - cpu)
        cpu = statistics.median(cpus)
        print(f"  {model:11s} {modes} {rtol or 'default':>8} {cpu:8.4f} "
              f"{error_of_peak(r, finest):9.2e} {fe[chosen]['cpu_time_s'] / cpu:6.1f}x")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--elements", type=int, nargs="+", default=[4, 8, 16, 32])
    args = parser.parse_args()
    print(f"python {platform.python_version()}, {platform.processor() or platform.machine()}")
    first = [("first_order", modes, rtol) for modes in (4, 6) for rtol in (None, 1e-6)]
    compare("Case 23: tip deflection 1% of the beam's length", slider_fe_case,
            first + [("nonlinear", 4, None), ("nonlinear", 4, 1e-3)], args.elements,
            args.repeat)
    compare("large deflection (tip 36% of the beam's length)", large_slider_case,
            [("nonlinear", modes, rtol) for modes in (3, 4, 6) for rtol in (1e-3, None)]
            + [("nonlinear", 6, 1e-6), ("first_order", 6, 1e-6)], args.elements,
            args.repeat)


if __name__ == "__main__":
    main()
