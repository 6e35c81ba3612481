"""Sensor readings from a solved nonlinear trajectory (docs/nonlinear.md, "Sensors").

Same definitions as the first-order model, evaluated exactly: in link k's clamped frame the
point x sits at (∫₀ˣ cos ψ, ∫₀ˣ sin ψ), ψ = Φ′q_k the section rotation, so

* deflection w(x) = ∫₀ˣ sin ψ ds (transverse coordinate in the clamped frame) [m];
* slope ψ(x) (section rotation relative to the clamped frame; w′ to first order) [rad];
* strain −(h/2) ψ′(x), ψ′ = Φ″q the exact curvature of the inextensible axis [-];
* acceleration n(x)·r̈(x), n the normal of the deformed section [m/s²], from q̈ of the equations;
* PZT gain · [ψ(x_end) − ψ(x_start)] [V].
"""

from __future__ import annotations

import numpy as np

from ..dynamics.kinematics import JointHistory
from ..dynamics.nonlinear import NonlinearSystem
from ..model import PiezoSensor, PointSensor, Sensor
from .evaluate import _UNITS, Channel, Trajectory


def sensor_channels(system: NonlinearSystem, traj: Trajectory, sensors: tuple[Sensor, ...],
                    hist: JointHistory | None = None) -> list[Channel]:
    """One channel per sensor, in the given order (hist: the joints at traj.t, if known)."""
    hist = system.joint_history(traj.t) if hist is None else hist
    return [_read(system, traj, hist, s) for s in sensors]


def joint_and_tip_channels(system: NonlinearSystem, traj: Trajectory,
                           hist: JointHistory | None = None) -> list[Channel]:
    """Joint angles (rad) and motor torques (N·m), global tip positions of every link (m)."""
    hist = system.joint_history(traj.t) if hist is None else hist
    torque = system.joint_torques(traj.t, traj.z, traj.z_dot, traj.z_ddot, hist)
    alpha = system.node_angles(traj.z, hist.angle)
    links = system.chain.links
    out = [Channel(f"joint{k + 1}_angle", hist.angle[:, k], "rad",
                   f"prescribed angle of joint {k + 1}") for k in range(len(links))]
    out += [Channel(f"joint{k + 1}_torque", torque[:, k], "N*m",
                    f"motor torque of joint {k + 1} (inverse dynamics, nonlinear model)")
            for k in range(len(links))]
    for k, link in enumerate(links):
        row = system.position_rows(k, np.array([link.length]))[0]
        out.append(Channel(f"{link.name}_tip_X", np.cos(alpha) @ row, "m",
                           f"X of the tip of {link.name}"))
        out.append(Channel(f"{link.name}_tip_Y", np.sin(alpha) @ row, "m",
                           f"Y of the tip of {link.name}"))
    return out


def _read(system: NonlinearSystem, traj: Trajectory, hist: JointHistory,
          sensor: Sensor) -> Channel:
    k = sensor.link
    arc = system.arcs[k]
    shapes = system.modal[k].shapes
    q = traj.z[:, arc.coords]
    if isinstance(sensor, PiezoSensor):
        slopes = shapes.evaluate(np.array([sensor.x_start, sensor.x_end]), 1)
        values = sensor.gain * (q @ (slopes[1] - slopes[0]))
        return Channel(sensor.name, values, "V", "PZT voltage, pin-force model (eq. 37)")
    assert isinstance(sensor, PointSensor)
    x = np.array([sensor.x])
    if sensor.kind == "deflection":
        values = np.sin(q @ arc.dphi.T) @ arc.quad.cumulative(x)[0]
    elif sensor.kind == "slope":
        values = q @ shapes.evaluate(x, 1)[0]
    elif sensor.kind == "strain":
        h = sensor.thickness if sensor.thickness is not None else system.chain.links[k].thickness
        if h is None:
            raise ValueError(f"strain sensor {sensor.name!r} needs a thickness")
        values = -0.5 * h * (q @ shapes.evaluate(x, 2)[0])
    else:
        values = normal_acceleration(system, traj, hist, k, sensor.x)
    return Channel(sensor.name, values, _UNITS[sensor.kind], f"{sensor.kind} at x = {sensor.x} m")


def normal_acceleration(system: NonlinearSystem, traj: Trajectory, hist: JointHistory, k: int,
                        x: float) -> np.ndarray:
    """n(x)·r̈(x) = Σ_l W_l [cos(α_x − α_l) α̈_l + sin(α_x − α_l) α̇_l²] (m/s²)."""
    alpha = system.node_angles(traj.z, hist.angle)
    alpha_dot = system.node_angles(traj.z_dot, hist.rate)
    alpha_ddot = system.node_angles(traj.z_ddot, hist.acceleration)
    row = system.position_rows(k, np.array([x]))[0]
    arc = system.arcs[k]
    a_x = np.zeros(system.n)
    a_x[:] = system.root_A[k]
    a_x[arc.coords] = system.modal[k].shapes.evaluate(np.array([x]), 1)[0]
    angle_x = traj.z @ a_x + hist.angle[:, : k + 1].sum(axis=1)
    diff = angle_x[:, None] - alpha
    return (np.cos(diff) * alpha_ddot + np.sin(diff) * alpha_dot**2) @ row
