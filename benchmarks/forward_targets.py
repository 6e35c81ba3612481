"""The targets of first-order forward runs, before and after a change, side by side in one run.

    python benchmarks/forward_targets.py --before /path/to/old/src   # old tree vs this one
    python benchmarks/forward_targets.py                             # this tree only
    python benchmarks/forward_targets.py --only servo --repeat 15    # one row, less noise

``--before`` is the ``src`` folder of another checkout (e.g. ``git worktree add /tmp/old
<commit>``, or ``git archive <commit> src | tar -x -C /tmp/old``); every measurement runs in
a fresh child process that imports flexlink from that folder or from this tree's ``src``.
Rows, each a CPU-time median of ``--repeat`` runs of the whole ``simulate`` after a warm-up
(numba's compilation excluded):

- hub–beam small (tests/validation/forward_fe_cases.py: pinned hub, bang-bang torque, 4 s,
  4 modes): ``simulate`` at rtol 1e-3 … 1e-6, error = the largest difference of any channel
  from solve_ivp DOP853 at rtol 1e-10 over the same equations, relative to its peak; the
  cheapest run within 1e-3 against Exudyn's coarsest mesh within 1% of the converged FE
  model (16 elements, dt 1 ms; its solver's CPU time, as benchmarks/forward_vs_fe.py
  times its wall time), timed in the same run;
- ``examples/paper_servo.toml`` against its prescribed manoeuvre (the same scenario with
  each joint following its servo's reference);
- momentum of a free hub with two appendages, an internal bang-bang torque and a bang-bang
  moment over the first second, 10 s at the default rtol: the largest change of the linear
  momentum, and of the angular momentum after the moment, relative to their size.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
import statistics
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from _timing import use_tree

ROOT = Path(__file__).resolve().parents[1]
RTOLS = (1e-3, 1e-4, 1e-5, 1e-6)


def _cpu(scenario: Any, repeat: int) -> tuple[float, Any]:
    import flexlink

    flexlink.simulate(dataclasses.replace(scenario, settings=dataclasses.replace(
        scenario.settings, t_end=min(0.05, scenario.settings.t_end))), shapes=False)
    times, results = [], None
    for _ in range(repeat):
        start = time.process_time()
        results = flexlink.simulate(scenario, shapes=False)
        times.append(time.process_time() - start)
    return statistics.median(times), results


def _hub_beam(rtol: float, repeat: int) -> dict[str, Any]:
    from tests.validation.forward_fe_cases import CASES, flexlink_scenario

    scenario = flexlink_scenario(CASES["hub_beam_small"], 4)
    if rtol == 0.0:
        settings = dataclasses.replace(scenario.settings, method="DOP853", rtol=1e-10,
                                       atol=1e-12)
    else:
        settings = dataclasses.replace(scenario.settings, rtol=rtol, atol=1e-12)
    cpu, results = _cpu(dataclasses.replace(scenario, settings=settings), repeat)
    return {"cpu": cpu, "signals": {n: np.asarray(results[n]) for n in results.names}}


def _exudyn(repeat: int) -> tuple[float, float]:
    """Exudyn's solver on the hub–beam: median wall and CPU (process) time, s."""
    from tests.validation import exudyn_forward_reference as reference
    from tests.validation.forward_fe_cases import CASES, exudyn_signals

    solve, cpus = reference.solve_dynamic, []

    def timed(*args: Any, **kwargs: Any) -> Any:
        start = time.process_time()
        out = solve(*args, **kwargs)
        cpus.append(time.process_time() - start)
        return out

    reference.solve_dynamic = timed
    walls = [exudyn_signals(CASES["hub_beam_small"], 16, 1e-3)[1]["wall_time_s"]
             for _ in range(repeat)]
    return statistics.median(walls), statistics.median(cpus)


def _servo(repeat: int) -> tuple[float, float]:
    import flexlink
    from flexlink.model import Chain

    servo = flexlink.load_scenario(ROOT / "examples" / "paper_servo.toml")
    prescribed = dataclasses.replace(servo, chain=Chain(
        servo.chain.links, tuple(j.reference for j in servo.chain.joints)))
    return _cpu(servo, repeat)[0], _cpu(prescribed, repeat)[0]


def _momentum() -> tuple[float, float]:
    import flexlink
    from flexlink.model import BangBang, BaseLoad
    from tests.validation.test_forward import _free_hub

    r = flexlink.simulate(_free_hub((BaseLoad(moment=BangBang(1.0, 0.0, 1.0)),)),
                          shapes=False)
    t = np.asarray(r.time)
    linear = np.column_stack([r["momentum_x"], r["momentum_y"]])
    angular = np.asarray(r["angular_momentum"])[t >= 1.0]
    return (float(np.abs(linear - linear[0]).max() / np.linalg.norm(linear[0])),
            float(np.abs(angular - angular[0]).max() / abs(angular[0])))


def _child(src: str, what: str, *args: Any) -> Any:
    with ProcessPoolExecutor(1, initializer=use_tree, initargs=(src,)) as pool:
        return pool.submit(globals()[what], *args).result()


def _error(signals: dict[str, np.ndarray], reference: dict[str, np.ndarray]) -> float:
    worst = 0.0
    for key, ref in reference.items():
        peak = np.abs(ref).max()
        if key in signals and peak > 1e-12:
            worst = max(worst, float(np.abs(signals[key] - ref).max() / peak))
    return worst


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", help="src folder of the tree to compare with")
    parser.add_argument("--repeat", type=int, default=7, help="timed runs per row (median)")
    parser.add_argument("--only", choices=("hub_beam", "servo", "momentum"),
                        help="run only these rows (and no Exudyn)")
    args = parser.parse_args()
    trees = ([("before", args.before)] if args.before else []) + [("after", str(ROOT / "src"))]
    print(f"# {platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numpy {np.__version__}, load average {os.getloadavg()[0]:.1f}")
    exudyn = None
    if args.only is None:
        wall, exudyn = _child(str(ROOT / "src"), "_exudyn", 3)
        print(f"Exudyn, hub–beam small, 16 elements, dt 1 ms (coarsest within 1%): solver CPU "
              f"{exudyn:.3g} s (wall {wall:.3g} s)")
    print("| tree | row | CPU [s] | error / peak or ratio |")
    print("|---|---|---|---|")
    for label, src in trees:
        if args.only in (None, "hub_beam"):
            _hub_beam_rows(label, src, args.repeat, exudyn)
        if args.only in (None, "servo"):
            servo, prescribed = _child(src, "_servo", args.repeat)
            print(f"| {label} | paper_servo / its prescribed manoeuvre | {servo:.3g} / "
                  f"{prescribed:.3g} | {servo / prescribed:.2f}× |", flush=True)
        if args.only in (None, "momentum"):
            linear, angular = _child(src, "_momentum")
            print(f"| {label} | free hub 10 s, default rtol: momentum drift (linear, angular) "
                  f"| | {linear:.1e}, {angular:.1e} |", flush=True)


def _hub_beam_rows(label: str, src: str, repeat: int, exudyn: float | None) -> None:
    """The hub–beam rows of one tree (the cheapest within 1e-3 against Exudyn's solver CPU
    time when given)."""
    reference = _child(src, "_hub_beam", 0.0, 1)["signals"]
    best = None
    for rtol in RTOLS:
        run = _child(src, "_hub_beam", rtol, repeat)
        err = _error(run["signals"], reference)
        print(f"| {label} | hub–beam small, rtol {rtol:g} | {run['cpu']:.3g} | {err:.2g} |",
              flush=True)
        if err <= 1e-3 and (best is None or run["cpu"] < best):
            best = run["cpu"]
    if best is not None and exudyn is not None:
        print(f"| {label} | hub–beam small, cheapest within 1e-3 | {best:.3g} | "
              f"{exudyn / best:.1f}× faster than Exudyn |", flush=True)


if __name__ == "__main__":
    main()
