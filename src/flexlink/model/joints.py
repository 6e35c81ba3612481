"""Joints: a prescribed motion β(t), or a drive whose angle follows from the equations of
motion (forward dynamics, docs/derivation.md): a torque history or a servo loop.

Description only: motions are evaluated in ``motion/``, the servo laws in
``dynamics/servos.py``. Everything is SI and radians; the scenario loader converts degrees once.
"""

from __future__ import annotations

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


def is_driven(joint: object) -> bool:
    """True for a drive, False for a prescribed joint motion."""
    return isinstance(joint, TorqueDrive | VelocityServo | PositionServo)


def initial_angle(joint: object) -> float:
    """A joint's angle at t = 0 (rad): its motion's, a torque drive's initial angle, a servo's
    reference."""
    if isinstance(joint, TorqueDrive):
        return float(joint.initial_angle)
    motion = getattr(joint, "reference", joint)
    return float(np.ravel(motion.evaluate(np.array([0.0]))[0])[0])


# A joint is prescribed (its motion is given) or driven (its angle follows from the dynamics).
Joint = JointMotion | Drive
