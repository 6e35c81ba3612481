"""Sensitivities on the nonlinear model with prescribed joints (Gauss collocation): every
channel's derivative in ten fields against converged central differences, and the cost of
a run with ten sensitivities against the run alone.

The paper arm with ``model = "nonlinear"`` (1.5 s: rest, then the first second of the
move). Sensitivities at rtol 1e-10; the reference: runs at rtol 1e-12 with the field moved
by δ = 1e-3, 5e-4, 2.5e-4, 1.25e-4 of its value, Richardson on consecutive pairs, the
best-agreeing pair. Printed per field: the worst channel's difference relative to that
channel's peak derivative, and the reference's own spread there.

    python benchmarks/nonlinear_sensitivities.py [t_end]
"""

from __future__ import annotations

import sys
import time
import tomllib
from pathlib import Path

import numpy as np

import flexlink
from flexlink.scenario import paper_experiment_path, resolve_scenario_dict
from flexlink.scenario.fields import ScenarioFile
from flexlink.scenario.load import scenario_from_dict
from flexlink.simulation.sensitivities import scenario_file, simulate_with_derivatives

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the cases live with the tests
from tests.unit.test_forward_sensitivities import FREE_BASE, HUB_BEAM

PAPER = ["links[0].EI", "links[1].EI", "links[0].mass_per_length", "links[0].tip_mass",
         "links[0].damping_ratio", "links[1].damping_ratio", "links[1].length",
         "joints[1].motion[0].to_deg", "sensors[pzt].capacitance", "sensors[1].x"]
HUB = ["links[0].EI", "links[0].mass_per_length", "links[0].tip_mass",
       "links[0].damping_ratio", "links[0].length", "joints[0].torque[0].amplitude",
       "joints[0].motor_inertia", "sensors[0].x", "sensors[0].thickness"]
FREE = ["base.inertia", "base.mass", "base.rate_deg_s", "links[0].mass_per_length",
        "links[0].EI", "base.loads[0].moment[0].amplitude"]
RELS = (4e-3, 2e-3, 1e-3, 5e-4)
# channels of accelerations and forces (q̈ from the interpolant), reported apart
SECOND = ("acceleration", "torque")


def paper(t_end: float) -> ScenarioFile:
    d = resolve_scenario_dict(paper_experiment_path())
    d.pop("flexlink_version", None)
    d["simulation"].update({"t_end": t_end, "model": "nonlinear"})
    d["sensors"][1]["x"] = 0.5  # off link 2's tip: its length moves both ways
    return scenario_file(scenario_from_dict(d))


def driven(text: str) -> ScenarioFile:
    d = tomllib.loads(text)
    d["simulation"]["model"] = "nonlinear"
    return scenario_file(scenario_from_dict(d))


def case(name: str, file: ScenarioFile, fields: list[str]) -> None:
    """Cost and accuracy of one scenario's sensitivities (rtol 1e-10)."""
    scenario = file.build({("simulation", "rtol"): 1e-10})
    simulate_with_derivatives(scenario, fields)  # compile
    best = []
    for _ in range(3):
        start = time.process_time()
        flexlink.simulate(scenario, shapes=False)
        alone = time.process_time() - start
        start = time.process_time()
        results, derivatives = simulate_with_derivatives(scenario, fields)
        best.append((alone, time.process_time() - start))
    alone, with_fields = min(a for a, _ in best), min(b for _, b in best)
    print(f"{name}: run alone {alone:.3f} s CPU, with {len(fields)} sensitivities "
          f"{with_fields:.3f} s ({with_fields / alone:.1f}x)")
    largest = max(np.abs(results[c]).max() for c in results.names)
    for k, text in enumerate(fields):
        target = file.locate(text)
        value = float(target.value)
        estimates = []
        for rel in RELS:
            h = rel * abs(value)
            runs = [flexlink.simulate(file.build({target.path: value + s * h,
                                                  ("simulation", "rtol"): 1e-12}),
                                      shapes=False) for s in (1, -1)]
            estimates.append({c: (runs[0][c] - runs[1][c]) / (2 * h) for c in derivatives})
        rich = [{c: (4 * estimates[i + 1][c] - estimates[i][c]) / 3 for c in derivatives}
                for i in range(len(RELS) - 1)]
        worst = {True: (0.0, 0.0, ""), False: (0.0, 0.0, "")}
        vanishing = (0.0, "")  # a derivative that vanishes: |S| over the channel's scale
        for c, s in derivatives.items():
            size = np.abs(results[c]).max()
            if size <= 1e-9 * largest:  # zero to round-off (a conserved momentum)
                continue
            s = s[:, k]
            scale = size / abs(value)
            if np.abs(rich[-1][c]).max() <= 1e-6 * scale:  # a momentum the field keeps
                if np.abs(s).max() / scale > vanishing[0]:
                    vanishing = (float(np.abs(s).max() / scale), c)
                continue
            peak = max(np.abs(rich[-1][c]).max(), np.abs(s).max(), 1e-6 * scale)
            spreads = [np.abs(rich[i][c] - rich[i + 1][c]).max() / peak
                       for i in range(len(rich) - 1)]
            i = int(np.argmin(spreads))
            error = min(np.abs(s - rich[i][c]).max(), np.abs(s - rich[i + 1][c]).max()) / peak
            second = any(word in c for word in SECOND)
            if error > worst[second][0]:
                worst[second] = (error, spreads[i], c)
        print(f"  {text:30s} " + "; ".join(
            f"{label} {e:.1e} on {c} (spread {sp:.1e})" for label, (e, sp, c) in
            (("states", worst[False]), ("accelerations/torques", worst[True])) if c)
            + (f"; vanishing derivative of {vanishing[1]}: {vanishing[0]:.1e} of its scale"
               if vanishing[1] else ""), flush=True)


def main(t_end: float = 1.5) -> None:
    case(f"paper arm, nonlinear, prescribed joints ({t_end} s)", paper(t_end), PAPER)
    case("torque-driven hub-beam, nonlinear", driven(HUB_BEAM), HUB)
    case("free base, nonlinear", driven(FREE_BASE), FREE)


if __name__ == "__main__":
    main(*(float(a) for a in sys.argv[1:]))
