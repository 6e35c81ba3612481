"""Channel values of a forward run (free or pinned base, driven joints).

Sensors and tips are read as in a prescribed run (channels/first_order.py), about the solved
rigid motion: the expansion is about the actual rigid state, so ρ and θ1 depend on z only.
Base pose, joint quantities and momentum come from the rigid coordinates.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.elastic_joints import spring_torques
from ..dynamics.first_order import LinkBody, link_body, xi_states
from ..dynamics.forward import ForwardSystem
from ..dynamics.kinematics import FrameMotion
from ..dynamics.servos import command_volts
from ..model import PositionServo, VelocityServo
from ..model.joints import drive_side
from .catalogue import BASE_COORDINATES, cart_name, coordinate_name, joint_name


class SolvedMotion:
    """The solved rigid motion seen as a prescribed one (an `ElasticModel` for the readings
    of channels/first_order.py): frames and maps restricted to the elastic coordinates."""

    def __init__(self, system: ForwardSystem, frames: FrameMotion) -> None:
        self.chain = system.chain
        self.modal = system.modal
        self.n = system.n
        self.bodies: list[LinkBody] = [link_body(b.data, b.offset - system.n_rigid)
                                       for b in system.bodies]
        zc = slice(system.n_rigid, system.n_x)
        self.frames = FrameMotion(frames.theta, frames.omega, frames.alpha, frames.origin,
                                  frames.origin_accel, [T[:, :, zc] for T in frames.T],
                                  [T[:, :, zc] for T in frames.T_dot],
                                  [T[:, :, zc] for T in frames.T_ddot])

    def xi_states(self, frames: FrameMotion, k: int, z: np.ndarray, zd: np.ndarray,
                  zdd: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ξ_k, ξ̇_k, ξ̈_k (nt, 3+n_k) from z, ż, z̈."""
        return xi_states(frames, k, self.bodies[k].slice, z, zd, zdd)


def pose_and_joint_values(system: ForwardSystem, t: np.ndarray, p: np.ndarray, pd: np.ndarray,
                          integral: np.ndarray, torque: np.ndarray,
                          momenta: tuple[np.ndarray, np.ndarray] | None
                          ) -> dict[str, np.ndarray]:
    """Base pose and rates, joint angles, rates, torques, servo references and commands,
    and (base not fixed) momentum, by channel name, from the rigid state p, ṗ (nt, n_rigid),
    the servo integrals, the joint torques (nt, N) and (base not fixed) the linear (nt, 2)
    and angular (nt,) momentum of whichever model computed them (``system``: the rigid
    bookkeeping; the first-order model's: `dynamics.forward_outputs`)."""
    out: dict[str, np.ndarray] = {}
    for i, name in enumerate(BASE_COORDINATES[system.base.kind]):
        out[f"base_{name}"] = p[:, i]
        out[f"base_{name}_rate"] = pd[:, i]
    if system.base.cart is not None:  # its force: the model's own equations (the callers)
        out[cart_name("position")], out[cart_name("velocity")] = p[:, 0], pd[:, 0]
    for k, joint in enumerate(system.chain.joints):
        i = system.joint_index(k)
        out[coordinate_name(joint, k, "angle")] = p[:, i]
        out[coordinate_name(joint, k, "rate")] = pd[:, i]
        out[coordinate_name(joint, k, "torque")] = torque[:, k]
        joint, i = drive_side(joint), system.drive_index(k)  # a servo on an elastic motor
        if isinstance(joint, VelocityServo | PositionServo):
            out[joint_name(k, "reference")] = joint.reference.evaluate(t)[0] + 0 * t
        if isinstance(joint, VelocityServo):
            s = system.servos.index(k)
            out[joint_name(k, "command")] = command_volts(joint, t, p[:, i], pd[:, i],
                                                          integral[:, s])
    out.update(elastic_joint_values(system, p, pd))
    if momenta is not None:
        linear, angular = momenta
        out["momentum_x"], out["momentum_y"] = linear[:, 0], linear[:, 1]
        out["angular_momentum"] = angular
    return out


def elastic_joint_values(system: ForwardSystem, p: np.ndarray, pd: np.ndarray
                         ) -> dict[str, np.ndarray]:
    """Motor angle and rate and spring torque of each elastic joint, by channel name."""
    out: dict[str, np.ndarray] = {}
    tau = spring_torques(system, p, pd)
    for e, k in enumerate(system.elastic):
        out[joint_name(k, "motor_angle")] = p[:, system.motor_index(k)]
        out[joint_name(k, "motor_rate")] = pd[:, system.motor_index(k)]
        out[joint_name(k, "spring_torque")] = tau[:, e]
    return out
