"""Synthetic measurement sets from a model that is *not* the one being fitted.

The "truth" is the paper's arm with geometric stiffening, 6 modes per link (the fitted scenario
has 4 and no stiffening), a link-1 modulus and damping ratios the fitted scenario is not told;
the measurement adds what real instruments do: a quantised encoder angle, a noisy potentiometer
angle (filtered at 30 Hz by the mapping), accelerometer noise, and a PZT read through a charge
amplifier with a gain error, an offset, a drift and noise, all sensors 1 ms late.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from flexlink.model import Chain, Scenario, SimulationSettings
from flexlink.motion import Cycloidal
from flexlink.scenario import load_paper_experiment
from flexlink.simulation import simulate


@dataclass(frozen=True)
class Truth:
    E1: float = 26.0e9  # Pa; the scenario says 30 GPa
    zeta1: float = 0.025  # the scenario says 0.02
    zeta2: float = 0.013  # the scenario says 0.01
    modes: int = 6
    stiffening: bool = True
    t_end: float = 5.0  # s
    pzt_gain: float = 1.15
    pzt_offset: float = 0.02  # V
    pzt_drift: float = 0.004  # V/s
    delay: float = 1e-3  # s, sensors lag the angles
    encoder_step_deg: float = 0.01
    pot_noise_deg: float = 0.05
    acc_noise: float = 0.02  # fraction of the peak
    pzt_noise: float = 0.02  # fraction of the peak
    seed: int = 0

    @property
    def EI1(self) -> float:
        return self.E1 * 0.045 * 0.014**3 / 12


def truth_scenario(truth: Truth) -> Scenario:
    base = load_paper_experiment()
    link1, link2 = base.chain.links
    link1 = dataclasses.replace(link1, EI=truth.EI1, damping_ratio=truth.zeta1,
                                modes=truth.modes)
    link2 = dataclasses.replace(link2, damping_ratio=truth.zeta2, modes=truth.modes)
    settings = SimulationSettings(t_end=truth.t_end, dt_out=1e-3,
                                  geometric_stiffening=truth.stiffening)
    return Scenario(chain=Chain((link1, link2), base.chain.joints), sensors=base.sensors,
                    settings=settings, name="truth")


def measured_columns(truth: Truth) -> tuple[dict[str, np.ndarray], object]:
    """Columns as a data logger would write them: t (s), beta1/beta2 (deg), acc (m/s²), pzt (V);
    also returns the noise-free truth results."""
    results = simulate(truth_scenario(truth))
    t = results.time
    rng = np.random.default_rng(truth.seed)
    beta1 = np.degrees(Cycloidal(0.0, 90.0, 0.5, 1.0).evaluate(t)[0])
    beta2 = np.degrees(Cycloidal(90.0, 170.0, 0.5, 1.0).evaluate(t)[0])
    late = t - truth.delay
    acc = np.interp(late, t, results["link1_tip_acceleration"])
    pzt = np.interp(late, t, results["pzt"])
    acc = acc + truth.acc_noise * np.abs(acc).max() * rng.normal(size=t.size)
    pzt = (truth.pzt_gain * pzt + truth.pzt_offset + truth.pzt_drift * t
           + truth.pzt_noise * np.abs(pzt).max() * rng.normal(size=t.size))
    columns = {
        "t": t,
        "beta1": np.round(beta1 / truth.encoder_step_deg) * truth.encoder_step_deg,
        "beta2": beta2 + truth.pot_noise_deg * rng.normal(size=t.size),
        "acc": acc,
        "pzt_v": pzt,
    }
    return columns, results


MAPPING = """
[measurement]
file = "measured.csv"
time_column = "t"

[[measurement.columns]]
column = "beta1"
joint = 1
unit = "deg"
lowpass_hz = 30.0

[[measurement.columns]]
column = "beta2"
joint = 2
unit = "deg"
lowpass_hz = 30.0

[[measurement.columns]]
column = "acc"
sensor = "link1_tip_acceleration"

[[measurement.columns]]
column = "pzt_v"
sensor = "pzt"
unit = "V"
"""


def write_csv(path, columns: dict[str, np.ndarray]) -> None:
    names = list(columns)
    np.savetxt(path, np.column_stack([columns[n] for n in names]), delimiter=",",
               header=",".join(names), comments="", fmt="%.9g")
