"""Positive position feedback on one mode: the closed-loop damping identified from the
simulated free decay matches the analytic closed-loop poles of the single-mode plant with the
continuous PPF filter (Goh & Caughey), within 5%; an over-gained loop is reported unstable."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.actuators import piezo_load
from flexlink.errors import SimulationError
from flexlink.scenario import scenario_from_dict
from flexlink.simulation import simulate

SAMPLE_RATE = 2000.0  # Hz: ω T ≈ 0.008 at the mode, the hold's lag is negligible
ZETA_F = 0.3


def beam(modes: int, controllers: list[dict], t_end: float = 3.0) -> dict:
    """A clamped aluminium strip (link 2 of the paper) with a collocated PZT pair near the
    root, kicked by a 50 V pulse on the actuator for 0.1 s."""
    return {
        "simulation": {"t_end": t_end, "dt_out": 1e-3, "rtol": 1e-8},
        "links": [{"name": "beam", "length": 0.6, "mass_per_length": 0.0636, "E": 70e9,
                   "width": 0.028, "thickness": 0.001, "damping_ratio": 0.005,
                   "modes": modes}],
        "joints": [{"motion": [{"profile": "hold", "angle_deg": 0.0}]}],
        "sensors": [{"name": "pzt", "kind": "piezo", "link": "beam", "x_start": 0.01,
                     "x_end": 0.04, "width": 0.025, "E_p": 63e9, "d31": -1.7e-10,
                     "capacitance": 1e-7}],
        "actuators": [{"name": "patch", "kind": "piezo", "collocated_with": "pzt",
                       "voltage": [{"profile": "step", "amplitude": 50.0, "start": 0.0,
                                    "duration": 0.1}]}],
        "controllers": controllers,
    }


def ppf(frequency_hz: float, gain: float) -> dict:
    return {"name": "ppf", "kind": "ppf", "sensor": "pzt", "actuator": "patch",
            "frequency_hz": frequency_hz, "damping": ZETA_F, "gain": gain,
            "sample_rate": SAMPLE_RATE}


def first_mode(scenario):
    """m, c, k of the first mode, the actuator's force per volt b and the sensor's volts per
    unit of q: the single-mode plant m q̈ + c q̇ + k q = b V, v = s q."""
    from flexlink.dynamics.first_order import chain_modal_data

    data = chain_modal_data(scenario.chain)[0]
    m, c, k = (data.mass_matrix[0, 0], data.damping_matrix[0, 0],
               data.stiffness_matrix[0, 0])
    b = piezo_load(scenario.actuators[0], data)[0]
    sensor = scenario.sensors[0]
    slopes = data.shapes.evaluate(np.array([sensor.x_start, sensor.x_end]), 1)
    s = sensor.gain * (slopes[1, 0] - slopes[0, 0])
    return m, c, k, b, s


def analytic_poles(m, c, k, b, s, w_f, g) -> np.ndarray:
    """Eigenvalues of [q, q̇, ξ, ξ̇]: m q̈ + c q̇ + k q = b g ξ, ξ̈ + 2ζ_f ω_f ξ̇ + ω_f² ξ = ω_f² s q."""
    A = np.array([[0, 1, 0, 0], [-k / m, -c / m, b * g / m, 0], [0, 0, 0, 1],
                  [w_f**2 * s, 0, -w_f**2, -2 * ZETA_F * w_f]])
    return np.linalg.eigvals(A)


def identified_poles(t: np.ndarray, y: np.ndarray, order: int, step: int) -> np.ndarray:
    """Poles (1/s) of the free response y(t) by Prony's method: y_k = Σ a_i y_{k−i}."""
    y = y[::step]
    dt = (t[1] - t[0]) * step
    rows = np.array([y[i:i + order][::-1] for i in range(y.size - order)])
    a = np.linalg.lstsq(rows, y[order:], rcond=None)[0]
    return np.log(np.roots(np.concatenate([[1.0], -a])).astype(complex)) / dt


def damping(pole: complex) -> float:
    return -pole.real / abs(pole)


def structural(poles: np.ndarray, w: float) -> complex:
    upper = poles[poles.imag > 0]
    return upper[np.argmin(np.abs(np.abs(upper) - w))]


@pytest.mark.parametrize("loop_gain", [0.2, 0.5])
def test_ppf_damping_matches_single_mode_theory(loop_gain: float) -> None:
    scenario = scenario_from_dict(beam(1, [ppf(1.0, 1.0)]))
    m, c, k, b, s = first_mode(scenario)
    w = np.sqrt(k / m)
    g = loop_gain * k / (b * s)  # V/V: the loop's static gain b g s / k = loop_gain < 1
    scenario = scenario_from_dict(beam(1, [ppf(w / (2 * np.pi), g)]))
    results = simulate(scenario, shapes=False)
    t, y = np.asarray(results.time), np.asarray(results["pzt"])
    free = t > 0.2
    found = structural(identified_poles(t[free], y[free], 4, 5), w)
    expected = structural(analytic_poles(m, c, k, b, s, w, g), w)
    open_loop = c / (2 * np.sqrt(k * m))
    assert damping(expected) > 4 * open_loop  # the loop does add damping
    print(f"loop gain {loop_gain}: damping simulated {damping(found):.5f}, analytic "
          f"{damping(expected):.5f}")
    assert damping(found) == pytest.approx(damping(expected), rel=0.05)
    assert abs(found) == pytest.approx(abs(expected), rel=0.01)
    volts = np.asarray(results["patch_voltage"])
    command = np.asarray(results["ppf_command"])
    assert np.allclose(volts[t > 0.1005], command[t > 0.1005])  # no open-loop part left


def test_unstable_loop_is_reported_with_its_time() -> None:
    one = scenario_from_dict(beam(1, [ppf(1.0, 1.0)]))
    m, _, k, b, s = first_mode(one)
    w = np.sqrt(k / m)
    g = 3.0 * k / (b * s)  # loop gain 3 > 1: PPF's static instability
    with pytest.raises(SimulationError, match=r"closed loop unstable: .*grows from .* t = "):
        simulate(scenario_from_dict(beam(1, [ppf(w / (2 * np.pi), g)], t_end=20.0)),
                 shapes=False)
