"""Calibrate the first-order forward runs' validity warning (flexlink/simulation/accuracy.py,
`forward_validity`) against the nonlinear model.

    python scripts/forward_validity_calibration.py             # runs every case, prints
    python scripts/forward_validity_calibration.py --table-only # reprints the recorded rows

Forward runs (driven joints, a free or moving base, carts, sliders, closed loops) drive their
rigid coordinates from forces, so the first-order model's error feeds back into the motion and
grows with time; the prescribed runs' estimate (scripts/accuracy_calibration.py) does not hold
there. Each case runs the nonlinear model (the reference, rtol 1e-7) and the first-order model
(stiffened and the paper's, rtol 1e-7): a torque-driven hub–beam, a free hub with two
appendages, a beam on an elastic joint, a cart carrying a hanging beam (the cases of
tests/validation/forward_fe_cases.py, their loads varied), examples/gravity_release.toml's
arm spun up in a level plane and pushed by a torque (spin, torque and duration varied),
examples/paper_servo.toml (the stroke and its duration varied), a hub on a velocity servo
carrying a beam through an elastic joint (examples/flexible_joint_arm.toml, speed varied),
examples/telescoping_arm.toml (the boom's and the slider's move varied),
examples/four_bar.toml (crank speed varied); and closed loops whose links a closure holds at
both ends (`loop_cases`: the benchmark four-bar, four_bar.toml and slider_crank.toml with
speed, the held link's EI and the piston varied), whose measure (`loop_held_measure`: the
span deflection, the tip's being zero) the rows record as loop_span, loop_axial,
loop_measure; only mid-span deflection is compared on those links.

For each first-order run: the quantities the warning reads from the run (per link: the peak
tip deflection per length δ and the axial load parameter S) and the measured error, the
largest over the compared channels (every elastic link's tip and mid-span deflection, every joint's angle or
travel and rate, a cart's travel, a free base's attitude; each as max |first order −
nonlinear| over the nonlinear peak). The rows go to scripts/forward_validity_calibration.csv;
the table printed shows which runs warn and the largest error of a run that does not.
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import re
import sys
import tomllib
from collections.abc import Callable
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from flexlink.model import PointSensor, Scenario
from flexlink.model.basis import held_by_loop
from flexlink.scenario import scenario_from_dict
from flexlink.simulation import simulate

CSV = Path(__file__).with_suffix(".csv")
FIELDS = ("case", "stiffening", "link", "deflection_per_length", "axial_load",
          "free_measure", "loop_link", "loop_span", "loop_axial", "loop_measure",
          "measured_error", "worst_channel", "warned", "warning")
COMPARED = re.compile(r"^(tip|mid)\d+$|^joint\d+_(angle|rate|position|velocity|motor_angle)$|"
                      r"^cart_(position|velocity)$|^base_attitude(_rate)?$")


def _example(name: str) -> dict:
    with open(ROOT / "examples" / f"{name}.toml", "rb") as file:
        return tomllib.load(file)


def spinning_arm(torque: float, rate_deg_s: float, t_end: float, hub: float = 0.0
                 ) -> Scenario:
    """examples/gravity_release.toml's arm in a level plane, spun up to ``rate_deg_s`` at
    t = 0 and pushed by a constant ``torque`` (N·m); ``hub``: a hub's inertia on its joint
    (kg·m²; the arm's own about the joint is 0.23)."""
    d = _example("gravity_release")
    joint = d["joints"][0]
    if hub:
        joint["motor_inertia"] = hub
    joint["torque"][0]["amplitude"] = torque
    joint["initial_rate_deg_s"] = rate_deg_s
    d["simulation"].update(t_end=t_end, dt_out=0.001, gravity=[0.0, 0.0])
    return scenario_from_dict(d)


def paper_servo(stroke_deg: float, duration: float) -> Scenario:
    """examples/paper_servo.toml, joint 1's stroke and both moves' duration changed."""
    d = _example("paper_servo")
    ref = d["joints"][0]["reference"][0]
    ref.update(to_deg=stroke_deg, duration=duration)
    d["joints"][1]["reference"][0]["duration"] = duration
    d["simulation"]["t_end"] = 0.5 + duration + 1.0
    return scenario_from_dict(d)


def servo_arm(turn_deg: float, duration: float) -> Scenario:
    """examples/flexible_joint_arm.toml (a velocity servo on the motor of an elastic joint):
    the link turned ``turn_deg`` in ``duration`` (s)."""
    d = _example("flexible_joint_arm")
    ref = d["joints"][0]["reference"][0]
    ref.update(to_deg=turn_deg * d["joints"][0]["gear_ratio"], duration=duration)
    d["joints"][0]["torque_limit"] = 5.0
    d["simulation"]["t_end"] = 0.2 + duration + 0.8
    return scenario_from_dict(d)


def telescoping(duration: float) -> Scenario:
    """examples/telescoping_arm.toml (a slider on the boom's tip carrying the arm), the
    boom's 90° and the slider's stroke in ``duration`` (s)."""
    d = _example("telescoping_arm")
    d["joints"][0]["motion"][0]["duration"] = duration
    d["joints"][1]["motion"][0]["duration"] = duration
    d["simulation"]["t_end"] = duration + 0.5
    return scenario_from_dict(d)


def four_bar(rate_deg_s: float, coupler_ei: float = 1.0) -> Scenario:
    """examples/four_bar.toml, the crank spun up to ``rate_deg_s``, the coupler's EI times
    ``coupler_ei``."""
    d = _example("four_bar")
    d["joints"][0]["motion"][0]["to_rate_deg_s"] = rate_deg_s
    d["links"][1]["EI"] *= coupler_ei
    d["simulation"]["t_end"] = 1.0
    return scenario_from_dict(d)


def four_bar_benchmark(rpm: float, coupler_ei: float = 1.0, rigid_crank: bool = False,
                       t_end: float = 0.6) -> Scenario:
    """examples/four_bar_benchmark.toml, the crank spun up to ``rpm`` (rigid if
    ``rigid_crank``), the coupler's bending stiffness times ``coupler_ei`` (thickness
    scaled, mass kept), run to ``t_end`` (s)."""
    d = _example("four_bar_benchmark")
    if rigid_crank:
        d["links"][0] = {k: v for k, v in d["links"][0].items() if k not in
                         ("E", "width", "thickness", "modes")} | {"rigid": True}
    d["joints"][0]["motion"][0]["to_rate_deg_s"] = 6.0 * rpm
    d["links"][1]["thickness"] *= coupler_ei ** (1.0 / 3.0)
    d["simulation"]["t_end"] = t_end
    return scenario_from_dict(d)


def slider_crank(rate_rad_s: float, rod_ei: float = 1.0, piston: float = 0.05) -> Scenario:
    """examples/slider_crank.toml, the crank spun up to ``rate_rad_s``, the rod's EI times
    ``rod_ei``, a ``piston`` of that mass (kg) on the rod's tip."""
    d = _example("slider_crank")
    d["joints"][0]["motion"][0]["to_rate_deg_s"] = float(np.degrees(rate_rad_s))
    d["links"][1]["EI"] *= rod_ei
    d["links"][1]["tip_mass"] = piston
    return scenario_from_dict(d)


def fe_case(name: str, amplitude: float) -> Scenario:
    """A case of tests/validation/forward_fe_cases.py with 4 modes, its load ``amplitude``."""
    from tests.validation.forward_fe_cases import CASES, flexlink_scenario

    case = dataclasses.replace(CASES[name], amplitude=amplitude)
    return flexlink_scenario(case, modes=4)


def cases() -> list[tuple[str, Callable[[], Scenario]]]:
    out: list[tuple[str, Callable[[], Scenario]]] = []
    for a in (1.0, 2.0, 5.0, 10.0, 20.0):
        out.append((f"hub-beam ±{a:g} N·m", lambda a=a: fe_case("hub_beam_small", a)))
    for a in (4.0, 8.0, 20.0, 50.0, 100.0):
        out.append((f"free hub ±{a:g} N·m", lambda a=a: fe_case("free_hub_small", a)))
    for a in (0.05, 0.1, 0.3, 1.0):
        out.append((f"elastic joint ±{a:g} N·m", lambda a=a: fe_case("elastic_joint", a)))
    for a in (2.0, 4.0, 8.0, 16.0):
        out.append((f"cart ±{a:g} N", lambda a=a: fe_case("cart_hanging", a)))
    for t_end in (0.1, 0.5):
        for rate in (0.0, 500.0, 1000.0, 2000.0, 5000.0):
            for torque in (0.5, 2.0, 5.0, 20.0):
                if t_end > 0.1 and rate == 1000.0:
                    continue
                out.append((f"spun arm {rate:g}°/s, {torque:g} N·m, {t_end:g} s",
                            lambda r=rate, q=torque, e=t_end: spinning_arm(q, r, e)))
    for hub in (0.1, 0.23, 1.0):
        for rate in (500.0, 2000.0):
            for torque in (2.0, 5.0, 10.0):
                out.append((f"spun arm with hub {hub:g} kg·m², {rate:g}°/s, {torque:g} N·m, 0.5 s",
                            lambda r=rate, q=torque, h=hub: spinning_arm(q, r, 0.5, h)))
    for stroke in (45.0, 90.0, 180.0):
        for duration in (0.6, 1.0, 2.0):
            out.append((f"paper servo {stroke:g}° in {duration:g} s",
                        lambda s=stroke, u=duration: paper_servo(s, u)))
    for turn in (30.0, 60.0, 120.0):
        for duration in (0.4, 0.8):
            out.append((f"servo on elastic joint {turn:g}° in {duration:g} s",
                        lambda s=turn, u=duration: servo_arm(s, u)))
    for duration in (0.5, 1.0, 2.0):
        out.append((f"telescoping arm {duration:g} s",
                    lambda u=duration: telescoping(u)))
    for rate in (360.0, 720.0, 1440.0, 2880.0):
        out.append((f"four-bar {rate:g}°/s", lambda r=rate: four_bar(r)))
    out += loop_cases()
    return out


def loop_cases() -> list[tuple[str, Callable[[], Scenario]]]:
    """Closed loops whose links a closure holds at both ends (`loop_held_measure`)."""
    out: list[tuple[str, Callable[[], Scenario]]] = []
    for ei in (1.0, 0.3, 0.1, 0.03):
        for rpm in (100.0, 200.0, 250.0, 300.0, 400.0):
            out.append((f"benchmark four-bar {rpm:g} rpm, coupler EI ×{ei:g}",
                        lambda r=rpm, e=ei: four_bar_benchmark(r, e)))
    for rpm in (200.0, 225.0, 250.0):  # near the loop's first frequency: longer runs drift
        out.append((f"benchmark four-bar {rpm:g} rpm, coupler EI ×1, 1.2 s",
                    lambda r=rpm: four_bar_benchmark(r, 1.0, t_end=1.2)))
    for ei in (1.0, 0.3, 0.1):
        for rpm in (200.0, 300.0, 400.0):
            out.append((f"benchmark four-bar, rigid crank {rpm:g} rpm, coupler EI ×{ei:g}",
                        lambda r=rpm, e=ei: four_bar_benchmark(r, e, True)))
    for ei in (0.1, 0.02, 0.005, 0.002):
        for rate in (720.0, 1440.0, 2880.0):
            out.append((f"four-bar {rate:g}°/s, coupler EI ×{ei:g}",
                        lambda r=rate, e=ei: four_bar(r, e)))
    for ei in (1.0, 0.3, 0.1, 0.03, 0.01):
        for rate in (50.0, 100.0, 150.0, 200.0):
            for piston in (0.05, 0.5):
                out.append((f"slider-crank {rate:g} rad/s, rod EI ×{ei:g}, piston {piston:g} kg",
                            lambda r=rate, e=ei, m=piston: slider_crank(r, e, m)))
    return out


def with_tip_sensors(scenario: Scenario) -> Scenario:
    """The scenario with deflection sensors ``tip<k>`` and ``mid<k>`` (mid-span) on every
    elastic link (``mid<k>`` only on a link whose tip a closed loop holds), rtol 1e-7."""
    chain = scenario.chain
    sensors = tuple(PointSensor(f"{where}{k}", "deflection", k, x * link.length)
                    for k, link in enumerate(chain.links) if not link.rigid
                    for where, x in (("tip", 1.0), ("mid", 0.5))
                    if where == "mid" or not held_by_loop(chain, k, scenario.closures))
    return dataclasses.replace(scenario, sensors=sensors, settings=dataclasses.replace(
        scenario.settings, rtol=1e-7))


def channel_errors(run, reference) -> dict[str, float]:
    """max |run − reference| / max |reference| of every compared channel."""
    out = {}
    for name in reference.channels:
        if not COMPARED.match(name):
            continue
        exact = np.asarray(reference[name])
        peak = float(np.abs(exact).max())
        if peak < 1e-9 or np.ptp(exact) <= 1e-9 * peak:  # a held joint, a pinned tip
            continue
        out[name] = float(np.abs(np.asarray(run[name]) - exact).max() / peak)
    return out



def measure(label: str, scenario: Scenario) -> list[dict[str, object]]:
    """Both first-order models' rows of one case (a refused run is a row with no error)."""
    scenario = with_tip_sensors(scenario)
    settings = scenario.settings
    try:
        reference = simulate(dataclasses.replace(
            scenario, settings=dataclasses.replace(settings, model="nonlinear")), shapes=False)
    except Exception as exc:  # noqa: BLE001 — no reference, no row
        print(f"{label}: the nonlinear run failed: {exc}")
        return []
    rows = []
    for stiffening in (True, False):
        row: dict[str, object] = {"case": label, "stiffening": int(stiffening)}
        try:
            run = simulate(dataclasses.replace(scenario, settings=dataclasses.replace(
                settings, model="first_order", geometric_stiffening=stiffening)),
                shapes=False)
        except Exception as exc:  # noqa: BLE001 — a refused run warns by its error
            rows.append({**row, "link": "", "deflection_per_length": float("nan"),
                         "axial_load": float("nan"), "free_measure": float("nan"),
                         "measured_error": float("nan"),
                         "worst_channel": "", "warned": 1, "warning": f"refused: {exc}"})
            continue
        meta = run.metadata
        errors = channel_errors(run, reference)
        worst = max(errors, key=errors.get)
        rows.append({**row, "link": meta["forward_validity_link"],
                     "deflection_per_length": meta["peak_tip_deflection_per_length"],
                     "axial_load": meta["axial_load_parameter"],
                     "free_measure": meta["forward_validity_measure"],
                     "loop_link": meta.get("loop_validity_link", ""),
                     "loop_span": meta.get("loop_span_deflection_per_length", float("nan")),
                     "loop_axial": meta.get("loop_axial_load_parameter", float("nan")),
                     "loop_measure": meta.get("loop_validity_measure", float("nan")),
                     "measured_error": errors[worst], "worst_channel": worst,
                     "warned": int("validity_warning" in meta),
                     "warning": meta.get("validity_warning", "")})
    return rows


def table(rows: list[dict[str, object]]) -> str:
    lines = ["| case | model | δ | S | δ·S | measured | warns |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        d, S, m = (float(r[k]) for k in ("deflection_per_length", "axial_load",
                                         "measured_error"))
        model = "stiffened" if int(r["stiffening"]) else "paper"
        if not np.isfinite(m):
            lines.append(f"| {r['case']} | {model} | | | | | refused |")
            continue
        lines.append(f"| {r['case']} | {model} | {d:.1%} | {S:.3g} | {d * S:.3g} | "
                     f"{m:.2%} ({r['worst_channel']}) | {'yes' if int(r['warned']) else 'no'} |")
    return "\n".join(lines)


def family(label: str) -> str:
    """A case's family: its label up to its first number."""
    return re.split(r" [±]?-?\d", label, maxsplit=1)[0]


def families(rows: list[dict[str, object]]) -> str:
    """Per family and model: runs, those without a warning and their largest error, those
    warned or refused and the smallest error of a warned one (docs/validation.md's table)."""
    head = ("| family | model | runs | quiet | largest error, quiet | warned or refused | "
            "smallest error, warned |")
    lines = [head, "|---|---|---|---|---|---|---|"]
    for name in dict.fromkeys(family(str(r["case"])) for r in rows):
        for stiffening in (1, 0):
            chosen = [r for r in rows if family(str(r["case"])) == name
                      and int(r["stiffening"]) == stiffening]
            quiet = [float(r["measured_error"]) for r in chosen if not int(r["warned"])]
            loud = [float(r["measured_error"]) for r in chosen if int(r["warned"])
                    and np.isfinite(float(r["measured_error"]))]
            lines.append(
                f"| {name} | {'stiffened' if stiffening else 'paper'} | {len(chosen)} | "
                f"{len(quiet)} | {max(quiet, default=float('nan')):.2%} | "
                f"{len(chosen) - len(quiet)} | {min(loud, default=float('nan')):.2%} |")
    return "\n".join(lines)


def summary(rows: list[dict[str, object]]) -> str:
    out = []
    for stiffening in (1, 0):
        chosen = [r for r in rows if int(r["stiffening"]) == stiffening]
        quiet = [float(r["measured_error"]) for r in chosen if not int(r["warned"])]
        loud = [float(r["measured_error"]) for r in chosen if int(r["warned"])
                and np.isfinite(float(r["measured_error"]))]
        model = "stiffened" if stiffening else "paper's"
        out.append(f"{model} model: {len(chosen)} runs, {len(quiet)} without a warning (largest "
                   f"error {max(quiet, default=0.0):.2%}), {len(chosen) - len(quiet)} warned "
                   f"or refused (smallest error of a warned run "
                   f"{min(loud, default=float('nan')):.2%})")
    return "\n".join(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--table-only", action="store_true", help="reprint the recorded rows")
    parser.add_argument("--only", default="", help="run the cases whose label contains this")
    args = parser.parse_args()
    if args.table_only:
        with CSV.open(newline="") as f:
            rows = list(csv.DictReader(f))
    else:
        rows = []
        for label, build in cases():
            if args.only not in label:
                continue
            new = measure(label, build())
            rows += new
            for r in new:
                print(label, r["stiffening"], f"δ {float(r['deflection_per_length']):.3g}",
                      f"S {float(r['axial_load']):.3g}",
                      f"error {float(r['measured_error']):.3%} {r['worst_channel']}",
                      f"span {float(r.get('loop_span', 'nan')):.3g}",
                      f"Sl {float(r.get('loop_axial', 'nan')):.3g}",
                      "warns" if int(r["warned"]) else "", flush=True)
        with CSV.open("w", newline="") as f:
            writer = csv.DictWriter(f, FIELDS)
            writer.writeheader()
            writer.writerows(rows)
    print(table(rows))
    print(families(rows))
    print(summary(rows))


if __name__ == "__main__":
    main()
