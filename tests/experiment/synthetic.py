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


SINGLE = """\
[simulation]
name = "single"
t_end = 2.0
dt_out = 0.001
geometric_stiffening = {stiffening}

[[links]]
name = "arm"
length = 1.37
mass_per_length = 0.5292
EI = {EI}
tip_mass = 0.129
damping_ratio = {zeta}
modes = {modes}

[[joints]]
motion = [{{ profile = "cycloidal", from_deg = 0.0, to_deg = 60.0, start = 0.1, duration = 0.5 }}]

[[sensors]]
name = "acc"
kind = "acceleration"
link = "arm"
x = 1.37

[[sensors]]
name = "strain"
kind = "strain"
link = "arm"
x = 0.05
thickness = 0.014
"""


def single_link_text(EI: float = 308.7, zeta: float = 0.02, modes: int = 3,
                     stiffening: bool = False) -> str:
    """A one-link arm (the paper's link 1 with its tip mass), 2 s; a short, cheap case."""
    return SINGLE.format(EI=EI, zeta=zeta, modes=modes, stiffening=str(stiffening).lower())


def single_link_measurement(EI: float, zeta: float, seed: int = 1) -> dict[str, np.ndarray]:
    """Measured columns of the one-link arm from a 6-mode stiffened truth: t (s), angle (deg,
    quantised to 0.01°), acc (m/s², 2 % noise), strain (µstrain, gain 0.9, 2 % noise)."""
    import tomllib

    from flexlink.scenario import scenario_from_dict

    truth = scenario_from_dict(tomllib.loads(single_link_text(EI, zeta, 6, True)))
    results = simulate(truth)
    t = results.time
    rng = np.random.default_rng(seed)
    angle = np.degrees(results["joint1_angle"])
    acc, strain = results["acc"], results["strain"]
    return {
        "t": t,
        "angle": np.round(angle / 0.01) * 0.01,
        "acc": acc + 0.02 * np.abs(acc).max() * rng.normal(size=t.size),
        "strain": 1e6 * (0.9 * strain + 0.02 * np.abs(strain).max() * rng.normal(size=t.size)),
    }
