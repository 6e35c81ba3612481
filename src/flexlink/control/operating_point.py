"""Where a plant is linearised: a configuration at rest, or a time of the scenario's run.

``at`` is a time in s (float), a sequence of joint angles in degrees (one per joint), or a
mapping ``{"joint1": deg, "joint2": deg, "base_x": m, "base_y": m, "base_attitude": deg}``
(joints and base coordinates not named keep their t = 0 values). A configuration is a rest
state: rates and accelerations zero, servos holding their reference there, torque drives,
base loads and actuator voltages at zero (the plant's inputs are deviations from that).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..model import (
    Base,
    ElasticJoint,
    JointMotion,
    PrismaticJoint,
    Scenario,
    TorqueDrive,
    is_driven,
)
from ..model.histories import ZERO
from ..model.joints import initial_angle
from ..model.prismatic import guide

At = float | int | Sequence[float] | Mapping[str, float]


@dataclass(frozen=True)
class Constant:
    """A joint held at ``angle`` (rad): a prescribed motion with zero rate."""

    angle: float

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        t = np.asarray(t, dtype=float)
        return np.full(t.shape, self.angle), np.zeros(t.shape), np.zeros(t.shape)


@dataclass(frozen=True)
class Shifted:
    """A motion plus a constant angle (rad) and rate (rad/s): a perturbed servo reference."""

    motion: JointMotion
    angle: float = 0.0
    rate: float = 0.0

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a, r, acc = self.motion.evaluate(t)
        return a + self.angle, r + self.rate, acc


@dataclass(frozen=True)
class Configuration:
    """A rest configuration: joint angles (rad), base x, y (m) and attitude (rad)."""

    angles: tuple[float, ...]
    base: tuple[float, float, float]

    def describe(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": "configuration (rest)"}
        out.update({f"joint{k + 1}_deg": math.degrees(a) for k, a in enumerate(self.angles)})
        out.update(base_x_m=self.base[0], base_y_m=self.base[1],
                   base_attitude_deg=math.degrees(self.base[2]))
        return out

    def describe_at(self) -> dict[str, float]:
        """This configuration as an ``at`` mapping (degrees, metres)."""
        out = {f"joint{k + 1}": math.degrees(a) for k, a in enumerate(self.angles)}
        return out


BASE_KEYS = ("base_x", "base_y", "base_attitude")


class NotLinearizable(ValueError):
    """The scenario has no linearisation about the operating point asked for (a servo
    saturated or a load's kink there, a time of a nonlinear prescribed run); the message
    says why and which operating point to choose instead."""


def parse_at(scenario: Scenario, at: At) -> float | Configuration:
    """A time (s) or a Configuration from ``at``; errors name the offending entry."""
    joints = scenario.chain.joints
    if isinstance(at, bool | str | bytes):  # a text would be read as one angle per character
        raise TypeError("at: give a time in s, joint angles in degrees or a mapping "
                        f"(at=1.2, at=[0, 45], at={{'joint2': 45}}), got {at!r}")
    if isinstance(at, int | float | np.floating | np.integer):
        t = float(at)
        t_end = scenario.settings.t_end
        if not (0.0 <= t <= t_end) or not math.isfinite(t):
            raise ValueError(f"at = {t} s is outside the run [0, {t_end}] s (simulation.t_end)")
        return t
    angles = [initial_angle(j) for j in joints]
    base = scenario.base or Base()
    pose = [base.position[0], base.position[1], base.attitude]
    sliders = [k for k, j in enumerate(joints) if isinstance(j, PrismaticJoint)]
    if isinstance(at, Mapping):
        names = [f"joint{k + 1}" for k in range(len(joints))]
        for key, value in at.items():
            if key in names:
                k = names.index(key)
                angle = math.radians(_number(key, value))
                if k in sliders and not _same(angle, angles[k]):
                    raise ValueError(_slider_held(k))
                angles[k] = angle
            elif key in BASE_KEYS:
                if base.kind in ("fixed", "cart") or (base.kind == "pinned"
                                                      and key != "base_attitude"):
                    raise ValueError(f"at: {key!r} is not a coordinate of a {base.kind} base")
                v = _number(key, value)
                pose[BASE_KEYS.index(key)] = math.radians(v) if key == "base_attitude" else v
            else:
                raise ValueError(f"at: unknown key {key!r}; use {', '.join(names)}"
                                 + (f", {', '.join(BASE_KEYS)}" if base.turns else ""))
    else:
        values = list(at)
        if len(values) != len(joints):
            raise ValueError(f"at: {len(values)} joint angles given, the chain has "
                             f"{len(joints)} joints")
        given = [math.radians(_number(f"joint{k + 1}", v)) for k, v in enumerate(values)]
        for k in sliders:
            if not _same(given[k], angles[k]):
                raise ValueError(_slider_held(k) + f"; give its link's angle there "
                                 f"({math.degrees(angles[k]):g}), or name the other joints "
                                 "(at={'joint1': …})")
        angles = given
    return Configuration(tuple(angles), (pose[0], pose[1], pose[2]))


def _same(a: float, b: float) -> bool:
    return abs(a - b) <= 1e-9 * max(1.0, abs(b))


def _slider_held(k: int) -> str:
    """Why a slider's travel cannot be given in ``at`` (its entry is its link's angle,
    which the configuration keeps: `model.joints.initial_angle`)."""
    return (f"at: joint{k + 1} is a slider (joints[{k}] type = \"prismatic\"): a configuration "
            f"holds its travel where it starts (joints[{k}].initial_position, or its "
            "reference or motion at t = 0); set that in the scenario, or linearise at a time "
            "of the run (at = T s)")


def _number(key: str, value: object) -> float:
    try:
        v = float(value)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        raise ValueError(f"at: {key} = {value!r} is not a number") from None
    if not math.isfinite(v):
        raise ValueError(f"at: {key} = {value!r} is not finite")
    return v


def held_scenario(scenario: Scenario, config: Configuration) -> Scenario:
    """The scenario at rest in ``config``: prescribed joints and servo references constant at
    the configuration's angles, torques, base loads and actuator voltages zero, the base at
    rest in the given pose."""
    joints = [_held_joint(joint, angle) for joint, angle in zip(scenario.chain.joints,
                                                                 config.angles)]
    base = scenario.base
    if base is not None and base.cart is not None:  # at rest where it starts
        start = base.cart.initial_travel()
        drive = base.cart.drive
        held = (replace(drive, torque=ZERO, initial_rate=0.0) if isinstance(drive, TorqueDrive)
                else replace(drive, reference=Constant(start)) if is_driven(drive)  # type: ignore[type-var]
                else Constant(start))
        base = replace(base, loads=(), cart=replace(base.cart, drive=held))
    elif base is not None:
        base = replace(base, loads=(), position=config.base[:2], attitude=config.base[2],
                       velocity=(0.0, 0.0), rate=0.0)
    actuators = tuple(replace(a, voltage=ZERO) for a in scenario.actuators)
    chain = replace(scenario.chain, joints=tuple(joints))
    return replace(scenario, chain=chain, base=base, actuators=actuators)


def _held_joint(joint: Any, angle: float) -> Any:
    """``joint`` at rest at ``angle`` (rad): torque zero, reference or motion constant; an
    elastic joint's motor at N·angle (the spring relaxed)."""
    if isinstance(joint, ElasticJoint):
        return replace(joint, motor=_held_joint(joint.motor, joint.gear_ratio * angle))
    if isinstance(joint, PrismaticJoint):  # a slider: at rest where it starts, its angle fixed
        start = guide(joint).initial_travel()
        drive = joint.drive
        held = (replace(drive, torque=ZERO, initial_rate=0.0) if isinstance(drive, TorqueDrive)
                else replace(drive, reference=Constant(start)) if is_driven(drive)  # type: ignore[type-var]
                else Constant(start))
        return replace(joint, drive=held)
    if isinstance(joint, TorqueDrive):
        return replace(joint, torque=ZERO, initial_angle=angle, initial_rate=0.0)
    if is_driven(joint):
        return replace(joint, reference=Constant(angle))
    return Constant(angle)
