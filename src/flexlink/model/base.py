"""The rigid base a chain hangs on (fixed, pinned, free, or a cart on a straight rail) and the
loads applied to it (SI units, radians)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal, get_args

import numpy as np

from .histories import ZERO, History
from .joints import Joint, TorqueDrive, initial_angle, is_driven

BaseKind = Literal["free", "pinned", "fixed", "cart"]
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
    move (today's hub); ``cart``: slides along a straight rail fixed in the ground, its one
    coordinate s (m) the travel of its reference point from ``position`` along the direction
    ``rail_angle`` (rad from global X), its attitude constant; ``cart_drive`` says how s moves
    (`Cart`). ``attachments`` maps a link index to the body-frame point (m) where
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
    cart: Cart | None = None  # the rail and drive of a ``cart`` base

    def __post_init__(self) -> None:
        if (self.kind == "cart") != (self.cart is not None):
            raise ValueError("base: kind = \"cart\" needs a Cart (rail and drive), and only a "
                             "cart base takes one")
        if self.kind == "cart" and (self.rate != 0.0 or self.velocity != (0.0, 0.0)):
            raise ValueError("base: a cart's velocity is its Cart's (initial rate along the "
                             "rail); velocity and rate must be zero")

    def attachment(self, link: int) -> tuple[float, float] | None:
        """Body-frame point of a link that starts a branch, None if it hangs on link − 1."""
        for index, point in self.attachments:
            if index == link:
                return point
        return (0.0, 0.0) if link == 0 else None

    @property
    def coordinates(self) -> tuple[str, ...]:
        """Names of the base's own degrees of freedom."""
        return {"free": ("x", "y", "attitude"), "pinned": ("attitude",), "fixed": (),
                "cart": ("s",)}[self.kind]

    @property
    def turns(self) -> bool:
        """Whether the base's attitude is one of its coordinates (free and pinned bases)."""
        return self.kind in ("free", "pinned")


@dataclass(frozen=True)
class Cart:
    """The rail of a cart base and what moves the cart along it.

    ``drive``: a prescribed travel s(t) (a ``JointMotion`` in metres), a force along the rail
    (``TorqueDrive``: its history in N, its initial angle and rate the initial travel (m) and
    speed (m/s), ``motor_inertia`` must be 0: the cart's mass is the base's), or a servo on the
    travel (its reference in metres, rate limit in m/s, loop gain in N·s/m, torque limit the
    force limit in N). A free cart is a force drive with zero force. ``travel``: the allowed
    range of s (m); a prescribed travel or a servo reference outside it is refused, a run that
    leaves it ends with an error.
    """

    drive: Joint = field(default_factory=lambda: TorqueDrive(ZERO))
    rail_angle: float = 0.0  # rad, direction of the rail from global X
    travel: tuple[float, float] = (-math.inf, math.inf)  # m, allowed range of s

    def __post_init__(self) -> None:
        lo, hi = self.travel
        if not lo < hi:
            raise ValueError(f"base.travel: need lower < upper, got [{lo:g}, {hi:g}] m")
        if is_driven(self.drive) and self.drive.motor_inertia != 0.0:  # type: ignore[union-attr]
            raise ValueError("base: a cart's drive has no motor inertia (give the cart's "
                             "mass as the base's mass)")

    @property
    def direction(self) -> tuple[float, float]:
        """Unit vector along the rail, global axes."""
        return (math.cos(self.rail_angle), math.sin(self.rail_angle))

    @property
    def prescribed(self) -> bool:
        """Whether the travel s(t) is given (not a coordinate the equations solve)."""
        return not is_driven(self.drive)

    def initial_travel(self) -> float:
        """s at t = 0 (m)."""
        return initial_angle(self.drive)

    def first_exit(self, t: np.ndarray, s: np.ndarray) -> tuple[float, float] | None:
        """The first (time s, travel m) of the samples t, s outside the allowed travel, or
        None if every sample is inside."""
        out = np.flatnonzero((s < self.travel[0]) | (s > self.travel[1]))
        return None if out.size == 0 else (float(t[out[0]]), float(s[out[0]]))

    def check_travel(self, t_end: float) -> None:
        """Refuse a start outside the travel, and a prescribed travel or a servo's reference
        that leaves it in [0, t_end] (s): a ValueError naming the field, the time and the
        travel."""
        lo, hi = self.travel
        if not lo <= self.initial_travel() <= hi:
            raise ValueError(f"base: the cart starts at s = {self.initial_travel():g} m, outside "
                             f"its travel [{lo:g}, {hi:g}] m (base.travel)")
        motion = self.drive if self.prescribed else getattr(self.drive, "reference", None)
        if motion is None:  # a force drive: only its run can tell
            return
        field, what = (("motion", "prescribed cart travel") if self.prescribed
                       else ("reference", "cart servo's reference"))
        # Dense samples and every breakpoint: the profiles' extremes are at their ends.
        breaks = [b for b in getattr(motion, "breakpoints", ()) if 0.0 <= b <= t_end]
        t = np.union1d(np.linspace(0.0, t_end, 4001), breaks)
        s = np.ravel(motion.evaluate(t)[0]) + 0 * t
        exit_ = self.first_exit(t, s)
        if exit_ is not None:
            far = s.max() if s.max() > hi else s.min()
            raise ValueError(f"base.{field}: the {what} leaves its travel "
                             f"[{lo:g}, {hi:g}] m (base.travel) at t = {exit_[0]:g} s and "
                             f"reaches s = {far:g} m")
