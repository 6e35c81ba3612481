"""Forward-run sensitivities (driven joints, moving base; compiled Radau IIA) against
converged central differences of tight-tolerance runs, and their cost against the run alone.

    python benchmarks/forward_sensitivities.py [--quick]

For each case and field: the sensitivities of every channel at rtol 1e-10 against
(c(p + δ) − c(p − δ)) / 2δ of runs at rtol 1e-12, δ = 1e-3 |p| and 2e-3 |p| combined by
Richardson (fourth order; at rtol 1e-11 or δ = 1e-4 the differences' own noise reaches
1e-6); the error is max |S − D| over time, relative to max |D| of the
channel, the worst channel reported. Then the wall time of the run with ten
sensitivities over the run alone (best of three each, default tolerance).
"""

from __future__ import annotations

import argparse
import time
import tomllib

import numpy as np

import flexlink
from flexlink.simulation.sensitivities import scenario_file

HUB_BEAM = """
[simulation]
name = "hub-beam"
t_end = 2.0
dt_out = 0.002
geometric_stiffening = true

[[links]]
name = "beam"
length = 1.0
mass_per_length = 1.0
EI = 10.0
tip_mass = 0.1
damping_ratio = 0.01
modes = 3

[[joints]]
drive = "torque"
motor_inertia = 1.0
torque = [{ profile = "bang_bang", amplitude = 2.0, start = 0.0, duration = 1.0 }]

[[sensors]]
name = "root_strain"
kind = "strain"
link = "beam"
x = 0.1
thickness = 0.02

[[sensors]]
name = "mid_acceleration"
kind = "acceleration"
link = "beam"
x = 0.6
"""

CASES = {
    "hub_beam": (HUB_BEAM, [
        "links[0].EI", "links[0].mass_per_length", "links[0].tip_mass",
        "links[0].damping_ratio", "links[0].length", "joints[0].motor_inertia",
        "joints[0].torque[0].amplitude", "sensors[0].x", "sensors[1].x", "sensors[0].thickness"]),
    "satellite": ("examples/satellite_slew.toml", [
        "links[0].EI", "links[1].mass_per_length", "links[0].damping_ratio", "base.mass",
        "base.inertia", "base.rate_deg_s", "base.loads[0].moment[0].amplitude",
        "links[1].length", "sensors[0].x", "links[0].tip_mass"]),
    "paper_servo": ("examples/paper_servo.toml", [
        "links[0].E", "links[1].mass_per_length", "links[0].tip_mass", "links[1].damping_ratio",
        "joints[0].P", "joints[0].D", "joints[0].loop_gain", "joints[1].bandwidth",
        "joints[0].motor_inertia", "links[1].length"]),
}


def _run(file, path_values: dict, rtol: float) -> flexlink.Results:
    values = dict(path_values)
    return flexlink.simulate(file.build(values), shapes=False) if rtol is None else \
        flexlink.simulate(file.build({**values, ("simulation", "rtol"): rtol}), shapes=False)


def differences(file, text: str, rtol: float, relative: float) -> dict[str, np.ndarray]:
    target = file.locate(text)
    value = float(target.value)
    out = {}
    for scale in (1.0, 2.0):
        h = relative * scale * abs(value)
        up = _run(file, {target.path: value + h}, rtol)
        down = _run(file, {target.path: value - h}, rtol)
        out[scale] = {name: (up[name] - down[name]) / (2 * h)
                      for name in up.names}
    return {name: (4 * out[1.0][name] - out[2.0][name]) / 3 for name in out[1.0]}


def _scenario(path: str) -> flexlink.Scenario:
    if path.endswith(".toml"):
        return flexlink.load_scenario(path)
    from flexlink.scenario.load import scenario_from_dict

    return scenario_from_dict(tomllib.loads(path))


def check(name: str, path: str, fields: list[str], rtol: float) -> float:
    file = scenario_file(_scenario(path))
    sc = file.build({("simulation", "rtol"): rtol})
    res = flexlink.simulate(sc, shapes=False, sensitivities=fields)
    worst_all = 0.0
    for text in fields:
        fd = differences(file, text, 1e-12, 1e-3)
        worst, where = 0.0, ""
        for ch, d in fd.items():
            if ch not in res.sensitivities.channel.values:
                continue
            s = res.sensitivities.sel(channel=ch, field=text).values
            peak = np.max(np.abs(d))
            if peak == 0.0:
                continue
            e = np.max(np.abs(s - d)) / peak
            if e > worst:
                worst, where = e, ch
        worst_all = max(worst_all, worst)
        print(f"{name:12s} {text:28s} worst relative error {worst:.2e} ({where})", flush=True)
    return worst_all


def cost(name: str, path: str, fields: list[str]) -> None:
    sc = _scenario(path)
    flexlink.simulate(sc, shapes=False, sensitivities=fields)

    def best(f):
        times = []
        for _ in range(3):
            t = time.perf_counter()
            f()
            times.append(time.perf_counter() - t)
        return min(times)
    alone = best(lambda: flexlink.simulate(sc, shapes=False))
    both = best(lambda: flexlink.simulate(sc, shapes=False, sensitivities=fields))
    print(f"{name:12s} run {alone:.3f} s, with {len(fields)} sensitivities {both:.3f} s: "
          f"{both / alone:.1f}x", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="cost only")
    args = parser.parse_args()
    for name, (path, fields) in CASES.items():
        if not args.quick:
            check(name, path, fields, 1e-10)
        cost(name, path, fields)


if __name__ == "__main__":
    main()
