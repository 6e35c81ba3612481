"""Driven cases run both in flexlink (forward dynamics, first-order stiffened) and in the
geometrically exact Exudyn model (tests/validation/exudyn_forward_reference.py).

* ``hub_beam``: a rigid hub of inertia J_h on a fixed pin, one beam clamped at its centre,
  slewed by a bang-bang torque. In flexlink joint 1 is ``drive = "torque"`` on a fixed base
  with the hub as the motor's inertia (``motor_inertia = J_h``): the hub *is* joint 1.
* ``free_hub``: a satellite-like hub free in the plane (``[base] type = "free"``) with two
  appendages at ±0.5 m, slewed by a bang-bang moment on the hub (``[[base.loads]]``), as
  examples/satellite_slew.toml but faster and harder.
* ``elastic_joint``: the hub–beam's beam on an elastic joint (no hub inertia), its motor
  turned by a bang-bang torque through a gear (docs/elastic_joints.md); in Exudyn a pinned
  rotor body of the reflected inertia coupled to the hub by a coordinate spring.
* ``cart``: examples/cart_beam.toml undamped — a beam with a tip mass hanging from a 2 kg
  cart (``[base] type = "cart"``) on a level rail, gravity, the cart pushed by a bang-bang force
  along the rail (``amplitude`` in N); in Exudyn the hub is the cart, held to the rail by
  constraints (``rail = True``). The same beam standing on the cart (``cart_inverted``: its
  weight compresses it, 1/4 of its tip-load buckling load) and held level
  (``cart_horizontal``: released undeformed, it sags and swings to ≈ 20% of its length under
  its weight, past the first-order model's validity).
* ``pendulum``: the hub–beam's pin and hub with a stiffer beam and a tip mass (L = 1 m,
  1 kg/m, EI = 100 N·m², 0.2 kg) in a vertical plane, released level and undeformed under
  gravity with no torque: it falls and swings through 170° in 2 s, bending 2.4% of its
  length (tests/validation/test_gravity.py checks its accuracy).
* ``arm``: a gravity-loaded arm moved rest to rest: examples/vertical_arm.toml's arm (1 m,
  0.8 kg/m, EI = 150 N·m², 0.3 kg payload) on a pinned 0.5 kg·m² hub, hanging at rest, swung
  up 70° (cycloidal, 1 s) by the rigid arm's inverse-dynamics torque (inertia and weight,
  then the weight's holding torque), 2.5 s; the static sag at the end is ≈ 1.2% of L.

Each hub at two deflection levels: ``small`` (peak tip deflection ≈ 3% of the length) and
``large`` (≥ 30%); the cart at ≈ 2.4%. Both models are undamped. Signals (SI, per case):
``tip`` — tip deflection of the (first) appendage in its clamped root frame (m); ``hub_angle`` (rad); ``hub_rate``
(rad/s); the free case adds ``hub_momentum`` = J_h × hub rate (N·m·s, the hub's own angular
momentum about its centre), the elastic joint ``motor_angle`` (rad, motor shaft) and
``spring_torque`` (N·m); the cart has ``cart_travel`` (m) in place of the hub's angle and
rate.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from flexlink.model import (
    BangBang,
    Base,
    BaseLoad,
    Chain,
    ElasticJoint,
    Link,
    PointSensor,
    Scenario,
    SimulationSettings,
    Table,
    TorqueDrive,
)
from flexlink.motion import Hold

from .exudyn_forward_reference import Appendage, simulate_hub_exudyn
from .exudyn_pieces import BeamSection, default_section


@dataclass(frozen=True)
class DrivenCase:
    """One driven manoeuvre: a bang-bang moment ``amplitude`` (N·m) from 0 to ``slew`` (s),
    ``t_end`` (s) simulated, output every ``dt_out`` (s)."""

    name: str
    kind: str  # "hub_beam", "free_hub", "elastic_joint" (amplitude: the motor's torque), "cart",
    # "pendulum" or "arm" (amplitude unused: `arm_torque`)
    amplitude: float
    slew: float
    t_end: float
    dt_out: float
    beam_angle: float = -90.0  # deg from the rail, the cart's beam (kind "cart" only)

    @property
    def moment(self) -> BangBang | Table:
        return arm_torque(self) if self.kind == "arm" else BangBang(self.amplitude, 0.0,
                                                                     self.slew)


# hub–beam: L = 1 m, ρA = 1 kg/m, EI = 10 N·m² (first clamped mode 1.77 Hz), J_h = 1 kg·m²
# (η = J_h/(ρA L³) = 1); a 2 s slew of 1.5 rad (small) or 15 rad (large: the beam whirls at
# up to 15 rad/s, above its clamped frequency — centrifugal stiffening is not small).
HUB_INERTIA = 1.0
BEAM = Link("beam", 1.0, 1.0, 10.0, thickness=0.02)
# free hub: 100 kg, 20 kg·m²; two 3 m arrays, 2 kg/m, EI = 200 N·m² (0.62 Hz), at ±0.5 m
SAT_MASS, SAT_INERTIA, SAT_OFFSET = 100.0, 20.0, 0.5
ARRAY = Link("array_right", 3.0, 2.0, 200.0, thickness=0.02)
# elastic joint: BEAM on a spring k = 50 N·m/rad to a rotor J_m = 2·10⁻³ kg·m² through N = 10
# (reflected 0.2 kg·m²); ±0.1 N·m on the motor over 2 s slews the link 108°, tip 4.4% of L
GEAR, ROTOR, SPRING = 10.0, 2e-3, 50.0

# cart: examples/cart_beam.toml's beam (1.2 m, 0.8 kg/m, EI = 30 N·m², tip 0.3 kg) hanging from
# a 2 kg cart, ±4 N for 1 s
CART_MASS = 2.0
CART_BEAM = Link("beam", 1.2, 0.8, 30.0, tip_mass=0.3, thickness=0.01)
G = 9.81
PENDULUM_BEAM = Link("beam", 1.0, 1.0, 100.0, thickness=0.02, tip_mass=0.2)
# arm: examples/vertical_arm.toml's arm on a pinned hub, hanging, raised by ARM_SWING (rad)
ARM_BEAM = Link("arm", 1.0, 0.8, 150.0, thickness=0.01, tip_mass=0.3)
ARM_HUB, ARM_START, ARM_SWING, ARM_MOVE_AT = 0.5, -np.pi / 2, np.radians(70.0), 0.2


def arm_torque(case: DrivenCase, samples: int = 2001) -> Table:
    """The rigid arm's inverse-dynamics torque (N·m) along a cycloidal move of ``case.slew``
    (s) from ARM_START by ARM_SWING (rad), starting at ARM_MOVE_AT (s): J θ̈ + m g d cos θ,
    J the hub, beam and payload about the pin; sampled on ``samples`` points over the run."""
    link = ARM_BEAM
    inertia = ARM_HUB + link.mass_per_length * link.length**3 / 3 + link.tip_mass * link.length**2
    moment = G * (link.mass_per_length * link.length**2 / 2 + link.tip_mass * link.length)
    t = np.linspace(0.0, case.t_end, samples)
    s = np.clip((t - ARM_MOVE_AT) / case.slew, 0.0, 1.0)
    angle = ARM_START + ARM_SWING * (s - np.sin(2 * np.pi * s) / (2 * np.pi))
    accel = np.where((s > 0) & (s < 1), ARM_SWING * 2 * np.pi / case.slew**2
                     * np.sin(2 * np.pi * s), 0.0)
    return Table(tuple(t), tuple(inertia * accel + moment * np.cos(angle)))

CASES = {c.name: c for c in (
    DrivenCase("hub_beam_small", "hub_beam", 2.0, 2.0, 4.0, 0.002),
    DrivenCase("hub_beam_large", "hub_beam", 20.0, 2.0, 4.0, 0.002),
    DrivenCase("free_hub_small", "free_hub", 8.0, 4.0, 8.0, 0.004),
    DrivenCase("free_hub_large", "free_hub", 100.0, 4.0, 8.0, 0.004),
    DrivenCase("elastic_joint", "elastic_joint", 0.1, 2.0, 4.0, 0.002),
    DrivenCase("cart_hanging", "cart", 4.0, 1.0, 2.0, 0.002),
    DrivenCase("cart_inverted", "cart", 4.0, 1.0, 2.0, 0.002, beam_angle=90.0),
    DrivenCase("cart_horizontal", "cart", 4.0, 1.0, 2.0, 0.002, beam_angle=0.0),
    DrivenCase("pendulum", "pendulum", 0.0, 1.0, 2.0, 0.002),
    DrivenCase("arm", "arm", 0.0, 1.0, 2.5, 0.002),
)}


def flexlink_scenario(case: DrivenCase, modes: int = 6, rtol: float = 1e-6) -> Scenario:
    """The case as a flexlink scenario (first order, stiffened, undamped)."""
    settings = SimulationSettings(case.t_end, case.dt_out, geometric_stiffening=True, rtol=rtol)
    if case.kind in ("hub_beam", "elastic_joint", "pendulum", "arm"):
        beam = {"pendulum": PENDULUM_BEAM, "arm": ARM_BEAM}.get(case.kind, BEAM)
        link = _with_modes(beam, modes)
        joint = (ElasticJoint(TorqueDrive(case.moment, motor_inertia=ROTOR), SPRING,
                              gear_ratio=GEAR) if case.kind == "elastic_joint"
                 else TorqueDrive(case.moment, motor_inertia=ARM_HUB,
                                  initial_angle=ARM_START) if case.kind == "arm"
                 else TorqueDrive(case.moment, motor_inertia=HUB_INERTIA))
        if case.kind in ("pendulum", "arm"):
            settings = replace(settings, gravity=(0.0, -G))
        chain = Chain((link,), (joint,))
        sensors = (PointSensor("tip", "deflection", 0, link.length),)
        return Scenario(chain, sensors, settings, name=case.name)
    if case.kind == "cart":
        from flexlink.model import Cart

        link = _with_modes(CART_BEAM, modes)
        base = Base("cart", mass=CART_MASS, cart=Cart(TorqueDrive(case.moment)))
        sensors = (PointSensor("tip", "deflection", 0, link.length),)
        settings = SimulationSettings(case.t_end, case.dt_out, geometric_stiffening=True,
                                      rtol=rtol, gravity=(0.0, -G))
        return Scenario(Chain((link,), (Hold(case.beam_angle),)), sensors, settings, base=base,
                        name=case.name)
    right = _with_modes(ARRAY, modes)
    left = _with_modes(Link("array_left", ARRAY.length, ARRAY.mass_per_length, ARRAY.EI,
                            thickness=ARRAY.thickness), modes)
    base = Base("free", mass=SAT_MASS, inertia=SAT_INERTIA,
                attachments=((0, (SAT_OFFSET, 0.0)), (1, (-SAT_OFFSET, 0.0))),
                loads=(BaseLoad(moment=case.moment),))
    chain = Chain((right, left), (Hold(0.0), Hold(180.0)))
    sensors = (PointSensor("tip", "deflection", 0, right.length),)
    return Scenario(chain, sensors, settings, base=base, name=case.name)


def _with_modes(link: Link, modes: int) -> Link:
    return replace(link, modes=modes, damping_ratio=0.0)


def flexlink_signals(case: DrivenCase, results: Any) -> dict[str, np.ndarray]:
    """The comparison signals of a flexlink run (see the module docstring)."""
    if case.kind == "cart":
        return {"tip": np.asarray(results["tip"]),
                "cart_travel": np.asarray(results["cart_position"])}
    if case.kind != "free_hub":
        out = {"tip": np.asarray(results["tip"]), "hub_angle": np.asarray(results["joint1_angle"]),
               "hub_rate": np.asarray(results["joint1_rate"])}
        if case.kind == "elastic_joint":
            out["motor_angle"] = np.asarray(results["joint1_motor_angle"])
            out["spring_torque"] = np.asarray(results["joint1_spring_torque"])
        return out
    rate = np.asarray(results["base_attitude_rate"])
    return {"tip": np.asarray(results["tip"]), "hub_angle": np.asarray(results["base_attitude"]),
            "hub_rate": rate, "hub_momentum": SAT_INERTIA * rate}


# Exudyn's section near flexlink's Euler–Bernoulli beam: shear stiffness ×10, rotary inertia
# ×0.01 (a tenth of the section's shear flexibility left; ×100 stalls Newton).
THIN_SHEAR, THIN_ROTARY = 10.0, 0.01


def thin_section(link: Link) -> BeamSection:
    """`default_section` with the shear stiffness times THIN_SHEAR and the rotary inertia
    times THIN_ROTARY."""
    s = default_section(link)
    return BeamSection(s.EA, THIN_SHEAR * s.GA, THIN_ROTARY * s.rhoI)


def exudyn_signals(case: DrivenCase, elements: int, dt: float, thin: bool = False
                   ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """The comparison signals of the Exudyn model with ``elements`` per appendage and step
    ``dt`` (s), and the raw result (wall time, coordinates); ``thin``: every beam on
    `thin_section`, near the Euler–Bernoulli limit flexlink models (the default section's
    shear flexibility and rotary inertia, terms in (h/L)², slow its vibrations: on the
    pendulum 0.8% of the tip's peak after 2 s)."""
    moment = case.moment

    def app(link: Link, **kw: Any) -> Appendage:
        return Appendage(link, section=thin_section(link) if thin else None, **kw)

    def m(t: float) -> float:
        return float(moment.value(np.asarray(t)))

    if case.kind in ("hub_beam", "pendulum"):
        pendulum = case.kind == "pendulum"
        out = simulate_hub_exudyn([app(PENDULUM_BEAM if pendulum else BEAM)], HUB_INERTIA,
                                  m, case.t_end, case.dt_out, elements, dt=dt,
                                  gravity=(0.0, -G) if pendulum else (0.0, 0.0))
    elif case.kind == "arm":  # Exudyn's hub angle counts from the hanging start
        out = simulate_hub_exudyn([app(ARM_BEAM, angle=ARM_START)], ARM_HUB, m, case.t_end,
                                  case.dt_out, elements, dt=dt, gravity=(0.0, -G))
        out["hub_angle"] = out["hub_angle"] + ARM_START
    elif case.kind == "elastic_joint":  # N τ_m on the reflected rotor
        out = simulate_hub_exudyn([app(BEAM)], 0.0, lambda t: GEAR * m(t), case.t_end,
                                  case.dt_out, elements, dt=dt,
                                  rotor=(GEAR**2 * ROTOR, SPRING, 0.0))
    elif case.kind == "cart":
        out = simulate_hub_exudyn([app(CART_BEAM, angle=np.radians(case.beam_angle))], 0.0, m,
                                  case.t_end, case.dt_out, elements, hub_mass=CART_MASS,
                                  dt=dt, gravity=(0.0, -G), rail=True)
        return ({"tip": np.asarray(out["tip_deflection"][0]),
                 "cart_travel": out["hub_position"][:, 0]}, out)
    else:
        arrays = [app(ARRAY, point=(SAT_OFFSET, 0.0), angle=0.0),
                  app(ARRAY, point=(-SAT_OFFSET, 0.0), angle=np.pi)]
        out = simulate_hub_exudyn(arrays, SAT_INERTIA, m, case.t_end, case.dt_out, elements,
                                  pinned=False, hub_mass=SAT_MASS, dt=dt)
    signals = {"tip": np.asarray(out["tip_deflection"][0]), "hub_angle": out["hub_angle"],
               "hub_rate": out["hub_rate"]}
    if case.kind == "free_hub":
        signals["hub_momentum"] = SAT_INERTIA * out["hub_rate"]
    if case.kind == "elastic_joint":
        signals["motor_angle"] = GEAR * out["rotor_angle"]
        signals["spring_torque"] = SPRING * (out["rotor_angle"] - out["hub_angle"])
    return signals, out


def error_of_peak(ours: dict[str, np.ndarray], reference: dict[str, np.ndarray]
                  ) -> dict[str, float]:
    """max |ours − reference| / max |reference|, per signal of the reference."""
    return {k: float(np.abs(ours[k] - ref).max() / np.abs(ref).max())
            for k, ref in reference.items()}
