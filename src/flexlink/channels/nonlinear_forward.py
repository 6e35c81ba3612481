"""Channel values of a nonlinear forward run (dynamics/nonlinear_forward.py): sensors, tips
and shapes read exactly as in a prescribed nonlinear run (channels/nonlinear.py, through an
`ArcMotion` with the solved base and joints), base pose, joints and momentum as in a
first-order forward run (channels/forward.py), with this model's torques and momentum."""

from __future__ import annotations

import numpy as np

from ..dynamics.nonlinear_forward import NonlinearForwardSystem, StageInputs
from ..model import Sensor
from .catalogue import cart_name
from .forward import pose_and_joint_values
from .nonlinear import ArcMotion, motion_sensor_values, motion_shapes, motion_tip_values
from .shapes import POINTS, LinkShape


def forward_motion(system: NonlinearForwardSystem, t: np.ndarray, y: np.ndarray,
                   v: np.ndarray, a: np.ndarray, inp: StageInputs | None = None) -> ArcMotion:
    """The ArcMotion of the solved y, ẏ, ÿ (nt, n_y) at times t (s) (``inp``: the system's
    stage_inputs(t) if known)."""
    inp = system.stage_inputs(t) if inp is None else inp
    alpha, alpha_d, alpha_dd, R, _, Rdd = system.node_motion(t, y, v, a, inp)
    p, _, _ = system.rigid_state(t, y, v, a)
    q = y[:, :system.n]
    lengths = system.line_weights(y, v, a, inp) if system.slides else None
    return ArcMotion(alpha, alpha_d, alpha_dd, R, Rdd,
                     q @ system.root_A.T + p @ system.root_B.T + system.root_offset
                     + system.link_offset, q, lengths)


def forward_values(system: NonlinearForwardSystem, t: np.ndarray, y: np.ndarray, v: np.ndarray,
                   a: np.ndarray, sensors: tuple[Sensor, ...],
                   constraint_torques: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Every channel of a forward scenario by name: sensors, base pose and rates, joint
    angles, rates, torques, servo references and commands, momentum (base not fixed), tips.
    ``constraint_torques`` (nt, N; N·m): closed loops' constraint forces on each joint, left
    out of its motor torque."""
    inp = system.stage_inputs(t)
    motion = forward_motion(system, t, y, v, a, inp)
    values = motion_sensor_values(system, motion, sensors)
    p, pd, _ = system.rigid_state(t, y, v, a)
    moving = system.base.kind != "fixed"
    momenta = system.momentum(t, y, v, inp) if moving else None
    torques = system.joint_torques(t, y, v, a, inp=inp)
    if constraint_torques is not None:
        torques = torques - constraint_torques
    values.update(pose_and_joint_values(system.loads, t, p, pd, v[:, system.n + system.nu:],
                                        torques, momenta))
    if system.rail is not None:
        values[cart_name("force")] = system.cart_force(t, y, v, a, inp)
    values.update(motion_tip_values(system, motion))
    return values


def forward_shapes(system: NonlinearForwardSystem, t: np.ndarray, y: np.ndarray,
                   points: int = POINTS) -> list[LinkShape]:
    """Every link's deformed shape (exact) and its rigid frame (straight links at the solved
    base pose and joint angles)."""
    zero = np.zeros_like(y)
    origins, theta = system.root_frames(t, y)
    return motion_shapes(system, forward_motion(system, t, y, zero, zero), origins, theta,
                         points)
