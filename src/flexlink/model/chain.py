"""Links and the chain they form with their joints (SI units, radians).

Objects are frozen: algorithms take a model and never mutate it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

from .joints import Joint

ModeShapes = Literal["auto", "clamped_free", "tip_loaded", "outboard_loaded", "hub_loaded",
                     "pinned_pinned"]
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

    @property
    def rigid(self) -> bool:
        """Whether the link has no assumed modes (it does not bend)."""
        return self.modes == 0

    @property
    def mass(self) -> float:
        """Beam mass plus tip mass, kg."""
        return self.mass_per_length * self.length + self.tip_mass


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
