"""Forward runs (driven joints, free base): the integrators side by side at equal accuracy,
in one run, against a tight-tolerance reference of the same equations.

    python benchmarks/forward_integrators.py                 # every case
    python benchmarks/forward_integrators.py --cases paper_servo hub_beam_small

For each case and integrator, ``simulate`` runs at rtol = 1e-3 … 1e-7 (atol 1e-12); each row
gives the CPU time of the whole ``simulate`` call (median of ``--repeat`` runs after a
warm-up, numba's compilation excluded) and its error: the largest difference of any channel
from the reference — solve_ivp DOP853 at rtol 1e-10 over the compiled kernel — relative to
that channel's peak. The summary line per case gives, for each integrator, the cheapest run
whose error is below 1e-3 and below 1e-5 of peak. Cases: examples/paper_servo.toml and
satellite_slew.toml, and the driven cases of tests/validation/forward_fe_cases.py
(benchmarks/forward_vs_fe.py times Exudyn on them), 4 modes per link.

Integrators (``--methods``): ``radau5``, the compiled Radau IIA (the default), and any
solve_ivp method ("DOP853", "Radau": over the compiled kernel). The compiled RK4 and Lawson
loops that Radau IIA replaced were measured by this script in the same run as it before they
were removed (docs/performance.md, "Forward runs: one implicit integrator").
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
CASES = ("paper_servo", "satellite_slew", "hub_beam_small", "hub_beam_large", "free_hub_small",
         "free_hub_large")
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)
TARGETS = (1e-3, 1e-5)


def _scenario(case: str) -> Any:
    import flexlink

    if case in ("paper_servo", "satellite_slew"):
        return flexlink.load_scenario(ROOT / "examples" / f"{case}.toml")
    from tests.validation.forward_fe_cases import CASES as FE
    from tests.validation.forward_fe_cases import flexlink_scenario

    return flexlink_scenario(FE[case], 4)


def _run(case: str, method: str, rtol: float, repeat: int) -> dict[str, Any]:
    """One row in this (child) process: CPU times and the channels of the last run."""
    import flexlink
    import flexlink.simulation.forward as path
    from flexlink.solvers.forward import integrate_forward

    scenario = _scenario(case)
    if method == "reference":
        settings = dataclasses.replace(scenario.settings, method="DOP853", rtol=1e-10,
                                       atol=1e-12)
    else:
        settings = dataclasses.replace(scenario.settings, rtol=rtol, atol=1e-12)

        def chosen(*args: Any, **kwargs: Any) -> Any:
            args = list(args)
            args[4] = method
            return integrate_forward(*args, **kwargs)
        path.integrate_forward = chosen  # type: ignore[assignment]
    scenario = dataclasses.replace(scenario, settings=settings)
    flexlink.simulate(dataclasses.replace(scenario, settings=dataclasses.replace(
        settings, t_end=min(0.05, settings.t_end))))  # warm-up: imports, numba's cache
    cpu = []
    for _ in range(repeat):
        start = time.process_time()
        results = flexlink.simulate(scenario, shapes=False)
        cpu.append(time.process_time() - start)
    return {"cpu": statistics.median(cpu),
            "signals": {n: np.asarray(results[n]) for n in results.names}}


SOURCE: list[str] = []  # --src: the flexlink source folder the children import


def _use(src: list[str]) -> None:
    sys.path[:0] = src


def _in_child(*args: Any) -> dict[str, Any]:
    with ProcessPoolExecutor(1, initializer=_use, initargs=(SOURCE,)) as pool:
        return pool.submit(_run, *args).result()


def _error(signals: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> float:
    """Largest difference / peak over the channels."""
    worst = 0.0
    for key, ref in reference.items():
        peak = np.abs(ref).max()
        if key not in signals or peak < 1e-12 or not np.all(np.isfinite(ref)):
            continue  # a channel at round-off (a free hub's centre of mass) has no error
        worst = max(worst, float(np.abs(signals[key] - ref).max() / peak))
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3, help="timed runs per row (median)")
    parser.add_argument("--cases", nargs="*", default=list(CASES), choices=CASES)
    parser.add_argument("--methods", nargs="*", default=["radau5"])
    parser.add_argument("--src", help="import flexlink from this src folder (another tree: "
                        "before and after a change in one run, one invocation each)")
    args = parser.parse_args()
    SOURCE[:] = [args.src] if args.src else []
    print(f"# {platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numpy {np.__version__}")
    print("| case | integrator | rtol | CPU [s] | error / peak |")
    print("|---|---|---|---|---|")
    for case in args.cases:
        reference = _in_child(case, "reference", 0.0, 1)["signals"]
        best: dict[str, dict[float, tuple[float, float]]] = {}
        for method in args.methods:
            for rtol in RTOLS:
                try:
                    run = _in_child(case, method, rtol, args.repeat)
                except Exception as error:  # noqa: BLE001 — a failed run is a result
                    print(f"| {case} | {method} | {rtol:g} | failed: {error} | |", flush=True)
                    continue
                err = _error(run["signals"], reference)
                print(f"| {case} | {method} | {rtol:g} | {run['cpu']:.3g} | {err:.2g} |",
                      flush=True)
                for target in TARGETS:
                    if err <= target:
                        old = best.setdefault(method, {}).get(target)
                        if old is None or run["cpu"] < old[0]:
                            best[method][target] = (run["cpu"], rtol)
        for target in TARGETS:
            cells = ", ".join(f"{m} {best[m][target][0]:.3g} s (rtol {best[m][target][1]:g})"
                              for m in args.methods if target in best.get(m, {}))
            print(f"\n{case}, error ≤ {target:g} of peak: {cells}", flush=True)
        print()


if __name__ == "__main__":
    main()
