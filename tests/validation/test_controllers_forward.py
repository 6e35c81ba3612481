"""Sampled controllers on the first-order forward path (driven joints, moving base;
docs/closed_loop.md): PPF damps a link on a torque-driven hub; with the hub locked (a huge
motor inertia) the closed-loop poles are those of the prescribed-joint closed loop; on a
free base the actuator is internal and the momentum stays zero; an over-gained loop is
reported unstable, not NaN."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.errors import SimulationError
from flexlink.scenario import scenario_from_dict
from flexlink.simulation import model_path, simulate
from tests.validation.test_ppf import beam, first_mode, identified_poles, ppf


def hub(motor_inertia: float) -> list[dict]:
    """A torque-driven joint with no torque: the hub turns freely, its motor inertia against
    the link's reaction (a huge inertia locks it)."""
    return [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.0}],
             "motor_inertia": motor_inertia}]


def poles(results, w: float) -> np.ndarray:
    """The oscillatory poles (1/s) of the sensor's free decay within an octave of w, by
    Prony's method (order 6: two structural modes and the filter)."""
    t, y = np.asarray(results.time), np.asarray(results["pzt"])
    free = t > 0.2
    p = identified_poles(t[free], y[free], 6, 5)
    return p[(p.imag > 0) & (np.abs(p) > 0.5 * w) & (np.abs(p) < 2.0 * w)]


def plant(t_end: float = 3.0) -> tuple[dict, float, float]:
    """The clamped strip of test_ppf with 2 modes, its first frequency (rad/s) and the PPF
    gain (V/V) for a static loop gain of 1."""
    d = beam(2, [], t_end=t_end)
    d["simulation"]["rtol"] = 1e-6
    m, _, k, b, s = first_mode(scenario_from_dict(d))
    return d, float(np.sqrt(k / m)), float(k / (b * s))


def test_ppf_damps_a_link_on_a_torque_driven_hub() -> None:
    """Hub inertia 0.01 kg·m² (the link's own about the joint: 0.005): the pinned-free first
    mode decays several times faster with PPF (tuned on the clamped mode) than without."""
    d, w, unit = plant()
    d["joints"] = hub(0.01)
    rates = {}
    for name, controllers in (("open", []), ("closed", [ppf(w / (2 * np.pi), 0.3 * unit)])):
        d["controllers"] = controllers
        sc = scenario_from_dict(d)
        assert model_path(sc) == "forward"
        results = simulate(sc, shapes=False)
        rates[name] = float(-poles(results, w).real.max())  # the slowest decay in the band
        assert np.abs(np.asarray(results["joint1_angle"])).max() > 1e-4  # the hub moved
    print(f"slowest decay rate near the first mode: {rates}")
    assert rates["closed"] > 5 * rates["open"]


def test_locked_hub_matches_the_prescribed_closed_loop() -> None:
    """With a 10⁴ kg·m² motor inertia the driven hub does not move (< 1e-8 rad) and the
    closed-loop poles of the forward run are those of the prescribed-joint closed loop."""
    d, w, unit = plant()
    d["controllers"] = [ppf(w / (2 * np.pi), 0.3 * unit)]
    reference = scenario_from_dict(d)
    assert model_path(reference) == "closed_loop"
    expected = poles(simulate(reference, shapes=False), w)
    d["joints"] = hub(1e4)
    results = simulate(scenario_from_dict(d), shapes=False)
    assert np.abs(np.asarray(results["joint1_angle"])).max() < 1e-8
    found = poles(results, w)
    print(f"closed-loop poles, prescribed {expected}, forward {found}")
    assert found.size == expected.size > 0
    for e in expected:
        f = found[np.argmin(np.abs(found - e))]
        assert abs(f.real / e.real - 1) < 0.01 and abs(f.imag / e.imag - 1) < 0.01
    volts = np.asarray(results["patch_voltage"])
    command = np.asarray(results["ppf_command"])
    t = np.asarray(results.time)
    assert np.allclose(volts[t > 0.1005], command[t > 0.1005])  # no open-loop part left
    assert np.abs(command).max() > 0.0
    assert np.abs(np.asarray(results["ppf_state1"])).max() > 0.0


def satellite(controllers: list[dict]) -> dict:
    """A free base (10 kg, 0.5 kg·m²) carrying the strip clamped 0.2 m from its centre."""
    d, _, _ = plant(t_end=1.5)
    d["base"] = {"type": "free", "mass": 10.0, "inertia": 0.5}
    d["joints"] = [{"motion": [{"profile": "hold", "angle_deg": 0.0}], "base_point": [0.2, 0.0]}]
    d["controllers"] = controllers
    return d


def test_free_base_momentum_stays_zero_under_control() -> None:
    """The piezo pair is internal: with no external load the linear and angular momentum
    of base + appendage stay at their initial zero while PPF damps the appendage."""
    _, w, unit = plant()
    results = simulate(scenario_from_dict(satellite([ppf(w / (2 * np.pi), 0.3 * unit)])),
                       shapes=False)
    assert model_path(scenario_from_dict(satellite([]))) == "forward"
    assert np.abs(np.asarray(results["ppf_command"])).max() > 1.0
    assert np.abs(np.asarray(results["base_attitude"])).max() > 1e-6  # the base reacts
    for name in ("momentum_x", "momentum_y", "angular_momentum"):
        value = np.abs(np.asarray(results[name])).max()
        print(f"{name}: max |·| = {value:.3g}")
        assert value < 1e-8


def test_unstable_loop_on_a_driven_hub_is_reported() -> None:
    d, w, unit = plant(t_end=20.0)
    d["joints"] = hub(1e4)
    d["controllers"] = [ppf(w / (2 * np.pi), 3.0 * unit)]  # PPF is unstable above gain 1
    with pytest.raises(SimulationError, match=r"closed loop unstable: .* t = "):
        simulate(scenario_from_dict(d), shapes=False)
