"""Write the measured-data example: a lab-like record of the paper's arm
(examples/lab_run3.csv) and the scenario that reads it (examples/lab_arm.toml).

    python scripts/lab_record.py

The record is made by a model that is not the one the example scenario describes (as a real
arm would be): the paper's arm with geometric stiffening, 6 modes per link, link 1's modulus
26 GPa instead of 30 and damping ratios 0.025 / 0.013 instead of 0.02 / 0.01. It carries the
nuisances docs/experiment.md describes: joint 1 read by an encoder (0.01° steps), joint 2 by
a noisy potentiometer (0.05° after its 100 Hz analog filter), the link-1 tip accelerometer in
g with a 3% gain error and noise, the PZT through an inverting charge amplifier in mV with a
15% gain error, an offset and a drift, both sensors 1 ms late, three lost accelerometer
samples, 500 Hz sampling over 4 s. `flexlink compare examples/lab_arm.toml
examples/lab_run3.csv` and `flexlink fit` (README, "Your measurements") run on it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
from scipy.signal import butter, lfilter

from flexlink.model import Chain, SimulationSettings
from flexlink.motion import Cycloidal
from flexlink.scenario import load_paper_experiment, paper_experiment_path
from flexlink.simulation import simulate

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
RATE = 500.0  # Hz, the logger's sampling rate
T_END = 4.0  # s
G = 9.80665  # m/s² per g

MAPPING = '''
# --- the measurement (flexlink compare / fit; flexlink run ignores this section) ------------
# examples/lab_run3.csv: a lab-like record written by scripts/lab_record.py (a different model
# of the arm plus instrument nuisances: docs/experiment.md).
[measurement]
file = "lab_run3.csv"
time_column = "t"

[[measurement.columns]]
column = "beta1"              # encoder, 0.01° steps
joint = 1
unit = "deg"
lowpass_hz = 30.0

[[measurement.columns]]
column = "beta2"              # potentiometer: its noise needs a lower cut-off
joint = 2
unit = "deg"
lowpass_hz = 15.0

[[measurement.columns]]
column = "acc"
sensor = "link1_tip_acceleration"
unit = "g"

[[measurement.columns]]
column = "pzt_raw"
sensor = "pzt"
unit = "mV"
scale = -1.0                  # the charge amplifier inverts
'''


def record(seed: int = 3) -> dict[str, np.ndarray]:
    """The logger's columns: t (s), beta1, beta2 (deg), acc (g), pzt_raw (mV)."""
    paper = load_paper_experiment()
    link1, link2 = paper.chain.links
    link1 = dataclasses.replace(link1, EI=26e9 * 0.045 * 0.014 ** 3 / 12, damping_ratio=0.025,
                                modes=6)
    link2 = dataclasses.replace(link2, damping_ratio=0.013, modes=6)
    moves = (Cycloidal(0.0, 90.0, 0.5, 1.0), Cycloidal(90.0, 170.0, 0.5, 1.0))
    truth = dataclasses.replace(paper, chain=Chain((link1, link2), moves),
                                settings=SimulationSettings(t_end=T_END, dt_out=1e-3,
                                                            geometric_stiffening=True))
    results = simulate(truth, shapes=False)
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, T_END + 0.5 / RATE, 1.0 / RATE)
    late = t - 1e-3
    acc = 0.97 * np.interp(late, results.time, results["link1_tip_acceleration"]) / G
    acc += 0.02 * np.abs(acc).max() * rng.normal(size=t.size)
    acc[[900, 901, 1500]] = np.nan  # lost samples: repaired by interpolation (a warning)
    pzt = 1.15 * np.interp(late, results.time, results["pzt"])
    pzt = -(pzt + 0.02 + 0.004 * t + 0.02 * np.abs(pzt).max() * rng.normal(size=t.size))
    beta1, beta2 = (np.degrees(m.evaluate(t)[0]) for m in moves)
    b, a = butter(2, 100.0, fs=RATE)  # the potentiometer's analog filter
    pot = lfilter(b, a, rng.normal(size=t.size))
    return {"t": t, "beta1": np.round(beta1 / 0.01) * 0.01,
            "beta2": beta2 + 0.05 * pot / pot.std(), "acc": acc, "pzt_raw": 1e3 * pzt}


def scenario_text() -> str:
    """The built-in paper scenario, ending with the record, plus the [measurement] section."""
    text = paper_experiment_path().read_text(encoding="utf-8")
    text = text.replace('name = "paper-experiment"', 'name = "lab-arm"', 1)
    text = text.replace("t_end = 5.0                   # s: the manoeuvre ends at 1.5 s, then "
                        "3.5 s of free vibration",
                        "t_end = 4.0                   # s: the record's length (the manoeuvre "
                        "ends at 1.5 s)", 1)
    header = ("# The paper's arm (flexlink show-paper) with the measurement of a lab run: what\n"
              "# flexlink compare and flexlink fit read (README, \"Your measurements\").\n#\n")
    return header + text.rstrip("\n") + "\n" + MAPPING


def main() -> None:
    columns = record()
    names = list(columns)
    data = np.column_stack([columns[n] for n in names])
    csv = EXAMPLES / "lab_run3.csv"
    with csv.open("w", encoding="utf-8") as f:
        f.write(",".join(names) + "\n")
        for row in data:
            f.write(",".join("nan" if np.isnan(v) else f"{v:.6g}" for v in row) + "\n")
    (EXAMPLES / "lab_arm.toml").write_text(scenario_text(), encoding="utf-8")
    print(f"wrote {csv} ({len(data)} rows) and {EXAMPLES / 'lab_arm.toml'}")


if __name__ == "__main__":
    main()
