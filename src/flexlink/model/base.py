"""The rigid base a chain hangs on (fixed, pinned or free) and the loads applied to it (SI
units, radians)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

from .histories import ZERO, History

BaseKind = Literal["free", "pinned", "fixed"]
BASE_KINDS: tuple[str, ...] = get_args(BaseKind)
LoadFrame = Literal["inertial", "body"]
LOAD_FRAMES: tuple[str, ...] = get_args(LoadFrame)


@dataclass(frozen=True)
class BaseLoad:
    """Applied force (N) at a point of the base (m, body frame from the reference point),
    components in the body or the inertial frame, and a moment (N·m)."""

    force_x: History = ZERO
    force_y: History = ZERO
    moment: History = ZERO
    point: tuple[float, float] = (0.0, 0.0)
    frame: LoadFrame = "inertial"


@dataclass(frozen=True)
class Base:
    """The rigid body the chain(s) hang on.

    ``free``: moves in the plane (x, y, attitude of its centre of mass, the reference point);
    ``pinned``: turns freely about its reference point, which stays fixed; ``fixed``: does not
    move (today's hub). ``attachments`` maps a link index to the body-frame point (m) where
    that link's joint sits: such a link starts a new branch; link 0 always starts at the base
    (default point (0, 0)), every other link hangs on the tip of the link before it.
    """

    kind: BaseKind = "fixed"
    mass: float = 0.0  # kg
    inertia: float = 0.0  # kg·m², about the reference point
    attachments: tuple[tuple[int, tuple[float, float]], ...] = ()
    loads: tuple[BaseLoad, ...] = ()
    position: tuple[float, float] = (0.0, 0.0)  # m, initial
    attitude: float = 0.0  # rad, initial
    velocity: tuple[float, float] = (0.0, 0.0)  # m/s, initial
    rate: float = 0.0  # rad/s, initial

    def attachment(self, link: int) -> tuple[float, float] | None:
        """Body-frame point of a link that starts a branch, None if it hangs on link − 1."""
        for index, point in self.attachments:
            if index == link:
                return point
        return (0.0, 0.0) if link == 0 else None

    @property
    def coordinates(self) -> tuple[str, ...]:
        """Names of the base's own degrees of freedom."""
        return {"free": ("x", "y", "attitude"), "pinned": ("attitude",), "fixed": ()}[self.kind]
