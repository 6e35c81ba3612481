"""A clamped beam under a constant actuator voltage: the patch's moment pair bends it with the
uniform curvature M/EI between the patch ends (straight outside), so the tip deflection is
κ (x_e − x_s)(L − (x_s + x_e)/2) and the slope difference across the patch κ (x_e − x_s):
the simulated static state converges to both with the number of modes, and a collocated
piezo sensor reads the actuator-induced slope difference (the reciprocal pin-force model)."""

from __future__ import annotations

import numpy as np

from flexlink.scenario import scenario_from_dict
from flexlink.simulation import simulate

L, EI, XS, XE, VOLTS = 0.6, 0.16333333333333333, 0.1, 0.2, 100.0
PATCH = {"x_start": XS, "x_end": XE, "width": 0.025, "E_p": 30.33e9, "d31": 265e-12}


def run(modes: int):
    d = {"simulation": {"t_end": 4.0, "dt_out": 1e-3},
         "links": [{"name": "beam", "length": L, "mass_per_length": 0.0636, "EI": EI,
                    "thickness": 0.001, "damping_ratio": 0.9, "modes": modes}],
         "joints": [{"motion": [{"profile": "hold", "angle_deg": 0.0}]}],
         "sensors": [{"name": "tip", "kind": "deflection", "link": "beam", "x": L},
                     {"name": "pzt", "kind": "piezo", "link": "beam", "capacitance": 1e-6,
                      **PATCH}],
         "actuators": [{"name": "patch", "kind": "piezo", "collocated_with": "pzt",
                        "voltage": [{"profile": "step", "amplitude": VOLTS}]}]}
    scenario = scenario_from_dict(d)
    return scenario, simulate(scenario, shapes=False)


def test_static_deflection_under_constant_voltage() -> None:
    scenario, _ = run(2)
    moment = scenario.actuators[0].moment_per_volt * VOLTS
    kappa = moment / EI
    tip = kappa * (XE - XS) * (L - 0.5 * (XS + XE))
    errors, sensor_errors = [], []
    for modes in (2, 4, 8):
        scenario, results = run(modes)
        final = float(np.asarray(results["tip"])[-1])
        errors.append(abs(final - tip) / abs(tip))
        sensor = scenario.sensors[1]
        reading = float(np.asarray(results["pzt"])[-1])
        sensor_errors.append(abs(reading / (sensor.gain * kappa * (XE - XS)) - 1))
        assert float(np.asarray(results["patch_voltage"])[-1]) == VOLTS
    assert errors[-1] < 2e-3
    assert errors[0] > errors[-1]
    # The slope difference converges slowly (the curvature jumps at the patch ends, which a
    # modal series of smooth shapes resolves like a Fourier series a step): 70%, 33%, 11%.
    assert sensor_errors[0] > sensor_errors[1] > sensor_errors[2]
    assert sensor_errors[2] < 0.15
