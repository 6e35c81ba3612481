"""Piezo actuators in every model path (docs/closed_loop.md): the nonlinear model against the
first-order one at small voltage and against the exact elastica at large voltage, the
actuator's work against the change of energy, and a pinned hub whose angular momentum an
actuator (an internal moment pair) cannot change."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.nonlinear import NonlinearSystem
from flexlink.model import Table
from flexlink.scenario import scenario_from_dict
from flexlink.simulation import model_path, simulate
from flexlink.solvers.gauss import solve_nonlinear

L, EI, XS, XE = 0.6, 0.16333333333333333, 0.1, 0.2
PATCH = {"x_start": XS, "x_end": XE, "width": 0.025, "E_p": 30.33e9, "d31": 265e-12}


def scenario(model: str, volts: float, modes: int = 8, t_end: float = 4.0,
             damping: float = 0.9, base: dict | None = None, voltage: list | None = None,
             step: float | None = None):
    d = {"simulation": {"t_end": t_end, "dt_out": 1e-3, "model": model,
                        **({"step": step} if step else {})},
         "links": [{"name": "beam", "length": L, "mass_per_length": 0.0636, "EI": EI,
                    "thickness": 0.001, "damping_ratio": damping, "modes": modes}],
         "joints": [{"motion": [{"profile": "hold", "angle_deg": 0.0}]}],
         "sensors": [{"name": "tip", "kind": "deflection", "link": "beam", "x": L},
                     {"name": "pzt", "kind": "piezo", "link": "beam", "capacitance": 1e-6,
                      **PATCH}],
         "actuators": [{"name": "patch", "kind": "piezo", "collocated_with": "pzt",
                        "voltage": voltage or [{"profile": "step", "amplitude": volts}]}]}
    if base is not None:
        d["base"] = base
    return scenario_from_dict(d)


def final_tip(model: str, volts: float, modes: int = 8, step: float | None = None) -> float:
    results = simulate(scenario(model, volts, modes, step=step), shapes=False)
    assert float(np.asarray(results["patch_voltage"])[-1]) == volts
    return float(np.asarray(results["tip"])[-1])


def test_nonlinear_static_deflection_at_small_voltage_is_first_order() -> None:
    """At 10 V (tip 0.3 mm, L/2000) both models settle to the same tip deflection within the
    O(φ²) geometric difference (φ ≈ 6e-5 rad across the patch)."""
    linear, nonlinear = final_tip("first_order", 10.0, 4), final_tip("nonlinear", 10.0, 4)
    assert abs(nonlinear / linear - 1) < 1e-5


def test_nonlinear_static_tip_is_the_elastica_at_large_voltage() -> None:
    """A moment pair M at the patch ends bends the inextensible beam into a circular arc of
    curvature κ = M/EI between them (straight outside): the tip sits at
    w = (1 − cos φ)/κ + (L − x_e) sin φ, φ = κ (x_e − x_s). At φ = 0.5 rad the linear
    prediction κ(x_e − x_s)(L − (x_s + x_e)/2) is 4% off; the nonlinear model is within the
    modal-series error of the linear case (2e-3 with 8 modes, test_actuator_static.py)."""
    sc = scenario("nonlinear", 1.0)
    volts = 0.5 / (sc.actuators[0].moment_per_volt / EI * (XE - XS))
    kappa = sc.actuators[0].moment_per_volt * volts / EI
    phi = kappa * (XE - XS)
    exact = (1 - np.cos(phi)) / kappa + (L - XE) * np.sin(phi)
    linear = kappa * (XE - XS) * (L - 0.5 * (XS + XE))
    assert abs(linear / exact - 1) > 0.03
    # (the static end state needs no step control: the 8 kV step rings the top modes)
    errors = [abs(final_tip("nonlinear", volts, modes, 2e-3) / exact - 1) for modes in (4, 8)]
    print(f"elastica: tip error {errors} (4, 8 modes)")
    assert errors[1] < 3e-3
    assert errors[1] < errors[0]


def test_actuator_work_is_the_change_of_energy() -> None:
    """Undamped, joints held: the work ∫ V Bᵀq̇ dt of a voltage pulse equals the kinetic plus
    elastic energy of the nonlinear model at every instant."""
    pulse = Table((0.0, 0.02, 0.04, 0.06), (0.0, 2000.0, -2000.0, 0.0))
    sc = scenario("nonlinear", 0.0, modes=4, t_end=0.2, damping=0.0)
    system = NonlinearSystem(sc.chain, actuators=[
        type(sc.actuators[0])(**{**sc.actuators[0].__dict__, "voltage": pulse})])
    t = np.linspace(0.0, 0.2, 4001)
    solution = solve_nonlinear(system, t, 1e-8, step=2.5e-4)
    power = np.einsum("ta,na,tn->t", system.voltages(t), system.actuator_B, solution.q_dot)
    work = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(t))])
    kinetic, elastic = system.energy(t, solution.q, solution.q_dot)
    energy = kinetic + elastic
    assert energy.max() > 1e-4  # J: the pulse did work
    np.testing.assert_allclose(energy, work, rtol=0, atol=1e-4 * energy.max())


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_actuator_on_a_pinned_hub_keeps_the_angular_momentum(model: str) -> None:
    """A pinned hub with a flexible beam and an actuator on it: the moment pair is internal,
    so the angular momentum stays zero (to 1e-8 N·m·s) while the hub turns."""
    sc = scenario(model, 0.0, modes=3, t_end=0.5, damping=0.05,
                  base={"type": "pinned", "inertia": 0.002},
                  voltage=[{"profile": "bang_bang", "amplitude": 500.0, "start": 0.0,
                            "duration": 0.1}])
    assert model_path(sc) == ("forward" if model == "first_order" else "nonlinear_forward")
    results = simulate(sc, shapes=False)
    hub = np.asarray(results["base_attitude"])
    assert np.abs(hub).max() > 1e-4  # rad: the hub reacts to the beam's bending
    assert np.abs(np.asarray(results["angular_momentum"])).max() < 1e-8
    assert np.abs(np.asarray(results["patch_voltage"])).max() == 500.0
