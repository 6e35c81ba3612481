"""Forward-dynamics description: a free or pinned rigid base, applied loads, driven joints.

A joint in ``Chain.joints`` is either a prescribed ``JointMotion`` or one of the drives here,
whose angle then follows from the equations of motion (docs/derivation.md, "Forward
dynamics"). Description only: the servo laws are evaluated in ``dynamics/servos.py``.
Everything is SI and radians; the scenario loader converts degrees once.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, get_args

from .chain import JointMotion
from .histories import ZERO, History


@dataclass(frozen=True)
class TorqueDrive:
    """Joint driven by an applied torque history τ(t) (N·m, on link k, reaction on its
    parent). ``motor_inertia`` (kg·m²) is the rotor inertia reflected to the joint."""

    torque: History
    initial_angle: float = 0.0  # rad
    initial_rate: float = 0.0  # rad/s
    motor_inertia: float = 0.0


@dataclass(frozen=True)
class VelocityServo:
    """Velocity-mode servo behind a PID position loop (the paper's AC servo, section 4).

    Command V = sat(P e + I ∫e + D ė) in volts, e = β_ref − β (rad), |V| ≤ saturation;
    commanded rate Ω = rate_per_volt · V; the amplifier's velocity loop applies
    τ = loop_gain (Ω − β̇), limited to ±torque_limit.
    """

    reference: JointMotion
    P: float  # V/rad
    I: float  # V/(rad·s)
    D: float  # V·s/rad
    saturation: float = 10.0  # V
    rate_per_volt: float = 1.0  # rad/s per V
    loop_gain: float = 50.0  # N·m·s/rad
    torque_limit: float = float("inf")  # N·m
    motor_inertia: float = 0.0  # kg·m², reflected to the joint
    integrator: bool = field(init=False, default=True)

    def __post_init__(self) -> None:
        object.__setattr__(self, "integrator", self.I != 0.0)


@dataclass(frozen=True)
class PositionServo:
    """Small RC position servo: commanded rate Ω = clip(bandwidth (β_ref − β), ±rate_limit),
    applied through the same velocity loop τ = loop_gain (Ω − β̇), limited to ±torque_limit."""

    reference: JointMotion
    bandwidth: float  # rad/s
    rate_limit: float  # rad/s
    loop_gain: float = 5.0  # N·m·s/rad
    torque_limit: float = float("inf")  # N·m
    motor_inertia: float = 0.0  # kg·m²
    integrator: bool = field(init=False, default=False)


Drive = TorqueDrive | VelocityServo | PositionServo
Servo = VelocityServo | PositionServo


def is_driven(joint: object) -> bool:
    """True for a drive, False for a prescribed joint motion."""
    return isinstance(joint, TorqueDrive | VelocityServo | PositionServo)


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
