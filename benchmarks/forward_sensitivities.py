"""Forward-run sensitivities (driven joints, moving base; compiled Radau IIA) against
converged central differences of tight-tolerance runs, and their cost against the run alone.

    python benchmarks/forward_sensitivities.py [--quick] [--against REV]

For each case and field: the sensitivities of every channel at rtol 1e-10 against
(c(p + δ) − c(p − δ)) / 2δ of runs at rtol 1e-12, δ = 1e-3 |p| and 2e-3 |p| combined by
Richardson (fourth order; at rtol 1e-11 or δ = 1e-4 the differences' own noise reaches
1e-6); the error is max |S − D| over time, relative to max |D| of the
channel, the worst channel reported. Then the CPU time of the run with ten
sensitivities over the run alone (best of five each, default tolerance), and of an
objective's value and gradient in the same fields (`OBJECTIVES`: by the reverse pass of the
run's steps); with --against
REV, first the same timing of the package as committed at git revision REV (exported to a
temporary folder, run in a child process), so that before and after come from one run.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

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
        "links[1].length", "links[1].EI", "links[1].damping_ratio"]),
    "flexible_joint": ("examples/flexible_joint_arm.toml", [
        "links[0].EI", "links[0].mass_per_length", "joints[0].spring_stiffness",
        "joints[0].spring_damping", "joints[0].motor_inertia"]),
    "paper_servo": ("examples/paper_servo.toml", [
        "links[0].E", "links[1].mass_per_length", "links[0].tip_mass", "links[1].damping_ratio",
        "joints[0].P", "joints[0].D", "joints[0].loop_gain", "joints[1].bandwidth",
        "joints[0].motor_inertia", "joints[0].rate_per_volt_deg_s"]),
    "four_bar": ("examples/four_bar.toml", [
        "links[1].EI", "links[1].mass_per_length", "links[1].damping_ratio",
        "links[0].mass_per_length", "links[2].mass_per_length", "links[1].length",
        "links[2].length", "joints[2].base_point[0]", "joints[2].base_point[1]",
        "joints[0].motion[0].to_rate_deg_s"]),
    "slider_crank": ("examples/slider_crank.toml", [
        "links[1].EI", "links[1].mass_per_length", "links[1].tip_mass",
        "links[0].mass_per_length", "links[1].length", "links[0].length",
        "closures[0].ground[1]", "closures[0].angle_deg", "joints[0].motion[0].from_deg",
        "joints[0].motion[0].to_rate_deg_s"]),
}

# the satellite's first 8 s (the bang-bang's switch at 10 s stays outside): the
# differences' runs at rtol 1e-12 over its 30 s would take minutes each
OVERRIDES = {"satellite": {("simulation", "t_end"): 8.0},
             # the closed loops' first half second (four-bar: the crank's spin-up)
             "four_bar": {("simulation", "t_end"): 0.5},
             "slider_crank": {("simulation", "t_end"): 0.1}}


def _run(file, path_values: dict, rtol: float) -> flexlink.Results:
    return flexlink.simulate(file.build({**path_values, ("simulation", "rtol"): rtol}),
                             shapes=False)


def differences(file, text: str, rtol: float, overrides: dict
                ) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """Converged central differences of every channel in field ``text``: D(δ) at δ = 4e-3,
    2e-3, 1e-3, 5e-4 of |p| (runs at ``rtol``), Richardson R(δ) = (4 D(δ) − D(2δ)) / 3 for
    the three smaller δ, and of the two consecutive R that agree best (per channel: large δ
    where the runs' noise dominates, small where truncation does) their mean; also that
    pair's disagreement relative to the channel's peak derivative (the reference's own
    uncertainty)."""
    target = file.locate(text)
    value = float(target.value)
    rel = [4e-3, 2e-3, 1e-3, 5e-4]
    D = []
    for r in rel:
        h = r * (abs(value) or 1.0)  # a zero field: steps in its unit
        up = _run(file, {**overrides, target.path: value + h}, rtol)
        down = _run(file, {**overrides, target.path: value - h}, rtol)
        D.append({name: (up[name] - down[name]) / (2 * h) for name in up.names})
    out, spread = {}, {}
    for name in D[0]:
        R = [(4 * D[i + 1][name] - D[i][name]) / 3 for i in range(3)]
        peak = max(np.max(np.abs(R[-1])), 1e-300)
        gaps = [np.max(np.abs(R[i + 1] - R[i])) / peak for i in range(2)]
        best = int(np.argmin(gaps))
        out[name] = 0.5 * (R[best] + R[best + 1])
        spread[name] = gaps[best]
    return out, spread


def _scenario(path: str) -> flexlink.Scenario:
    if path.endswith(".toml"):
        return flexlink.load_scenario(path)
    from flexlink.scenario.load import scenario_from_dict

    return scenario_from_dict(tomllib.loads(path))


def check(name: str, path: str, fields: list[str], rtol: float, overrides: dict) -> float:
    """Print, per field, the worst channel's error of the sensitivities (at ``rtol``)
    against converged differences (at rtol 1e-12), relative to its peak derivative."""
    file = scenario_file(_scenario(path))
    sc = file.build({**overrides, ("simulation", "rtol"): rtol})
    res = flexlink.simulate(sc, shapes=False, sensitivities=fields)
    worst_all = 0.0
    for text in fields:
        fd, spread = differences(file, text, 1e-12, overrides)
        largest = max(np.max(np.abs(res[name])) for name in res.names)
        value = abs(float(file.locate(text).value)) or 1.0
        worst, where = 0.0, ""
        for ch, d in fd.items():
            if ch not in res.sensitivities.channel.values:
                continue
            s = res.sensitivities.sel(channel=ch, field=text).values
            peak = np.max(np.abs(d))
            if not peak > 0.0 or np.max(np.abs(res[ch])) <= 1e-9 * largest:
                continue  # a channel that stays zero to round-off (a conserved momentum)
            # a channel the field does not move: its derivative is zero to round-off
            peak = max(peak, 1e-3 * np.max(np.abs(res[ch])) / value)
            e = np.max(np.abs(s - d)) / peak
            if e > worst:
                worst, where = e, ch
        worst_all = max(worst_all, worst)
        print(f"{name:12s} {text:36s} worst relative error {worst:.1e} ({where}; the "
              f"differences' own spread there {spread.get(where, 0.0):.1e})", flush=True)
    return worst_all


# the objective per case: the mean square of a sensor on the modes after 30% of the run
OBJECTIVES = {"hub_beam": "root_strain", "satellite": "right_root_strain",
              "paper_servo": "link2_tip_deflection", "flexible_joint": "arm_tip_deflection"}


def objective_cost(name: str, path: str, fields: list[str], overrides: dict) -> None:
    """Print the CPU time of `flexlink.Objective`'s value and gradient in the fields (the
    mean square of `OBJECTIVES`' channel after 30% of the run) over the run alone, how the
    gradient was computed, and its largest difference from the tangents' gradient
    (relative to its largest component)."""
    sc = scenario_file(_scenario(path)).build(overrides)
    channel = OBJECTIVES[name]
    metric = flexlink.MeanSquare(channel, after=0.3 * sc.settings.t_end)
    objective = flexlink.Objective(sc, fields, metric)

    def gradient() -> None:
        objective._last = None  # a new evaluation each time, not the remembered one
        objective(objective.x0)

    gradient()
    results = flexlink.simulate(sc, shapes=False, sensitivities=fields)
    _, slopes = metric(results)
    tangents = slopes[channel] @ results.sensitivities.sel(channel=channel).values
    _, g = objective(objective.x0)
    alone = _best(lambda: flexlink.simulate(sc, shapes=False))
    both = _best(gradient)
    print(f"{name:12s} run {alone:.3f} s, objective + gradient ({objective.method}, "
          f"{len(fields)} fields) {both:.3f} s (CPU): {both / alone:.1f}x; against the "
          f"tangents {np.abs(g - tangents).max() / np.abs(tangents).max():.1e}", flush=True)


def _best(f) -> float:
    times = []
    for _ in range(5):
        t = time.process_time()
        f()
        times.append(time.process_time() - t)
    return min(times)


def cost(name: str, path: str, fields: list[str], overrides: dict) -> None:
    """Print the CPU time of the run with the sensitivities over the run alone (the
    process's CPU time: on a loaded machine wall time counts the other processes too)."""
    sc = scenario_file(_scenario(path)).build(overrides)
    flexlink.simulate(sc, shapes=False, sensitivities=fields)
    alone = _best(lambda: flexlink.simulate(sc, shapes=False))
    both = _best(lambda: flexlink.simulate(sc, shapes=False, sensitivities=fields))
    print(f"{name:12s} run {alone:.3f} s, with {len(fields)} sensitivities {both:.3f} s "
          f"(CPU): {both / alone:.1f}x", flush=True)


def _export(revision: str, folder: str) -> str:
    """The package's src/ as of git ``revision``, unpacked under ``folder``."""
    root = Path(__file__).resolve().parent.parent
    archive = subprocess.run(["git", "-C", str(root), "archive", revision, "src"],
                             check=True, capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", folder], input=archive, check=True)
    return os.path.join(folder, "src")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="cost only")
    parser.add_argument("--case", choices=list(CASES), action="append",
                        help="only these cases (default: all)")
    parser.add_argument("--against", metavar="REV",
                        help="also time the package at git revision REV (before)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        before = _export(args.against, folder) if args.against else None
        for name in args.case or list(CASES):
            path, fields = CASES[name]
            overrides = OVERRIDES.get(name, {})
            if not args.quick:
                check(name, path, fields, 1e-10, overrides)
            if before is not None:
                print(f"before ({args.against}):", flush=True)
                subprocess.run([sys.executable, __file__, "--quick", "--case", name],
                               env={**os.environ, "PYTHONPATH": before}, check=True)
                print("after:", flush=True)
            cost(name, path, fields, overrides)
            if name in OBJECTIVES:
                objective_cost(name, path, fields, overrides)


if __name__ == "__main__":
    main()
