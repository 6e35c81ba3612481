"""Synthetic measurement sets from a model that is *not* the one being fitted.

The "truth" is the paper's arm with geometric stiffening, 6 modes per link (the fitted scenario
has 4 and no stiffening), a link-1 modulus and damping ratios the fitted scenario is not told;
the measurement adds what real instruments do: a quantised encoder angle, a noisy potentiometer
angle (white noise through the potentiometer's analog filter, filtered again at 30 Hz by the
mapping), accelerometer noise and gain error, and a PZT read through a charge amplifier with a
gain error, an offset, a drift and noise, all sensors late. ``Truth`` sets the manoeuvre (start,
duration, rest after it) and every nuisance; ``MANOEUVRES`` are the lab cases the slow tests fit.
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
    move_start: float = 0.5  # s, both joints move together (cycloidal)
    move_duration: float = 1.0  # s
    pzt_gain: float = 1.15
    acc_gain: float = 1.0
    pzt_offset: float = 0.02  # V
    pzt_drift: float = 0.004  # V/s
    delay: float = 1e-3  # s, sensors lag the angles
    encoder_step_deg: float = 0.01
    pot_noise_deg: float = 0.05  # std of the potentiometer's noise after its analog filter
    pot_analog_hz: float | None = None  # Hz, analog (2nd-order) filter of the noise; None: white
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
    return Scenario(chain=Chain((link1, link2), joint_motions(truth)), sensors=base.sensors,
                    settings=settings, name="truth")


def joint_motions(truth: Truth) -> tuple[Cycloidal, Cycloidal]:
    """The true manoeuvre: β1 0 → 90°, β2 90 → 170°, together."""
    return (Cycloidal(0.0, 90.0, truth.move_start, truth.move_duration),
            Cycloidal(90.0, 170.0, truth.move_start, truth.move_duration))


def pot_noise(truth: Truth, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Potentiometer noise (deg): white, or through its analog filter, scaled to
    pot_noise_deg after the filter."""
    noise = rng.normal(size=t.size)
    if truth.pot_analog_hz is not None:
        from scipy.signal import butter, lfilter

        b, a = butter(2, truth.pot_analog_hz, fs=1.0 / (t[1] - t[0]))
        noise = lfilter(b, a, noise)
    return truth.pot_noise_deg * noise / np.std(noise)


def measured_columns(truth: Truth) -> tuple[dict[str, np.ndarray], object]:
    """Columns as a data logger would write them: t (s), beta1/beta2 (deg), acc (m/s²), pzt (V);
    also returns the noise-free truth results."""
    results = simulate(truth_scenario(truth))
    t = results.time
    rng = np.random.default_rng(truth.seed)
    beta1, beta2 = (np.degrees(m.evaluate(t)[0]) for m in joint_motions(truth))
    late = t - truth.delay
    acc = truth.acc_gain * np.interp(late, t, results["link1_tip_acceleration"])
    pzt = np.interp(late, t, results["pzt"])
    acc = acc + truth.acc_noise * np.abs(acc).max() * rng.normal(size=t.size)
    pzt = (truth.pzt_gain * pzt + truth.pzt_offset + truth.pzt_drift * t
           + truth.pzt_noise * np.abs(pzt).max() * rng.normal(size=t.size))
    columns = {
        "t": t,
        "beta1": np.round(beta1 / truth.encoder_step_deg) * truth.encoder_step_deg,
        "beta2": beta2 + pot_noise(truth, t, rng),
        "acc": acc,
        "pzt_v": pzt,
    }
    return columns, results


# the lab cases of the slow tests: two manoeuvres with 2 s of rest after them, noise levels
# from a good potentiometer to a poor one, a coarse encoder, gain errors, delays
MANOEUVRES = {
    "1.5 s move, 0.2 deg pot": Truth(move_duration=1.5, t_end=4.0, pot_noise_deg=0.2,
                                     pot_analog_hz=100.0, seed=5),
    "2 s move, coarse encoder": Truth(move_start=0.3, move_duration=2.0, t_end=4.3,
                                      encoder_step_deg=0.05, pot_noise_deg=0.1,
                                      pot_analog_hz=200.0, acc_gain=0.97, pzt_gain=0.8,
                                      delay=2e-3, E1=35e9, zeta1=0.015, zeta2=0.02, seed=6),
}


def scenario_text(truth: Truth) -> str:
    """The paper's scenario file (what is fitted), ending where ``truth``'s data do."""
    from flexlink.scenario import paper_experiment_path

    text = paper_experiment_path().read_text(encoding="utf-8")
    return text.replace("t_end = 5.0 ", f"t_end = {truth.t_end:g} ", 1)


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


# The [measurement] mapping of the single-link data: joint angle in degrees (filtered as the
# docs suggest) and the tip accelerometer.
SINGLE_LINK_MAPPING = """
[measurement]
file = "measured.csv"
[[measurement.columns]]
column = "angle"
joint = 1
unit = "deg"
lowpass_hz = 30.0
[[measurement.columns]]
column = "acc"
sensor = "acc"
"""
