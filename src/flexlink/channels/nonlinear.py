"""Channel values of the nonlinear model from a solved run (docs/nonlinear.md, "Sensors").

Same definitions as the first-order model, evaluated exactly: in link k's clamped frame the
point x sits at (∫₀ˣ cos ψ, ∫₀ˣ sin ψ), ψ = Φ′q_k the section rotation, so

* deflection w(x) = ∫₀ˣ sin ψ ds (transverse coordinate in the clamped frame) [m];
* slope, strain and PZT as in channels/modal.py (linear in q in both models);
* acceleration n(x)·r̈(x), n the normal of the deformed section [m/s²], from q̈ of the equations.

Both nonlinear paths (prescribed joints, dynamics/nonlinear.py; forward,
dynamics/nonlinear_forward.py) read through an `ArcMotion`: the node angles and their rates,
the base's reference point R_b (fixed at the origin unless the base is free) and every link's
clamped-frame angle. Positions are r(x) = R_b + Σ_j W_j(x) e(α_j) in both.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..dynamics.kinematics import JointHistory
from ..dynamics.nonlinear import NonlinearSystem
from ..model import PointSensor, Sensor
from ..solvers import Solution
from .catalogue import tip_name
from .modal import modal_reading
from .shapes import POINTS, LinkShape, fractions, rigid_chain_frames


@dataclass(frozen=True)
class ArcMotion:
    """The solved motion on a nonlinear system's node axis: α, α̇, α̈ (nt, nodes) in rad,
    rad/s, rad/s²; the base's reference point R_b and R̈_b (nt, 2) in m, m/s²; each link's
    clamped-frame (root section) angle (nt, N), rad; the elastic coordinates q (nt, n);
    ``lengths``: each node's length ρ, ρ̇, ρ̈ (nt, nodes) where a slider's line makes it the
    travel (positions Σ_j W_j ρ_j e(α_j)); None: every ρ = 1."""

    alpha: np.ndarray
    alpha_dot: np.ndarray
    alpha_ddot: np.ndarray
    origin: np.ndarray
    origin_ddot: np.ndarray
    root_angle: np.ndarray
    q: np.ndarray
    lengths: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None

    def directions(self) -> tuple[np.ndarray, np.ndarray]:
        """ρ cos α and ρ sin α (nt, nodes): positions are their products with W rows."""
        c, s = np.cos(self.alpha), np.sin(self.alpha)
        if self.lengths is None:
            return c, s
        return self.lengths[0] * c, self.lengths[0] * s


def prescribed_motion(system: NonlinearSystem, solution: Solution,
                      hist: JointHistory) -> ArcMotion:
    """The ArcMotion of a prescribed-joint run (fixed hub at the origin)."""
    zero = np.zeros((solution.t.size, 2))
    return ArcMotion(system.node_angles(solution.q, hist.angle),
                     system.node_rates(solution.q_dot, hist.rate),
                     system.node_rates(solution.q_ddot, hist.acceleration), zero, zero,
                     solution.q @ system.root_A.T + np.cumsum(hist.angle, axis=1), solution.q)


def sensor_values(system: NonlinearSystem, solution: Solution, sensors: tuple[Sensor, ...],
                  hist: JointHistory) -> dict[str, np.ndarray]:
    """Each sensor's reading at the solution's times (hist: the joints there), by name."""
    return motion_sensor_values(system, prescribed_motion(system, solution, hist), sensors)


def tip_values(system: NonlinearSystem, solution: Solution,
               hist: JointHistory) -> dict[str, np.ndarray]:
    """Global X and Y (m) of every link's deformed tip, by channel name."""
    return motion_tip_values(system, prescribed_motion(system, solution, hist))


def shape_values(system: NonlinearSystem, solution: Solution, hist: JointHistory,
                 points: int = POINTS) -> list[LinkShape]:
    """Every link's deformed shape on `points` evenly spaced points (exact positions), and its
    rigid frame (the chain at the joint angles with straight links)."""
    origins, theta = rigid_chain_frames([link.length for link in system.chain.links],
                                        hist.angle)
    return motion_shapes(system, prescribed_motion(system, solution, hist), origins, theta,
                         points)


# -- readings of an ArcMotion (system: NonlinearSystem or NonlinearForwardSystem) ------------
def motion_sensor_values(system: Any, motion: ArcMotion,
                         sensors: tuple[Sensor, ...]) -> dict[str, np.ndarray]:
    """Each sensor's reading, by name."""
    return {s.name: _read(system, motion, s) for s in sensors}


def motion_tip_values(system: Any, motion: ArcMotion) -> dict[str, np.ndarray]:
    """Global X and Y (m) of every link's deformed tip, by channel name."""
    out = {}
    c, s = motion.directions()
    for k, link in enumerate(system.chain.links):
        row = system.position_rows(k, np.array([link.length]))[0]
        out[tip_name(link.name, "X")] = motion.origin[:, 0] + c @ row
        out[tip_name(link.name, "Y")] = motion.origin[:, 1] + s @ row
    return out


def motion_shapes(system: Any, motion: ArcMotion, origins: np.ndarray, theta: np.ndarray,
                  points: int = POINTS) -> list[LinkShape]:
    """Every link's deformed shape (exact positions) with the given rigid frames: origins
    (nt, N, 2), m, angles (nt, N), rad."""
    c, s = motion.directions()
    out = []
    for k, link in enumerate(system.chain.links):
        fraction = fractions(points)
        rows = system.position_rows(k, fraction * link.length)
        out.append(LinkShape(link.name, link.length, fraction,
                             motion.origin[:, :1] + c @ rows.T,
                             motion.origin[:, 1:] + s @ rows.T, origins[:, k], theta[:, k]))
    return out


def _read(system: Any, motion: ArcMotion, sensor: Sensor) -> np.ndarray:
    k = sensor.link
    arc = system.arcs[k]
    q = motion.q[:, arc.coords]
    reading = modal_reading(sensor, system.modal[k].shapes, q, system.chain)
    if reading is not None:
        return reading
    assert isinstance(sensor, PointSensor)
    if sensor.kind == "deflection":
        return np.sin(q @ arc.dphi.T) @ arc.quad.cumulative(np.array([sensor.x]))[0]
    return normal_acceleration(system, motion, k, sensor.x)


def normal_acceleration(system: Any, motion: ArcMotion, k: int, x: float) -> np.ndarray:
    """n(x)·(r̈(x) − g) = n·(R̈_b − g) + Σ_l W_l [cos(α_x − α_l) α̈_l + sin(α_x − α_l) α̇_l²]
    (m/s²): the specific force an accelerometer reads (its proof mass feels no gravity); a
    slider's line node l adds its length's terms, n·[ρ(α̈ e⊥ − α̇² e) + 2ρ̇α̇ e⊥ + ρ̈ e]."""
    row = system.position_rows(k, np.array([x]))[0]
    arc = system.arcs[k]
    slope = system.modal[k].shapes.evaluate(np.array([x]), 1)[0]
    angle_x = motion.root_angle[:, k] + motion.q[:, arc.coords] @ slope
    diff = angle_x[:, None] - motion.alpha
    gx, gy = system.gravity
    base = (-np.sin(angle_x) * (motion.origin_ddot[:, 0] - gx)
            + np.cos(angle_x) * (motion.origin_ddot[:, 1] - gy))
    if motion.lengths is None:
        return base + (np.cos(diff) * motion.alpha_ddot
                       + np.sin(diff) * motion.alpha_dot**2) @ row
    rho, rho_d, rho_dd = motion.lengths
    return base + (np.cos(diff) * (rho * motion.alpha_ddot + 2.0 * rho_d * motion.alpha_dot)
                   + np.sin(diff) * (rho * motion.alpha_dot**2 - rho_dd)) @ row
