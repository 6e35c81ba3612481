"""Immutable description of a planar chain: links, joints, sensors, simulation settings.

Everything here is in SI units and radians. Degrees only appear at the scenario/CLI edge,
which converts them once.  Objects are frozen: algorithms take a model and never mutate it.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal, Protocol, runtime_checkable

import numpy as np

if TYPE_CHECKING:
    from .drives import Base

ModeShapes = Literal["clamped_free", "tip_loaded", "outboard_loaded"]
PointSensorKind = Literal["deflection", "slope", "strain", "acceleration"]


@dataclass(frozen=True)
class Link:
    """A uniform Euler–Bernoulli link, clamped at its joint.

    Its local x axis runs from the joint along the undeformed link, y is x turned +90°.
    Transverse deflection w(x, t) is positive along +y.
    """

    name: str
    length: float  # m
    mass_per_length: float  # kg/m
    EI: float  # N·m²
    tip_mass: float = 0.0  # kg, point mass at x = length
    tip_inertia: float = 0.0  # kg·m², about the tip, rotates with the tip section
    damping_ratio: float = 0.0  # modal damping ratio of every clamped mode
    modes: int = 4  # number of assumed modes
    # clamped_free: classical cantilever modes; tip_loaded: modes of the cantilever with this
    # link's tip mass and inertia; outboard_loaded: the tip body also holds the rest of the chain
    # (rigid, as at t = 0) — lets an inner link carry the outer links' tip moment.
    mode_shapes: ModeShapes = "clamped_free"
    thickness: float | None = None  # m, section depth in the bending plane (strain sensors)

    @property
    def mass(self) -> float:
        """Beam mass plus tip mass, kg."""
        return self.mass_per_length * self.length + self.tip_mass


@runtime_checkable
class JointMotion(Protocol):
    """A prescribed joint angle history β(t)."""

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Angle (rad), rate (rad/s) and acceleration (rad/s²) at times t (s)."""
        ...


@dataclass(frozen=True)
class PointSensor:
    """A sensor at a material point x (m, from the link's joint) of one link.

    kinds: ``deflection`` w(x) [m], ``slope`` w'(x) [rad], ``strain`` surface bending strain
    on the link's +y face, −(h/2)·w''(x) [-], ``acceleration`` absolute acceleration of the
    point along the deformed normal [m/s²].
    """

    name: str
    kind: PointSensorKind
    link: int  # index into Chain.links
    x: float
    thickness: float | None = None  # m, for strain (defaults to the link's thickness)


@dataclass(frozen=True)
class PiezoSensor:
    """A PZT patch read through the pin-force model (paper eq. 37):

    v = w_p E_p d31 (t/2) [w'(x_end) − w'(x_start)] / C_c   [V].
    """

    name: str
    link: int
    x_start: float  # m
    x_end: float  # m
    width: float  # m, patch width w_p
    E_p: float  # Pa
    d31: float  # m/V
    thickness: float  # m, host beam thickness t
    capacitance: float  # F, charge-amplifier capacitance C_c

    @property
    def gain(self) -> float:
        """Volts per radian of slope difference."""
        return self.width * self.E_p * self.d31 * 0.5 * self.thickness / self.capacitance


Sensor = PointSensor | PiezoSensor


@dataclass(frozen=True)
class SimulationSettings:
    t_end: float  # s
    dt_out: float  # s
    geometric_stiffening: bool = False
    rtol: float = 1e-6  # error relative to the peak of the displacements / velocities
    atol: float = 1e-12
    method: str = "lawson"  # or "magnus", or a solve_ivp method: "DOP853", "RK45", "Radau", "LSODA"
    model: str = "first_order"  # or "nonlinear": large deflections (docs/nonlinear.md)
    step: float | None = None  # s, fixed step of the nonlinear model (None: step halving)


@dataclass(frozen=True)
class Chain:
    """N ≥ 1 links in series. Joint 1 is a hub at the fixed origin; joint k > 1 sits at the
    deformed tip of link k−1. β1 is absolute (from X), βk is relative to link k−1's deformed
    tip tangent. A joint is a prescribed ``JointMotion`` or a drive of ``flexlink.drives``
    (forward dynamics); a ``Scenario.base`` may move the hub and start branches on it."""

    links: tuple[Link, ...]
    joints: tuple[JointMotion, ...]

    def __post_init__(self) -> None:
        if len(self.links) == 0:
            raise ValueError("a chain needs at least one link")
        if len(self.joints) != len(self.links):
            raise ValueError(
                f"a chain needs one joint per link: {len(self.links)} links, "
                f"{len(self.joints)} joints"
            )

    def link_index(self, name: str) -> int:
        for i, link in enumerate(self.links):
            if link.name == name:
                return i
        raise KeyError(name)


@dataclass(frozen=True)
class Scenario:
    """Everything one simulation needs."""

    chain: Chain
    sensors: tuple[Sensor, ...] = ()
    settings: SimulationSettings = field(
        default_factory=lambda: SimulationSettings(t_end=1.0, dt_out=1e-3)
    )
    name: str = "scenario"
    # None: the chain hangs on a fixed hub at the origin. A Base (flexlink.drives) makes the
    # hub free or pinned, carries applied loads and lets several branches start on it.
    base: Base | None = None
