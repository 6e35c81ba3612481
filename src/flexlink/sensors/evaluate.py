"""Sensor readings from a solved first-order trajectory (vectorised over output times).

Point quantities use the link's clamped frame: deflection w(x), slope w'(x), surface strain
−(h/2) w''(x) on the +y face. The accelerometer reads the absolute acceleration of the material
point along its deformed normal, to first order (docs/derivation.md, "Sensors"):

    a_n = a0_y + a1_y − a0_x (θ1 + w'(x)),

computed from z̈ of the equations of motion, never by differentiating displacements.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.first_order import FirstOrderSystem
from ..dynamics.kinematics import FrameMotion, rotation
from ..dynamics.torques import joint_torques
from ..model import PiezoSensor, PointSensor, Sensor


@dataclass(frozen=True)
class Channel:
    name: str
    values: np.ndarray
    unit: str
    description: str


@dataclass(frozen=True)
class Trajectory:
    """Elastic coordinates and their first two derivatives at times t, each (nt, n)."""

    t: np.ndarray
    z: np.ndarray
    z_dot: np.ndarray
    z_ddot: np.ndarray


_UNITS = {"deflection": "m", "slope": "rad", "strain": "1", "acceleration": "m/s^2"}


def sensor_channels(
    system: FirstOrderSystem, traj: Trajectory, sensors: tuple[Sensor, ...]
) -> list[Channel]:
    """One channel per sensor, in the given order."""
    frames = system.frames(traj.t)
    return [_read(system, frames, traj, s) for s in sensors]


def joint_and_tip_channels(system: FirstOrderSystem, traj: Trajectory) -> list[Channel]:
    """Joint angles (rad) and motor torques (N·m), global tip positions of every link (m)."""
    frames = system.frames(traj.t)
    hist = system.joint_history(traj.t)
    torque = joint_torques(system, traj.t, traj.z, traj.z_dot, traj.z_ddot)
    out = []
    for k in range(len(system.chain.links)):
        out.append(Channel(f"joint{k + 1}_angle", hist.angle[:, k], "rad",
                           f"prescribed angle of joint {k + 1}"))
    for k in range(len(system.chain.links)):
        out.append(Channel(f"joint{k + 1}_torque", torque[:, k], "N*m",
                           f"motor torque of joint {k + 1} (inverse dynamics, first order)"))
    for k, link in enumerate(system.chain.links):
        tip = _tip_position(system, frames, traj.z, k)
        out.append(Channel(f"{link.name}_tip_X", tip[:, 0], "m", f"X of the tip of {link.name}"))
        out.append(Channel(f"{link.name}_tip_Y", tip[:, 1], "m", f"Y of the tip of {link.name}"))
    return out


def _q(system: FirstOrderSystem, z: np.ndarray, k: int) -> np.ndarray:
    return z[:, system.bodies[k].slice]


def _xi(system: FirstOrderSystem, frames: FrameMotion, z: np.ndarray, k: int) -> np.ndarray:
    """ξ_k = [ρx, ρy, θ1, q_k] at every time, (nt, 3+n_k)."""
    rho = frames.apply(frames.T, k, z)
    return np.concatenate([rho, _q(system, z, k)], axis=1)


def _tip_position(system, frames, z, k) -> np.ndarray:
    d = system.modal[k]
    xi = _xi(system, frames, z, k)
    local = np.stack([d.length + xi[:, 0],
                      xi[:, 1] + d.length * xi[:, 2] + xi[:, 3:] @ d.tip_value], -1)
    return frames.origin[:, k] + np.einsum("tij,tj->ti", rotation(frames.theta[:, k]), local)


def _read(system, frames, traj: Trajectory, sensor: Sensor) -> Channel:
    k = sensor.link
    shapes = system.modal[k].shapes
    q = _q(system, traj.z, k)
    if isinstance(sensor, PiezoSensor):
        x = np.array([sensor.x_start, sensor.x_end])
        slopes = shapes.evaluate(x, 1)
        values = sensor.gain * (q @ (slopes[1] - slopes[0]))
        return Channel(sensor.name, values, "V", "PZT voltage, pin-force model (eq. 37)")
    assert isinstance(sensor, PointSensor)
    x = np.array([sensor.x])
    if sensor.kind == "deflection":
        values = q @ shapes.evaluate(x, 0)[0]
    elif sensor.kind == "slope":
        values = q @ shapes.evaluate(x, 1)[0]
    elif sensor.kind == "strain":
        h = sensor.thickness if sensor.thickness is not None else system.chain.links[k].thickness
        if h is None:
            raise ValueError(f"strain sensor {sensor.name!r} needs a thickness")
        values = -0.5 * h * (q @ shapes.evaluate(x, 2)[0])
    else:
        values = _normal_acceleration(system, frames, traj, k, sensor.x)
    return Channel(sensor.name, values, _UNITS[sensor.kind], f"{sensor.kind} at x = {sensor.x} m")


def _normal_acceleration(system, frames, traj: Trajectory, k: int, x: float) -> np.ndarray:
    xi, xi_d, xi_dd = system.xi_states(frames, k, traj.z, traj.z_dot, traj.z_ddot)
    shapes = system.modal[k].shapes
    phi = shapes.evaluate(np.array([x]), 0)[0]
    dphi = shapes.evaluate(np.array([x]), 1)[0]

    def transverse(v: np.ndarray) -> np.ndarray:
        return v[:, 1] + x * v[:, 2] + v[:, 3:] @ phi

    w, wd = frames.omega[:, k], frames.alpha[:, k]
    ax, ay = frames.origin_accel[:, k, 0], frames.origin_accel[:, k, 1]
    a0x, a0y = ax - w**2 * x, ay + wd * x
    a1y = transverse(xi_dd) + 2 * w * xi_d[:, 0] + wd * xi[:, 0] - w**2 * transverse(xi)
    rotation_angle = xi[:, 2] + xi[:, 3:] @ dphi
    return a0y + a1y - a0x * rotation_angle
