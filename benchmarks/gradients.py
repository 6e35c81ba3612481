"""Sensitivities (`flexlink.simulate(..., sensitivities=...)`): cost and accuracy side by side.

    python benchmarks/gradients.py              # the paper run, ten fields
    python benchmarks/gradients.py --repeat 20

Rows, in one process after one untimed run of each kind (numba's compilation):

- ``run alone``: CPU time (process time) of `simulate` of the paper experiment (5 s, Lawson,
  rtol 1e-6), the median of ``--repeat`` runs;
- ``run + N sensitivities``: the same run with the ten fields of `FIELDS` (bending stiffness,
  mass per length, tip mass, damping ratios, sensor gains, joint angles, a thickness), the
  median, and its ratio to the run alone (issue 28's target: at most 3): every channel's
  derivatives, from the fields' tangents;
- ``objective + gradient``: `flexlink.Objective` of the mean square of the link 2 tip
  deflection sensor after 1.5 s in the same fields, value and gradient (one reverse pass of
  the run's steps), the median and its ratio to the run alone, and the gradient's largest
  difference from the tangents' (relative to the largest component);
- per field, the largest error over the channels of ∂channel/∂field against fourth-order
  central differences of runs on the run's own discretisation (steps 1e-4 × the value, and
  3e-5 × to show the differences have converged), each relative to the channel's largest
  derivative (target: 1e-6).

The machine is shared: CPU time is the figure that load moves least; the load average and
the machine are printed.
"""

from __future__ import annotations

import argparse
import os
import platform
import time

import numpy as np

import flexlink
from flexlink.scenario.fields import ScenarioFile
from flexlink.simulation.common import output_times
from flexlink.simulation.prescribed import run_prescribed
from flexlink.simulation.sensitivities import scenario_file
from flexlink.solvers.lawson import integrate_lawson_discretised, integrate_lawson_on

FIELDS = ("links[0].EI", "links[1].mass_per_length", "links[0].tip_mass",
          "links[1].damping_ratio", "links[0].damping_ratio", "sensors[pzt].capacitance",
          "sensors[pzt].d31", "joints[1].motion[0].to_deg", "joints[0].motion[0].from_deg",
          "links[1].thickness")


def _cpu_median(run: object, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.process_time()
        run()  # type: ignore[operator]
        times.append(time.process_time() - start)
    return float(np.median(times))


def _differences(file: ScenarioFile, field: str, relative: float) -> dict[str, np.ndarray]:
    """Every channel's derivative by fourth-order central differences of runs on the
    discretisation of the run at the file's values."""
    scenario = file.build()
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    settled = []

    def adaptive(system, times, rtol, atol, progress):
        solution, disc = integrate_lawson_discretised(system, times, rtol, atol, progress)
        settled.append(disc)
        return solution

    run_prescribed(scenario, t, lambda _: None, False, adaptive)

    def on(system, times, rtol, atol, progress):
        return integrate_lawson_on(system, times, settled[0])

    target = file.locate(field)
    value = float(target.value)
    h = relative * abs(value) if value else relative
    runs = {j: run_prescribed(file.build({target.path: value + j * h}), t, lambda _: None,
                              False, on).values for j in (-2, -1, 1, 2)}
    return {name: (8 * (runs[1][name] - runs[-1][name]) - (runs[2][name] - runs[-2][name]))
            / (12 * h) for name in runs[1]}


def _worst(results: flexlink.Results, field: str, fd: dict[str, np.ndarray]) -> float:
    worst = 0.0
    for name, d in fd.items():
        scale = np.abs(d).max()
        if scale > 0:
            got = results.sensitivity(name, field).values
            worst = max(worst, float(np.abs(got - d).max() / scale))
    return worst


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as info:
            for line in info:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=10)
    args = parser.parse_args()
    scenario = flexlink.load_paper_experiment()
    file = scenario_file(scenario)
    print(f"# {platform.machine()} {_cpu_model()} {os.cpu_count()} cores, "
          f"Python {platform.python_version()}, numpy {np.__version__}, "
          f"load {os.getloadavg()[0]:.1f}")
    flexlink.simulate(scenario, shapes=False)
    results = flexlink.simulate(scenario, shapes=False, sensitivities=list(FIELDS))
    alone = _cpu_median(lambda: flexlink.simulate(scenario, shapes=False), args.repeat)
    both = _cpu_median(lambda: flexlink.simulate(scenario, shapes=False,
                                                 sensitivities=list(FIELDS)), args.repeat)
    print(f"run alone                         {alone * 1e3:8.1f} ms CPU")
    print(f"run + {len(FIELDS)} sensitivities          {both * 1e3:8.1f} ms CPU   "
          f"ratio {both / alone:5.1f} (target <= 3)")
    metric = flexlink.MeanSquare("link2_tip_deflection", after=1.5)
    objective = flexlink.Objective(scenario, list(FIELDS), metric)

    def gradient() -> None:
        objective._last = None  # a new evaluation each time, not the remembered one
        objective(objective.x0)

    gradient()
    reverse = _cpu_median(gradient, args.repeat)
    _, g = objective(objective.x0)
    _, slopes = metric(results)
    tangents = slopes["link2_tip_deflection"] @ results.sensitivities.sel(
        channel="link2_tip_deflection").values
    print(f"objective + gradient ({objective.method})   {reverse * 1e3:8.1f} ms CPU   "
          f"ratio {reverse / alone:5.1f} (target <= 3); against the tangents "
          f"{np.abs(g - tangents).max() / np.abs(tangents).max():.1e}")
    print(f"{'field':34s} {'max rel. error':>15s} {'(steps 3e-5)':>13s}")
    worst = 0.0
    for field in FIELDS:
        e1 = _worst(results, field, _differences(file, field, 1e-4))
        e2 = _worst(results, field, _differences(file, field, 3e-5))
        worst = max(worst, e1)
        print(f"{field:34s} {e1:15.2e} {e2:13.2e}")
    print(f"largest error {worst:.2e} (target < 1e-6); load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
