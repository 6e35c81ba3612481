"""Elastic joints (the flexible-joint robot, Spong 1987): a motor rotor coupled to its link
by a torsional spring and damper through a gear (model/joints.py `ElasticJoint`,
docs/elastic_joints.md).

Each elastic joint adds one rigid coordinate, its motor angle θ_m (rad, motor shaft, relative
to the parent), after the base's and the joints' in p = [base, β_1 … β_N, θ_m …]. The
coordinate moves no point of any link (its columns of the kinematical maps are zero); it
carries the rotor's inertia J_m and the motor's drive (prescribed: an input; torque or
servo: a free coordinate, the drive laws of dynamics/servos.py acting on θ_m), and the link
angle β_k is a free coordinate driven by the spring torque

    τ_s = k (θ_m/N − β_k) + c (θ̇_m/N − β̇_k)   on β_k,   −τ_s/N on θ_m.

The first-order (dynamics/forward.py) and nonlinear (dynamics/nonlinear_forward.py) forward
models take these terms through small hooks; `_elastic_numba.py` is the compiled twin.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..model import Chain, ElasticJoint, JointMotion, TorqueDrive, is_driven


class ForwardSystem(Protocol):
    """What these functions read of a `dynamics.forward.ForwardSystem` (which imports this
    module: no import the other way)."""

    chain: Chain
    elastic: list[int]

    def joint_index(self, k: int) -> int: ...

    def motor_index(self, k: int) -> int: ...


def elastic_joints(joints: tuple | list) -> list[int]:
    """Indices of the elastic joints, in the order of their motor coordinates."""
    return [k for k, joint in enumerate(joints) if isinstance(joint, ElasticJoint)]


def driven_motors(joints: tuple | list) -> list[int]:
    """Elastic joints whose motor angle is a free coordinate (torque or servo drive)."""
    return [k for k in elastic_joints(joints) if is_driven(joints[k].motor)]


def start(joint: object) -> tuple[float, float]:
    """A driven coordinate's angle (rad) and rate (rad/s) at t = 0: a torque drive's initial
    values, a servo's reference or a motion; an elastic joint's link starts on its motor
    angle over the gear ratio (the spring relaxed)."""
    if isinstance(joint, ElasticJoint):
        angle, rate = start(joint.motor)
        return angle / joint.gear_ratio, rate / joint.gear_ratio
    if isinstance(joint, TorqueDrive):
        return float(joint.initial_angle), float(joint.initial_rate)
    motion = getattr(joint, "reference", joint)
    angle, rate, _ = motion.evaluate(np.array([0.0]))
    return float(np.ravel(angle)[0]), float(np.ravel(rate)[0])


def prescribed_motors(system: ForwardSystem, t: np.ndarray,
                      out: list[np.ndarray]) -> None:
    """Writes the prescribed motor angles, rates and accelerations at times t into the rigid
    states ``out`` = [p, ṗ, p̈] (nt, n_rigid)."""
    for k in system.elastic:
        motor = system.chain.joints[k].motor
        if not is_driven(motor):
            assert isinstance(motor, JointMotion)
            for arr, v in zip(out, motor.evaluate(t)):
                arr[:, system.motor_index(k)] = np.broadcast_to(v, t.shape)


def spring_torques(system: ForwardSystem, p: np.ndarray, pd: np.ndarray) -> np.ndarray:
    """τ_s (nt, n_elastic), N·m, of each elastic joint at rigid states p, ṗ (nt, n_rigid)."""
    out = np.zeros((p.shape[0], len(system.elastic)))
    for e, k in enumerate(system.elastic):
        joint: ElasticJoint = system.chain.joints[k]
        i, m, n = system.joint_index(k), system.motor_index(k), joint.gear_ratio
        out[:, e] = (joint.stiffness * (p[:, m] / n - p[:, i])
                     + joint.damping * (pd[:, m] / n - pd[:, i]))
    return out


def add_spring_torques(system: ForwardSystem, p: np.ndarray, pd: np.ndarray,
                       Q: np.ndarray) -> None:
    """Adds τ_s on each link angle and −τ_s/N on its motor angle to Q (nt, n_x)."""
    tau = spring_torques(system, p, pd)
    for e, k in enumerate(system.elastic):
        Q[:, system.joint_index(k)] += tau[:, e]
        Q[:, system.motor_index(k)] -= tau[:, e] / system.chain.joints[k].gear_ratio


def add_rotor_inertia(system: ForwardSystem, pdd: np.ndarray, M: np.ndarray,
                      f: np.ndarray) -> None:
    """The rotors' J_m on their motor rows of M (nt, n_x, n_x) and −J_m θ̈_m on f (nt, n_x)."""
    for k in system.elastic:
        m, J = system.motor_index(k), system.chain.joints[k].rotor_inertia
        M[:, m, m] += J
        f[:, m] -= J * pdd[:, m]


def spring_energy(system: ForwardSystem, p: np.ndarray) -> np.ndarray:
    """½ k (θ_m/N − β)² summed over the elastic joints (nt,), J."""
    out = np.zeros(p.shape[0])
    for k in system.elastic:
        joint: ElasticJoint = system.chain.joints[k]
        stretch = p[:, system.motor_index(k)] / joint.gear_ratio - p[:, system.joint_index(k)]
        out += 0.5 * joint.stiffness * stretch**2
    return out


def rotor_energy(system: ForwardSystem, pd: np.ndarray) -> np.ndarray:
    """½ J_m θ̇_m² summed over the elastic joints (nt,), J."""
    out = np.zeros(pd.shape[0])
    for k in system.elastic:
        out += 0.5 * system.chain.joints[k].rotor_inertia * pd[:, system.motor_index(k)]**2
    return out


def spring_frequency(system: ForwardSystem) -> float:
    """The highest frequency (rad/s) an elastic joint's spring sets alone: the rotor on the
    spring, √(k / (N² J_m)), or with a prescribed motor the link (rigid, about its joint)
    on it; 0 without elastic joints. A scale of the fastest motion, as the links' clamped
    frequencies are (the nonlinear step control's floors)."""
    out = 0.0
    for k in system.elastic:
        joint: ElasticJoint = system.chain.joints[k]
        link = system.chain.links[k]
        inertia = (joint.gear_ratio**2 * joint.rotor_inertia if joint.rotor_inertia > 0.0 else
                   link.mass_per_length * link.length**3 / 3 + link.tip_mass * link.length**2
                   + link.tip_inertia)
        out = max(out, float(np.sqrt(joint.stiffness / inertia)) if inertia > 0.0 else 0.0)
    return out
