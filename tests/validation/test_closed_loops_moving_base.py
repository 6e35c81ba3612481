"""Closed loops on a moving base (first-order model): ground pivots and slider lines fixed
in the base. A four-bar on a cart accelerating uniformly against the same four-bar on a fixed
base in the equivalent gravity field (the equivalence principle, which the first-order model
holds exactly: gravity is the base's extra acceleration); a four-bar on a free base in
space against the conservation of momentum and of the energy of its rigid bodies (computed
here from the joint angles and rates); the closure residual through the runs."""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np
import pytest

import flexlink
from flexlink.scenario import scenario_from_dict
from tests.validation.test_closed_loops import FOUR_BAR, L1, L2, L3, MASS, D, _bar_energy

ACCELERATION = 3.0  # m/s², the cart's along its rail
RAIL = math.radians(30.0)


@dataclasses.dataclass(frozen=True)
class UniformAcceleration:
    """Travel ½ a t² (m) from rest: a constant acceleration a (m/s²)."""

    a: float
    breakpoints: tuple[float, ...] = ()

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        return 0.5 * self.a * t**2, self.a * t, self.a + 0 * t


def _swinging(flexible: bool = True) -> dict:
    """FOUR_BAR with a free crank at rest (the field swings it), a flexible coupler."""
    d = copy.deepcopy(FOUR_BAR)
    d["simulation"].update(t_end=0.5, dt_out=1e-3, rtol=1e-9)
    d["joints"][0] = {"drive": "free", "initial_angle_deg": 90.0}
    if flexible:
        d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": MASS[1],
                         "EI": 20.0, "modes": 3}
    return d


def test_a_uniformly_accelerated_cart_is_the_equivalent_gravity_field() -> None:
    """The four-bar on a cart whose rail runs at 30° and which accelerates at 3 m/s²
    from rest, against the fixed four-bar in gravity −a along the rail: joint angles and
    rates, the pin's force and the coupler's deflection equal to the integration
    tolerance."""
    d = _swinging()
    d["base"] = {"type": "cart", "mass": 5.0,
                 "cart": {"rail_angle_deg": math.degrees(RAIL), "drive": "prescribed",
                          "motion": [{"profile": "hold", "position": 0.0}]}}
    d["sensors"] = [{"name": "bend", "kind": "deflection", "link": "coupler", "x": 0.15}]
    scenario = scenario_from_dict(d)
    cart = dataclasses.replace(scenario.base.cart, drive=UniformAcceleration(ACCELERATION))
    scenario = dataclasses.replace(scenario, base=dataclasses.replace(scenario.base, cart=cart))
    on_cart = flexlink.simulate(scenario, shapes=False)
    fixed = copy.deepcopy(d)
    del fixed["base"]
    fixed["simulation"]["gravity"] = [-ACCELERATION * math.cos(RAIL),
                                      -ACCELERATION * math.sin(RAIL)]
    reference = flexlink.simulate(scenario_from_dict(fixed), shapes=False)
    assert np.asarray(on_cart["cart_position"])[-1] == pytest.approx(0.5 * ACCELERATION * 0.25)
    for name in ("joint1_angle", "joint2_angle", "joint3_angle", "joint1_rate",
                 "pin_force_x", "pin_force_y", "bend"):
        ref = np.asarray(reference[name])
        scale = np.abs(ref - ref[0]).max()
        assert scale > 0, name
        assert np.abs(np.asarray(on_cart[name]) - ref).max() < 1e-6 * scale, name
    assert np.abs(np.asarray(on_cart["joint1_angle"]) - np.pi / 2).max() > 0.1  # it swung
    assert on_cart.metadata["closure_residual_relative"] <= 1e-8


def test_a_four_bar_on_a_free_base_keeps_its_momentum_and_energy() -> None:
    """Rigid bars on a free base (2 kg, 0.01 kg·m²) in space, the crank started at 2 rev/s:
    linear and angular momentum constant, and the kinetic energy of base and bars
    (from the base's pose and rates and the joints') constant."""
    d = _swinging(flexible=False)
    d["joints"][0]["initial_rate_deg_s"] = 720.0
    d["base"] = {"type": "free", "mass": 2.0, "inertia": 0.01}
    r = flexlink.simulate(scenario_from_dict(d), shapes=False)
    for name in ("momentum_x", "momentum_y", "angular_momentum"):
        m = np.asarray(r[name])
        assert np.abs(m - m[0]).max() < 1e-7 * max(np.abs(m).max(), 1e-3), name
    t = np.asarray(r.time)
    att, w_b = np.asarray(r["base_attitude"]), np.asarray(r["base_attitude_rate"])
    v_b = np.stack([r["base_x_rate"], r["base_y_rate"]], -1)
    b1, b2, b3 = (np.asarray(r[f"joint{k}_angle"]) for k in (1, 2, 3))
    w1, w2, w3 = (np.asarray(r[f"joint{k}_rate"]) for k in (1, 2, 3))

    def turn(x: np.ndarray, y: float, angle: np.ndarray) -> np.ndarray:
        return np.stack([np.cos(angle) * x - np.sin(angle) * y,
                         np.sin(angle) * x + np.cos(angle) * y], -1)

    def perp(angle: np.ndarray) -> np.ndarray:
        return np.stack([-np.sin(angle), np.cos(angle)], -1)

    pivot_r = turn(np.full(t.size, D), 0.0, att)  # the rocker's pivot, from the base's point
    v_rocker = v_b + w_b[:, None] * np.stack([-pivot_r[:, 1], pivot_r[:, 0]], -1)
    a1, a3 = att + b1, att + b3
    v_tip = v_b + L1 * (w_b + w1)[:, None] * perp(a1)
    energy = (0.5 * 2.0 * np.sum(v_b**2, 1) + 0.5 * 0.01 * w_b**2
              + _bar_energy(MASS[0] * L1, L1, v_b, a1, w_b + w1)
              + _bar_energy(MASS[1] * L2, L2, v_tip, a1 + b2, w_b + w1 + w2)
              + _bar_energy(MASS[2] * L3, L3, v_rocker, a3, w_b + w3))
    assert np.abs(att - att[0]).max() > 0.05  # the base turned in reaction
    assert np.abs(energy - energy[0]).max() < 1e-6 * energy[0]
    assert r.metadata["closure_residual_relative"] <= 1e-8


def test_an_elastic_crank_on_a_free_cart_sets_the_reduced_inertia_frequency() -> None:
    """Rigid four-bar, crank joint elastic with its motor held, on a free cart (1 kg) on a
    rail at 30°: T = ½ M ṡ² + c ṡ β̇₁ + ½ I_eff β̇₁², so ω² = k / (I_eff − c²/M), c the bars'
    momentum along the rail per unit crank rate; the plant's states name the cart."""
    from tests.validation.test_closed_loops import _four_bar_angles
    from tests.validation.test_closed_loops_elastic_joints import K as SPRING
    from tests.validation.test_closed_loops_elastic_joints import _crank_inertia, _elastic

    cart_mass, crank = 1.0, math.radians(90.0)
    d = _elastic()
    d["base"] = {"type": "cart", "mass": cart_mass,
                 "cart": {"rail_angle_deg": math.degrees(RAIL), "drive": "force",
                          "force": [{"profile": "step", "amplitude": 0.0}]}}
    plant = flexlink.linearize(scenario_from_dict(d), at=0.0)
    assert plant.state_names[:2] == ("cart_position", "joint1_angle")
    a, b, c = _four_bar_angles(crank)
    e = [np.array([-np.sin(x), np.cos(x)]) for x in (a, b, c)]
    rate_b, rate_c = np.linalg.solve(np.column_stack([L2 * e[1], -L3 * e[2]]), -L1 * e[0])
    centres = (0.5 * L1 * e[0], L1 * e[0] + 0.5 * L2 * rate_b * e[1], 0.5 * L3 * rate_c * e[2])
    masses = (MASS[0] * L1, MASS[1] * L2, MASS[2] * L3)
    rail = np.array([math.cos(RAIL), math.sin(RAIL)])
    coupling = sum(m * float(v @ rail) for m, v in zip(masses, centres))
    total = cart_mass + sum(masses)
    exact = math.sqrt(SPRING / (_crank_inertia(crank) - coupling**2 / total)) / (2 * math.pi)
    f = np.sort(np.abs(np.linalg.eigvals(plant.A).imag)) / (2 * math.pi)
    assert f[-1] == pytest.approx(exact, rel=1e-7)
    assert exact > 1.01 * math.sqrt(SPRING / _crank_inertia(crank)) / (2 * math.pi)
