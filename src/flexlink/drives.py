"""Forward-dynamics inputs: a free or pinned rigid base, applied load histories, driven joints.

A joint in ``Chain.joints`` is either a prescribed ``JointMotion`` or one of the drives here,
whose angle then follows from the equations of motion (docs/derivation.md, "Forward
dynamics"). Everything is SI and radians; the scenario loader converts degrees once.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal, Protocol, runtime_checkable

import numpy as np

from .model import JointMotion


@runtime_checkable
class History(Protocol):
    """A scalar input history u(t) (N, N·m, …) evaluated at times t (s)."""

    def value(self, t: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class Table:
    """Samples (t_i, u_i), linearly interpolated, held constant outside [t_0, t_last]."""

    t: tuple[float, ...]
    u: tuple[float, ...]

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        if t.ndim != 1 or t.size < 2 or len(self.u) != t.size:
            raise ValueError("a table needs at least two samples and as many values as times")
        if not np.all(np.diff(t) > 0) or not np.all(np.isfinite(self.u)):
            raise ValueError("table times must increase strictly and values must be finite")

    def value(self, t: np.ndarray) -> np.ndarray:
        return np.interp(np.asarray(t, dtype=float), self.t, self.u)


@dataclass(frozen=True)
class BangBang:
    """+amplitude on [start, start + duration/2), −amplitude on [start + duration/2,
    start + duration), zero elsewhere: a rest-to-rest slew of a rigid body."""

    amplitude: float
    start: float
    duration: float

    def value(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        half = self.start + 0.5 * self.duration
        out = np.where((t >= self.start) & (t < half), self.amplitude, 0.0)
        return np.where((t >= half) & (t < self.start + self.duration), -self.amplitude, out)


@dataclass(frozen=True)
class Step:
    """``amplitude`` on [start, start + duration), zero elsewhere (duration may be inf)."""

    amplitude: float
    start: float = 0.0
    duration: float = float("inf")

    def value(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return np.where((t >= self.start) & (t < self.start + self.duration), self.amplitude, 0.0)


@dataclass(frozen=True)
class Sum:
    """The sum of several histories (a list of segments in a scenario file)."""

    parts: tuple[History, ...]

    def value(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        return sum((p.value(t) for p in self.parts), np.zeros_like(t))


ZERO = Sum(())


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
    return isinstance(joint, TorqueDrive | VelocityServo | PositionServo)


def servo_torque(servo: Servo, t: np.ndarray, angle: np.ndarray, rate: np.ndarray,
                 integral: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Motor torque (N·m) and the rate of the integral state (rad) of a servo at times t (s),
    joint angle (rad), rate (rad/s) and integral of the error (rad·s), all of one shape."""
    ref, ref_rate, _ = servo.reference.evaluate(np.asarray(t, dtype=float))
    error = ref - angle
    if isinstance(servo, VelocityServo):
        raw = servo.P * error + servo.I * integral + servo.D * (ref_rate - rate)
        volts = np.clip(raw, -servo.saturation, servo.saturation)
        command = servo.rate_per_volt * volts
        # Conditional integration: no wind-up while the command is saturated.
        integral_rate = np.where((volts == raw) & servo.integrator, error, 0.0)
    else:
        command = np.clip(servo.bandwidth * error, -servo.rate_limit, servo.rate_limit)
        integral_rate = np.zeros_like(error)
    torque = np.clip(servo.loop_gain * (command - rate), -servo.torque_limit, servo.torque_limit)
    return torque, integral_rate


def command_volts(servo: VelocityServo, t: np.ndarray, angle: np.ndarray, rate: np.ndarray,
                  integral: np.ndarray) -> np.ndarray:
    """The PID's saturated command (V) of a velocity servo."""
    ref, ref_rate, _ = servo.reference.evaluate(np.asarray(t, dtype=float))
    raw = servo.P * (ref - angle) + servo.I * integral + servo.D * (ref_rate - rate)
    return np.clip(raw, -servo.saturation, servo.saturation)


BaseKind = Literal["free", "pinned", "fixed"]


@dataclass(frozen=True)
class BaseLoad:
    """Applied force (N) at a point of the base (m, body frame from the reference point),
    components in the body or the inertial frame, and a moment (N·m)."""

    force_x: History = ZERO
    force_y: History = ZERO
    moment: History = ZERO
    point: tuple[float, float] = (0.0, 0.0)
    frame: Literal["body", "inertial"] = "inertial"


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
