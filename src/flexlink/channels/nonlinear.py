"""Channel values of the nonlinear model from a solved run (docs/nonlinear.md, "Sensors").

Same definitions as the first-order model, evaluated exactly: in link k's clamped frame the
point x sits at (∫₀ˣ cos ψ, ∫₀ˣ sin ψ), ψ = Φ′q_k the section rotation, so

* deflection w(x) = ∫₀ˣ sin ψ ds (transverse coordinate in the clamped frame) [m];
* slope, strain and PZT as in channels/modal.py (linear in q in both models);
* acceleration n(x)·r̈(x), n the normal of the deformed section [m/s²], from q̈ of the equations.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.kinematics import JointHistory
from ..dynamics.nonlinear import NonlinearSystem
from ..model import PointSensor, Sensor
from ..solvers import Solution
from .catalogue import tip_name
from .modal import modal_reading
from .shapes import POINTS, LinkShape, fractions, rigid_chain_frames


def sensor_values(system: NonlinearSystem, solution: Solution, sensors: tuple[Sensor, ...],
                  hist: JointHistory) -> dict[str, np.ndarray]:
    """Each sensor's reading at the solution's times (hist: the joints there), by name."""
    return {s.name: _read(system, solution, hist, s) for s in sensors}


def tip_values(system: NonlinearSystem, solution: Solution,
               hist: JointHistory) -> dict[str, np.ndarray]:
    """Global X and Y (m) of every link's deformed tip, by channel name."""
    alpha = system.node_angles(solution.q, hist.angle)
    out = {}
    for k, link in enumerate(system.chain.links):
        row = system.position_rows(k, np.array([link.length]))[0]
        out[tip_name(link.name, "X")] = np.cos(alpha) @ row
        out[tip_name(link.name, "Y")] = np.sin(alpha) @ row
    return out


def shape_values(system: NonlinearSystem, solution: Solution, hist: JointHistory,
                 points: int = POINTS) -> list[LinkShape]:
    """Every link's deformed shape on `points` evenly spaced points (exact positions), and its
    rigid frame (the chain at the joint angles with straight links)."""
    alpha = system.node_angles(solution.q, hist.angle)
    c, s = np.cos(alpha), np.sin(alpha)
    links = system.chain.links
    origins, theta = rigid_chain_frames([link.length for link in links], hist.angle)
    out = []
    for k, link in enumerate(links):
        fraction = fractions(points)
        rows = system.position_rows(k, fraction * link.length)
        out.append(LinkShape(link.name, link.length, fraction, c @ rows.T, s @ rows.T,
                             origins[:, k], theta[:, k]))
    return out


def _read(system: NonlinearSystem, solution: Solution, hist: JointHistory,
          sensor: Sensor) -> np.ndarray:
    k = sensor.link
    arc = system.arcs[k]
    q = solution.q[:, arc.coords]
    reading = modal_reading(sensor, system.modal[k].shapes, q, system.chain)
    if reading is not None:
        return reading
    assert isinstance(sensor, PointSensor)
    if sensor.kind == "deflection":
        return np.sin(q @ arc.dphi.T) @ arc.quad.cumulative(np.array([sensor.x]))[0]
    return normal_acceleration(system, solution, hist, k, sensor.x)


def normal_acceleration(system: NonlinearSystem, solution: Solution, hist: JointHistory, k: int,
                        x: float) -> np.ndarray:
    """n(x)·r̈(x) = Σ_l W_l [cos(α_x − α_l) α̈_l + sin(α_x − α_l) α̇_l²] (m/s²)."""
    alpha = system.node_angles(solution.q, hist.angle)
    alpha_dot = system.node_angles(solution.q_dot, hist.rate)
    alpha_ddot = system.node_angles(solution.q_ddot, hist.acceleration)
    row = system.position_rows(k, np.array([x]))[0]
    arc = system.arcs[k]
    a_x = np.zeros(system.n)
    a_x[:] = system.root_A[k]
    a_x[arc.coords] = system.modal[k].shapes.evaluate(np.array([x]), 1)[0]
    angle_x = solution.q @ a_x + hist.angle[:, : k + 1].sum(axis=1)
    diff = angle_x[:, None] - alpha
    return (np.cos(diff) * alpha_ddot + np.sin(diff) * alpha_dot**2) @ row
