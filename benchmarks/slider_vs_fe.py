"""A slider inside a chain: flexlink's first-order forward model against a geometrically exact
FE model (Exudyn), timed side by side in one run.

    python benchmarks/slider_vs_fe.py
    python benchmarks/slider_vs_fe.py --repeat 5 --elements 4 8 16 32

The case (tests/validation/test_prismatic.py `slider_fe_case`): a rigid link turned by a
bang-bang moment carries, at its tip, a block sliding along its axis under a bang-bang force,
and on the block a flexible beam with a tip mass; 2 s, undamped. flexlink: stiffened first
order, its default forward integrator at the default rtol (1e-4) and at 1e-6, 4 and 6
modes. Exudyn (tests/validation/exudyn_slider_reference.py: Simo–Reissner beams,
generalized-α without numerical damping) on each mesh; the finest is the reference, and the
coarsest within 1% of it (tip deflection and travel, max error / peak) is the one flexlink's
time is compared with. Times: CPU (process) seconds, flexlink's whole ``simulate`` call
(median of ``--repeat`` after a warm-up: numba's compilation excluded), Exudyn's solver only.
"""

from __future__ import annotations

import argparse
import dataclasses
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # the Exudyn model lives with the validation tests

from flexlink import simulate
from tests.validation.exudyn_slider_reference import simulate_slider_exudyn
from tests.validation.test_prismatic import slider_fe_case

SIGNALS = (("joint2_position", "travel"), ("tip", "tip_deflection"))


def error_of_peak(ours: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> float:
    """The largest max |signal − reference| / peak |reference| over SIGNALS."""
    return max(float(np.abs(np.asarray(ours[a]) - reference[b]).max()
                     / np.abs(reference[b]).max()) for a, b in SIGNALS)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--elements", type=int, nargs="+", default=[4, 8, 16, 32])
    args = parser.parse_args()
    print(f"python {platform.python_version()}, {platform.processor() or platform.machine()}")
    fe = {}
    for elements in sorted(args.elements):
        scenario, fe_args = slider_fe_case()
        fe[elements] = simulate_slider_exudyn(**fe_args, elements=elements)
    finest = fe[max(fe)]
    print("Exudyn: elements, coordinates, solver CPU s, error of peak against the finest")
    chosen = None
    for elements, out in fe.items():
        error = max(float(np.abs(out[b] - finest[b]).max() / np.abs(finest[b]).max())
                    for _, b in SIGNALS)
        print(f"  {elements:3d} {out['coordinates']:5d} {out['cpu_time_s']:8.3f} {error:9.2e}")
        if chosen is None and error < 0.01 and elements != max(fe):
            chosen = elements
    chosen = chosen or max(fe)
    print(f"compared with the coarsest mesh within 1%: {chosen} elements, "
          f"{fe[chosen]['cpu_time_s']:.3f} s of CPU")
    print("flexlink: modes, rtol, CPU s (median), error of peak against the finest, "
          "speed-up (CPU) against that mesh")
    for modes in (4, 6):
        for rtol in (None, 1e-6):
            scenario, _ = slider_fe_case(modes)
            scenario = dataclasses.replace(scenario, settings=dataclasses.replace(
                scenario.settings, rtol=rtol))
            simulate(scenario, shapes=False)  # warm-up
            cpus = []
            for _ in range(args.repeat):
                cpu = time.process_time()
                r = simulate(scenario, shapes=False)
                cpus.append(time.process_time() - cpu)
            cpu = statistics.median(cpus)
            print(f"  {modes} {rtol or 'default':>8} {cpu:8.4f} {error_of_peak(r, finest):9.2e} "
                  f"{fe[chosen]['cpu_time_s'] / cpu:6.1f}x")


if __name__ == "__main__":
    main()
