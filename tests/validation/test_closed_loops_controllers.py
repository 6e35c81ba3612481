"""Sampled controllers on a closed-loop mechanism (first-order model): PZT damping of a
four-bar's flexible coupler (crank held by its motor, the coupler and rocker free). Against
an independent hybrid reference — the closed mechanism's linearised plant (`linearize`, its
patch voltage in, its PZT sensor out) discretised exactly over the sample period with the
voltage held, closed with the controller's discrete state-space form — and the damping it
adds against the open loop."""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
import pytest
from scipy.linalg import expm

import flexlink
from flexlink.dynamics.controllers import discretize
from flexlink.errors import SimulationError
from flexlink.model import Step, Sum
from flexlink.scenario import scenario_from_dict
from tests.validation.test_closed_loops import FOUR_BAR, _four_bar_angles
from tests.validation.test_ppf import ZETA_F, identified_poles

SAMPLE_RATE = 2000.0  # Hz
CRANK = 90.0  # deg
PULSE = 0.2  # V on the patch for the first 0.05 s (ends on a sample instant); small: the
# reference is linear (20 V leaves 2e-3 of the peak to the mechanism's nonlinearity)


def _damped(controllers: list[dict], t_end: float = 1.0) -> dict:
    """The four-bar with an aluminium strip as coupler (0.3 m, 28 × 1 mm, 4 modes), a PZT
    sensor and a collocated patch at its mid-span, the crank held at 90°."""
    d = copy.deepcopy(FOUR_BAR)
    angles = _four_bar_angles(math.radians(CRANK))
    d["simulation"].update(t_end=t_end, dt_out=5e-4, rtol=1e-8)
    d["links"][1] = {"name": "coupler", "length": 0.3, "mass_per_length": 0.0756,
                     "E": 70e9, "width": 0.028, "thickness": 0.001, "damping_ratio": 0.005,
                     "modes": 4}
    d["joints"][0] = {"motion": [{"profile": "hold", "angle_deg": CRANK}]}
    d["joints"][1]["initial_angle_deg"] = math.degrees(angles[1] - angles[0])
    d["joints"][2]["initial_angle_deg"] = math.degrees(angles[2])
    d["sensors"] = [{"name": "pzt", "kind": "piezo", "link": "coupler", "x_start": 0.13,
                     "x_end": 0.17, "width": 0.025, "E_p": 63e9, "d31": -1.7e-10,
                     "capacitance": 1e-7}]
    d["actuators"] = [{"name": "patch", "kind": "piezo", "collocated_with": "pzt",
                       "voltage": [{"profile": "step", "amplitude": PULSE, "start": 0.0,
                                    "duration": 0.05}]}]
    d["controllers"] = controllers
    return d


def _ppf(frequency_hz: float, gain: float) -> dict:
    return {"name": "ppf", "kind": "ppf", "sensor": "pzt", "actuator": "patch",
            "frequency_hz": frequency_hz, "damping": ZETA_F, "gain": gain,
            "sample_rate": SAMPLE_RATE}


def _first_frequency(d: dict) -> tuple[flexlink.LinearPlant, float]:
    """The open mechanism's plant (patch voltage → sensor) and its lowest frequency (Hz)."""
    open_loop = copy.deepcopy(d)
    open_loop["controllers"] = []
    plant = flexlink.linearize(scenario_from_dict(open_loop), at=0.0,
                               inputs=["patch_voltage"], outputs=["pzt"])
    return plant, float(plant.modes()[0][0])


def _hybrid(plant, scenario, t: np.ndarray) -> np.ndarray:
    """The sensor at t (s) of the plant under the held voltage V_k = V_open(t_k) + PPF's
    output, the filter updated with the sensor at each sample t_k (the integrator's order);
    the plant's state propagated exactly over each period."""
    T = 1.0 / SAMPLE_RATE
    n = plant.A.shape[0]
    big = expm(np.block([[plant.A, plant.B], [np.zeros((1, n + 1))]]) * T)
    Phi, Gam = big[:n, :n], big[:n, n:]
    Ad, Bd, Cd, Dd = discretize(scenario.controllers[0])
    x, xi = np.zeros(n), np.zeros(Ad.shape[0])
    steps = round(t[-1] * SAMPLE_RATE)
    sensor = np.empty(steps + 1)
    voltage = scenario.actuators[0].voltage
    for k in range(steps + 1):
        y = float(plant.C[0] @ x)  # D = 0: the sensor reads the strain alone
        sensor[k] = y
        v = float(voltage.value(np.array([k * T]))[0]) + float(Cd[0] @ xi + Dd[0, 0] * y)
        xi = Ad @ xi + Bd[:, 0] * y
        x = Phi @ x + Gam[:, 0] * v
    return np.interp(t, np.arange(steps + 1) * T, sensor)


def test_ppf_on_a_four_bars_coupler_matches_the_hybrid_plant_reference() -> None:
    """The run's sensor at the sample instants against the hybrid reference, through the
    pulse and the controlled decay; the held voltage is the pulse plus the filter's output;
    the loop stays closed."""
    d = _damped([])
    plant, f1 = _first_frequency(d)
    assert plant.D[0, 0] == 0.0
    d["controllers"] = [_ppf(f1, 0.5 / abs(float(plant.C[0] @ np.linalg.solve(
        plant.A, plant.B)[:, 0])))]  # static loop gain 0.5
    scenario = scenario_from_dict(d)
    run = flexlink.simulate(scenario, shapes=False)
    assert run.metadata["path"] == "forward" and run.metadata["controllers"] == 1
    t = np.asarray(run.time)
    on_samples = np.abs(t * SAMPLE_RATE - np.round(t * SAMPLE_RATE)) < 1e-6
    reference = _hybrid(plant, scenario, t)
    sensor = np.asarray(run["pzt"])
    peak = np.abs(reference).max()
    assert peak > 0
    assert np.abs(sensor - reference)[on_samples].max() < 1e-4 * peak
    volts, command = np.asarray(run["patch_voltage"]), np.asarray(run["ppf_command"])
    after = t > 0.05 + 1e-6
    assert np.abs(volts[after] - command[after]).max() < 1e-12 * PULSE
    assert np.abs(command).max() > 0.01 * PULSE
    assert run.metadata["closure_residual_relative"] <= 1e-8


def _decay_rate(run, f1: float) -> float:
    """The slowest decay rate (1/s) of the sensor's free decay near the first mode."""
    t, y = np.asarray(run.time), np.asarray(run["pzt"])
    free = t > 0.1
    p = identified_poles(t[free], y[free], 6, 4)
    w = 2 * math.pi * f1
    p = p[(p.imag > 0) & (np.abs(p) > 0.5 * w) & (np.abs(p) < 2.0 * w)]
    return float(-p.real.max())


def test_ppf_damps_the_coupler() -> None:
    """The first mode's decay rate with PPF several times the open loop's (structural
    damping 0.5%)."""
    d = _damped([])
    plant, f1 = _first_frequency(d)
    gain = 0.3 / abs(float(plant.C[0] @ np.linalg.solve(plant.A, plant.B)[:, 0]))
    rates = {}
    for name, controllers in (("open", []), ("closed", [_ppf(f1, gain)])):
        d["controllers"] = controllers
        rates[name] = _decay_rate(flexlink.simulate(scenario_from_dict(d), shapes=False), f1)
    assert rates["open"] == pytest.approx(0.005 * 2 * math.pi * f1, rel=0.05)
    assert rates["closed"] > 5 * rates["open"], rates


def test_an_over_gained_loop_on_a_closed_mechanism_is_reported_unstable() -> None:
    d = _damped([], t_end=0.5)
    plant, f1 = _first_frequency(d)
    gain = 50.0 / abs(float(plant.C[0] @ np.linalg.solve(plant.A, plant.B)[:, 0]))
    d["controllers"] = [_ppf(f1, gain)]
    with pytest.raises(SimulationError, match="unstable"):
        flexlink.simulate(scenario_from_dict(d), shapes=False)


def test_the_held_voltages_drive_the_closures_forces_at_the_outputs() -> None:
    """The outputs' pin forces and accelerations see the held voltages: an open-loop run
    whose patch gets the controlled run's held voltages (steps at the samples) gives the
    same pin force and sensor."""
    d = _damped([])
    plant, f1 = _first_frequency(d)
    gain = 0.3 / abs(float(plant.C[0] @ np.linalg.solve(plant.A, plant.B)[:, 0]))
    d["controllers"] = [_ppf(f1, gain)]
    d["simulation"].update(t_end=0.1, dt_out=1e-4)  # outputs between the samples too
    closed = flexlink.simulate(scenario_from_dict(d), shapes=False)
    t = np.asarray(closed.time)
    every = round(1 / (SAMPLE_RATE * (t[1] - t[0])))
    held = np.asarray(closed["patch_voltage"])[::every]
    d["controllers"] = []
    replay = scenario_from_dict(d)
    T = 1.0 / SAMPLE_RATE
    voltage = Sum(tuple(Step(float(v), k * T, T) for k, v in enumerate(held)))
    replay = dataclasses.replace(replay, actuators=(
        dataclasses.replace(replay.actuators[0], voltage=voltage),))
    again = flexlink.simulate(replay, shapes=False)
    between = np.arange(t.size) % every != 0  # at a sample the replay's step may round early
    for name in ("patch_voltage", "pin_force_y", "pzt"):
        ref = np.asarray(closed[name])
        error = np.abs(np.asarray(again[name]) - ref)[between].max()
        assert error < 1e-6 * np.abs(ref).max(), name  # measured 1.5e-13 (pzt)
