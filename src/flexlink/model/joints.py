"""Joints: a prescribed motion β(t), or a drive whose angle follows from the equations of
motion (forward dynamics, docs/derivation.md): a torque history or a servo loop.

Description only: motions are evaluated in ``motion/``, the servo laws in
``dynamics/servos.py``. Everything is SI and radians; the scenario loader converts degrees once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import numpy as np

from .histories import History


@runtime_checkable
class JointMotion(Protocol):
    """A prescribed joint angle history β(t)."""

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Angle (rad), rate (rad/s) and acceleration (rad/s²) at times t (s)."""
        ...


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


@dataclass(frozen=True)
class ElasticJoint:
    """A joint whose link is driven through a torsional spring and damper by a motor rotor
    (the flexible-joint robot, Spong 1987; docs/elastic_joints.md).

    ``motor`` drives the motor angle θ_m (rad, motor shaft, relative to the parent link): a
    prescribed motion, a `TorqueDrive` or a servo, whose angles, rates, references and
    torques are the motor shaft's and whose ``motor_inertia`` is the rotor's inertia J_m about
    its axis (kg·m², not reflected). Through a gear of ratio N (motor turns per link turn,
    N ≠ 0) the spring torque on the link is

        τ_s = k (θ_m/N − β) + c (θ̇_m/N − β̇)     (N·m; reaction −τ_s on the parent),

    and the motor feels −τ_s/N: J_m θ̈_m = τ_m − τ_s/N. The rotor's kinetic energy is
    ½ J_m θ̇_m² (Spong's assumption: the rotor's share of the parent's rotation is neglected).
    At t = 0 the spring is relaxed: β = θ_m/N, β̇ = θ̇_m/N."""

    motor: JointMotion | TorqueDrive | VelocityServo | PositionServo
    stiffness: float  # N·m/rad, k > 0
    damping: float = 0.0  # N·m·s/rad, c ≥ 0
    gear_ratio: float = 1.0  # N, motor turns per link turn

    @property
    def motor_inertia(self) -> float:
        """The link side carries no rotor (the rotor is the motor coordinate's): 0."""
        return 0.0

    @property
    def rotor_inertia(self) -> float:
        """J_m (kg·m²): the motor drive's inertia; 0 for a prescribed motor angle."""
        return float(getattr(self.motor, "motor_inertia", 0.0))

    @property
    def integrator(self) -> bool:
        """Whether the motor's servo has an integral state."""
        return bool(getattr(self.motor, "integrator", False))


@dataclass(frozen=True)
class PrismaticJoint:
    """A slider inside a chain (docs/prismatic_joints.md): link k rides on a block that
    slides along a straight line fixed in link k − 1's section at ``at`` (m from link k − 1's
    joint along its undeformed axis; None: its tip), carried with that section's deflection
    and slope. Its coordinate is the travel s (m) of the block from that point along the
    line, which points at ``axis_angle`` (rad) from the parent's section; link k is fixed to
    the block at ``link_angle`` (rad) from the parent's section.

    ``drive`` moves s as a cart's drive moves its travel (`base.Cart`): a prescribed travel
    (a ``JointMotion`` in metres: `motion.Travel`), a force along the line (``TorqueDrive``:
    its history in N, its initial angle and rate the initial travel (m) and speed (m/s)), or
    a servo on the travel (no integral state); a free slider is a force drive with zero
    force. ``mass`` (kg): the block, a point mass at link k's root. ``travel``: the allowed
    range of s (m), never clipped: a start, prescribed travel or servo reference outside it
    is refused at load, a run that leaves it ends with an error."""

    drive: object  # JointMotion | TorqueDrive | VelocityServo | PositionServo, in metres
    axis_angle: float = 0.0  # rad, the line's direction from the parent's section
    link_angle: float = 0.0  # rad, link k's direction from the parent's section
    travel: tuple[float, float] = (-float("inf"), float("inf"))  # m
    mass: float = 0.0  # kg, the block
    at: float | None = None  # m from the parent's joint, the line's point; None: its tip

    def __post_init__(self) -> None:
        if self.at is not None and not (math.isfinite(self.at) and self.at >= 0.0):
            raise ValueError(f"prismatic joint at: need a point ≥ 0 m on the parent link, "
                             f"got {self.at:g}")
        if not self.travel[0] < self.travel[1]:
            raise ValueError(f"prismatic joint travel: need lower < upper, got {self.travel}")
        if self.mass < 0.0:
            raise ValueError(f"prismatic joint mass: need ≥ 0 kg, got {self.mass:g}")
        if getattr(self.drive, "integrator", False):
            raise ValueError("a slider's servo has no integral state: its I gain must be 0")
        if getattr(self.drive, "motor_inertia", 0.0) != 0.0:
            raise ValueError("a slider's drive has no motor inertia (give the block's mass)")

    @property
    def motor_inertia(self) -> float:
        """The block's mass is a body on the carried link, not an inertia on the row: 0."""
        return 0.0

    @property
    def integrator(self) -> bool:
        return False

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """A prescribed slider's travel (m), speed (m/s), acceleration (m/s²) at times t."""
        return self.drive.evaluate(t)  # type: ignore[attr-defined]

    @property
    def breakpoints(self) -> tuple[float, ...]:
        return tuple(getattr(self.drive, "breakpoints", ()))

    @property
    def direction(self) -> tuple[float, float]:
        """Unit vector of the line in the axes of the parent's section at ``at``."""
        return (math.cos(self.axis_angle), math.sin(self.axis_angle))


def drive_side(joint: object) -> object:
    """What drives a joint's coordinate: an elastic joint's motor, a slider's drive, else the
    joint itself."""
    if isinstance(joint, PrismaticJoint):
        return joint.drive
    return joint.motor if isinstance(joint, ElasticJoint) else joint


def is_driven(joint: object) -> bool:
    """True for a drive or an elastic joint (the link angle follows from the dynamics), or a
    slider whose drive is one; False for a prescribed joint motion or travel."""
    if isinstance(joint, PrismaticJoint):
        return is_driven(joint.drive)
    return isinstance(joint, TorqueDrive | VelocityServo | PositionServo | ElasticJoint)


def initial_angle(joint: object) -> float:
    """A joint's angle at t = 0 (rad): its motion's, a torque drive's initial angle, a servo's
    reference; an elastic joint's motor angle over the gear ratio (the spring relaxed)."""
    if isinstance(joint, ElasticJoint):
        return initial_angle(joint.motor) / joint.gear_ratio
    if isinstance(joint, PrismaticJoint):  # the carried link's angle; its travel is not one
        return joint.link_angle
    if isinstance(joint, TorqueDrive):
        return float(joint.initial_angle)
    motion = getattr(joint, "reference", joint)
    return float(np.ravel(motion.evaluate(np.array([0.0]))[0])[0])


# A joint is prescribed (its motion is given) or driven (its angle follows from the dynamics).
Joint = JointMotion | Drive | ElasticJoint | PrismaticJoint
