"""Links and the chain they form with their joints (SI units, radians).

Objects are frozen: algorithms take a model and never mutate it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

from .joints import Joint


@dataclass(frozen=True)
class Body:
    """A rigid body fixed to a link's section at ``at`` (m from the joint, 0 ≤ at ≤ length).

    It turns with the section (the link's angle plus the slope w'(at)); its centre of mass sits
    at the deformed section point plus ``offset`` (m) in the section's frame (x along the
    tangent, y along the normal); ``inertia`` is about that centre (kg·m²). A link's
    ``tip_mass``/``tip_inertia`` is the body at the tip with zero offset."""

    at: float  # m, along the undeformed link
    mass: float = 0.0  # kg
    offset: tuple[float, float] = (0.0, 0.0)  # m, centre of mass in the section's frame
    inertia: float = 0.0  # kg·m², about the centre of mass
    name: str = ""

    def inertia_about_section(self) -> float:
        """Rotary inertia about the section point, kg·m²: J_c + m|c|²."""
        dx, dy = self.offset
        return self.inertia + self.mass * (dx * dx + dy * dy)


ModeShapes = Literal["auto", "clamped_free", "tip_loaded", "outboard_loaded", "hub_loaded",
                     "pinned_pinned", "pinned_loaded"]
MODE_SHAPES: tuple[str, ...] = get_args(ModeShapes)


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
    modes: int = 4  # number of assumed modes; 0: a rigid link (EI is then not used)
    # clamped_free: classical cantilever modes; tip_loaded: modes of the cantilever with this
    # link's tip mass and inertia; outboard_loaded: the tip body also holds the rest of the chain
    # (rigid, as at t = 0) — lets an inner link carry the outer links' tip moment; hub_loaded:
    # the modes of the link on its free joint or pinned hub, with its tip body or what its tip
    # carries; pinned_pinned: sine modes in the chord frame, for a member on a free joint whose
    # far end a closed loop holds; auto: chosen from the chain (model.basis, docs/modes.md),
    # the scenario files' default.
    mode_shapes: ModeShapes = "clamped_free"
    thickness: float | None = None  # m, section depth in the bending plane (strain sensors)
    bodies: tuple[Body, ...] = ()  # rigid bodies on the link besides the tip mass (`Body`)
    # m/s, the rates q̇(0) of the link's modal coordinates in its basis (one per mode); ():
    # at rest. Forward runs only (`ForwardSystem`, `NonlinearForwardSystem`).
    initial_modal_rates: tuple[float, ...] = ()

    def all_bodies(self) -> tuple[Body, ...]:
        """Every rigid body on the link: the tip mass and inertia as the body at x = length
        with zero offset (when either is non-zero), then ``bodies``."""
        tip = ((Body(self.length, self.tip_mass, (0.0, 0.0), self.tip_inertia, "tip"),)
               if self.tip_mass or self.tip_inertia else ())
        return tip + tuple(self.bodies)

    def tip_body(self) -> tuple[float, float, float]:
        """What the bodies at the tip (at = length) hold there, for the tip-loaded bases:
        (mass kg, rotary inertia about the tip section point kg·m², first moment along the
        tip's tangent m·offset_x kg·m)."""
        mass = inertia = moment = 0.0
        for body in self.all_bodies():
            if body.at == self.length:
                mass += body.mass
                inertia += body.inertia_about_section()
                moment += body.mass * body.offset[0]
        return mass, inertia, moment

    @property
    def rigid(self) -> bool:
        """Whether the link has no assumed modes (it does not bend)."""
        return self.modes == 0

    @property
    def mass(self) -> float:
        """Beam mass plus the bodies' masses (tip mass included), kg."""
        return (self.mass_per_length * self.length + self.tip_mass
                + sum(b.mass for b in self.bodies))


@dataclass(frozen=True)
class Chain:
    """N ≥ 1 links in series. Joint 1 is a hub at the fixed origin; joint k > 1 sits at the
    deformed tip of link k−1. β1 is absolute (from X), βk is relative to link k−1's deformed
    tip tangent. A joint is a prescribed ``JointMotion`` or a drive (``model.joints``:
    forward dynamics); a ``Scenario.base`` may move the hub and start branches on it."""

    links: tuple[Link, ...]
    joints: tuple[Joint, ...]

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
