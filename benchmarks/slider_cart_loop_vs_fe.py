"""First-order sliders on a moving base and inside a closed loop: flexlink against a
geometrically exact FE model (Exudyn), timed side by side in one run.

    python benchmarks/slider_cart_loop_vs_fe.py [--repeat 5] [--cases cart loop]
    python benchmarks/slider_cart_loop_vs_fe.py --before /path/to/old/src --model first_order

Two cases. ``cart``: Case 23's slider (tests/validation/test_prismatic.py `slider_fe_case`: a
rigid link turned by a bang-bang moment, a block pushed along it by a bang-bang force,
carrying a flexible beam with a tip mass; 2 s, undamped) with the link's pin on a free 1 kg
cart along x (tests/validation/test_first_order_slider_travel.py's Exudyn check; Exudyn:
exudyn_slider_reference with ``cart_mass``). ``loop``: the crank–slider–post–rod mechanism of
tests/validation/test_nonlinear_slider_loops.py (a crank carrying a slider along its axis, a
post on the block, a rod pinned to the ground), crank (EI 40 N·m²) and rod (EI 5 N·m²)
flexible, a 0.02 kg·m² hub under a 0.3 N·m torque step, the block under a ±0.5 N bang-bang
force; 0.5 s, undamped (Exudyn: exudyn_slider_loop_reference).

flexlink: the stiffened first-order model at its defaults (rtol 1e-4) at two mode counts (the
loop also with 3 modes on the crank and 2 on the rod), and the nonlinear model's default for
comparison. Exudyn (Simo–Reissner beams, generalized-α without numerical damping): the
reference is its finest mesh and step; flexlink's time is compared with the cheapest coarser
mesh and step within 1% of it on every signal the mesh is chosen by (max error / the
reference's peak). Times: CPU (process) seconds, flexlink's whole
``simulate`` call without the animation's shapes (median of ``--repeat`` after a warm-up:
numba's compilation excluded) in a spawned process importing this tree, Exudyn's solver only.

``--before`` is the ``src`` folder of another checkout: each flexlink row then runs in two
fresh child processes, one importing flexlink from that folder and one from this tree's
``src``, one after the other, so that both share the machine's load of the moment;
``--model`` keeps that model's rows only.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import math
import multiprocessing
import os
import platform
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
from _timing import median_cpu, use_tree

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


def _cart(model: str, modes: int) -> Any:
    from flexlink.model import Base, Cart
    from tests.validation.test_prismatic import slider_fe_case

    scenario, _ = slider_fe_case(modes)
    return dataclasses.replace(scenario, base=Base("cart", mass=1.0, cart=Cart()),
                               settings=dataclasses.replace(scenario.settings, model=model,
                                                            rtol=None))


def _cart_exudyn(elements: int, dt: float) -> dict[str, Any]:
    from tests.validation.exudyn_slider_reference import simulate_slider_exudyn
    from tests.validation.test_prismatic import slider_fe_case

    _, args = slider_fe_case()
    return simulate_slider_exudyn(**args, elements=elements, dt=dt, cart_mass=1.0,
                                  link_mass=1.0)


HUB_INERTIA = 0.02  # kg·m², the crank's motor: a massless hub leaves the root's slope unsettled
# m, the Exudyn loop's section depth (EA = 12 EI/h², GA and ρI from it). flexlink's links are
# inextensible Euler–Bernoulli beams; Exudyn's shear, rotary inertia and stretch lower the
# loop's frequencies by (h/L)² terms. At h = 0.01 (rod: L/40) that was ~0.1%, a phase lag
# of 0.4 ms after 0.42 s: 1.2% of the crank tip's and 5.5% of the rod midpoint's peak. At
# 0.005 they are 0.2% and 1.1%; thinner sections stall Exudyn's Newton at fine meshes.
LOOP_THICKNESS = 0.005


def _loop_dict() -> dict:
    from tests.validation.test_nonlinear_slider_loops import CRANK, ROD, slider_loop_case

    d = slider_loop_case("force", flexible=True)
    d["joints"][0]["motor_inertia"] = HUB_INERTIA
    d["sensors"] = [{"name": "crank_tip", "kind": "deflection", "link": "crank", "x": CRANK},
                    {"name": "rod_mid", "kind": "deflection", "link": "rod", "x": ROD / 2}]
    del d["simulation"]["rtol"]
    return d


def _loop(model: str, modes: int | tuple[int, int]) -> Any:
    """The loop with ``modes`` modes on each flexible link, or (crank, rod) modes."""
    from flexlink.scenario import scenario_from_dict

    d = copy.deepcopy(_loop_dict())
    d["simulation"].update(model=model, geometric_stiffening=True)
    per_link = dict(zip(("crank", "rod"), modes if isinstance(modes, tuple) else (modes,) * 2))
    for link in d["links"]:
        if "modes" in link:
            link["modes"] = per_link[link["name"]]
    return scenario_from_dict(d)


def _loop_exudyn(elements: int, dt: float) -> dict[str, Any]:
    from flexlink.model import Link
    from tests.validation.exudyn_slider_loop_reference import simulate_slider_loop_exudyn

    d = _loop_dict()
    scenario = _loop("first_order", 2)
    joints = scenario.chain.joints
    crank, post, rod = (Link(link["name"], link["length"], link["mass_per_length"],
                             link.get("EI", math.inf)) for link in d["links"])
    settings = scenario.settings
    return simulate_slider_loop_exudyn(
        crank, post, rod, d["joints"][1]["mass"], d["joints"][1]["initial_position"],
        lambda t: float(joints[0].torque.value(np.array([t]))[0]),
        lambda t: float(joints[1].drive.torque.value(np.array([t]))[0]),
        settings.t_end, settings.dt_out, elements, dt, hub_inertia=HUB_INERTIA,
        thickness=LOOP_THICKNESS)


# case: flexlink scenario, Exudyn run, (flexlink channel, Exudyn signal, chooses the mesh),
# the reference and the ladder (elements, step s), flexlink's (model, modes) rows
CASES: dict[str, dict[str, Any]] = {
    "cart": {"title": "Case 23's slider on a free 1 kg cart", "flexlink": _cart,
             "exudyn": _cart_exudyn,
             "signals": (("joint1_angle", "angle", True), ("joint2_position", "travel", True),
                         ("cart_position", "cart", True), ("tip", "tip_deflection", True)),
             "reference": (64, 1.25e-4),
             "ladder": ((8, 5e-4), (16, 5e-4), (16, 2.5e-4), (32, 5e-4)),
             "rows": (("first_order", 4), ("first_order", 6), ("nonlinear", 4))},
    "loop": {"title": "a slider inside a closed loop (crank, slider, post, rod)",
             "flexlink": _loop, "exudyn": _loop_exudyn,
             "signals": (("joint1_angle", "crank_angle", True),
                         ("joint2_position", "travel", True),
                         ("crank_tip", "crank_deflection", True),
                         ("rod_mid", "rod_deflection", False)),
             # the rod midpoint moves by 0.25% of its peak from 6.25e-5 s to 3.125e-5 s
             # (64 elements), the crank tip by 0.06%: the reference takes the finer step.
             # 128 elements move them by 0.72% and 0.20% more (softer: linear elements
             # converge from the stiff side) but cost ~150 s of Newton, so it stays at 64
             "reference": (64, 3.125e-5),
             "ladder": ((8, 2.5e-4), (16, 2.5e-4), (16, 1.25e-4), (32, 2.5e-4),
                        (32, 1.25e-4), (64, 6.25e-5)),
             # (crank, rod) modes (3, 2): of the 4-mode row's gain in the rod's midpoint,
             # the crank's third mode brings nearly all, the rod's own modes almost nothing
             "rows": (("first_order", 2), ("first_order", 4), ("first_order", (3, 2)),
                      ("nonlinear", 2))},
}


def _flexlink(case: str, model: str, modes: int, repeat: int
              ) -> tuple[float, dict[str, np.ndarray], float]:
    """CPU seconds (median of ``repeat`` after a warm-up), the compared channels and the
    run's relative closure residual (NaN without closures) of one row."""
    from flexlink import simulate

    spec = CASES[case]
    scenario = spec["flexlink"](model, modes)
    cpu, run = median_cpu(lambda: simulate(scenario, shapes=False), repeat)
    return (cpu, {a: np.asarray(run[a]) for a, _, _ in spec["signals"]},
            float(run.metadata.get("closure_residual_relative", math.nan)))


def _child(src: str, *args: Any) -> Any:
    # spawned, not forked: nothing of this process's imports
    with ProcessPoolExecutor(1, mp_context=multiprocessing.get_context("spawn"),
                             initializer=use_tree, initargs=(src,)) as pool:
        return pool.submit(_flexlink, *args).result()


def _errors(ours: dict[str, np.ndarray], reference: dict[str, Any],
            signals: tuple) -> list[float]:
    return [float(np.abs(np.asarray(ours[a]) - reference[b]).max()
                  / np.abs(reference[b]).max()) for a, b, _ in signals]


def compare(case: str, repeat: int, trees: list[tuple[str, str]], only: str | None = None
            ) -> None:
    """Exudyn's ladder and flexlink's rows of one case (model ``only``'s if set) for each
    (label, src folder) of ``trees``, in this run."""
    spec = CASES[case]
    signals = spec["signals"]
    print(f"\n== {spec['title']}")
    rows = [(label, model, modes, _child(src, case, model, modes, repeat))
            for model, modes in spec["rows"] if only in (None, model)
            for label, src in trees]
    fine = spec["exudyn"](*spec["reference"])
    names = ", ".join(b + ("" if chooses else " (not choosing)") for _, b, chooses in signals)
    print(f"Exudyn reference: {spec['reference'][0]} elements, steps {spec['reference'][1]:g} s,"
          f" {fine['cpu_time_s']:.2f} s of CPU; errors of peak: {names}")
    chosen = ("the reference", fine["cpu_time_s"])
    for elements, dt in spec["ladder"]:
        out = spec["exudyn"](elements, dt)
        errs = [float(np.abs(out[b] - fine[b]).max() / np.abs(fine[b]).max())
                for _, b, _ in signals]
        worst = max(e for e, (_, _, c) in zip(errs, signals) if c)
        print(f"  {elements:3d} {dt:8.2e} {out['coordinates']:5d} {out['cpu_time_s']:7.3f} s "
              + " ".join(f"{e:8.2e}" for e in errs), flush=True)
        if worst < 0.01 and out["cpu_time_s"] < chosen[1]:
            chosen = (f"{elements} elements, steps {dt:g} s", out["cpu_time_s"])
    print(f"compared with the cheapest within 1%: {chosen[0]}, {chosen[1]:.3f} s of CPU")
    print("flexlink: tree, model, modes, CPU s (median), errors of peak, closure residual, "
          "speed-up (CPU) against that mesh")
    for label, model, modes, (cpu, ours, closure) in rows:
        errs = _errors(ours, fine, signals)
        print(f"  {label:6s} {model:11s} {modes!s:6s} {cpu:8.4f} " + " ".join(f"{e:8.2e}" for e in errs)
              + f" {closure:8.1e} {chosen[1] / cpu:6.1f}x (target 20x)", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--cases", nargs="+", choices=tuple(CASES), default=tuple(CASES))
    parser.add_argument("--before", help="src folder of the tree to compare with")
    parser.add_argument("--model", choices=("first_order", "nonlinear"),
                        help="only this model's rows")
    args = parser.parse_args()
    trees = ([("before", args.before)] if args.before else []) + [("after", str(ROOT / "src"))]
    print(f"# {platform.machine()} {os.cpu_count()} cores, Python {platform.python_version()}, "
          f"numpy {np.__version__}, load average {os.getloadavg()[0]:.1f}")
    for case in args.cases:
        compare(case, args.repeat, trees, args.model)


if __name__ == "__main__":
    main()
