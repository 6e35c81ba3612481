"""Channel values of the first-order model from a solved run (vectorised over output times).

Point quantities use the link's clamped frame: deflection w(x), slope w'(x), surface strain
−(h/2) w''(x) on the +y face. The accelerometer reads the absolute acceleration of the material
point along its deformed normal, to first order (docs/derivation.md, "Sensors"):

    a_n = a0_y + a1_y − a0_x (θ1 + w'(x)),

computed from z̈ of the equations of motion, never by differentiating displacements.

Prescribed runs read the `FirstOrderSystem`; forward runs a view of theirs restricted to the
elastic coordinates about the solved rigid motion (channels/forward.py): both are an
`ElasticModel`.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np

from ..dynamics.first_order import LinkBody
from ..dynamics.kinematics import FrameMotion
from ..model import Chain, PointSensor, Sensor
from ..modes import ModalData
from ..solvers import Solution
from .catalogue import tip_name
from .modal import modal_reading, shape_row
from .shapes import POINTS, LinkShape, fractions


class ElasticModel(Protocol):
    """What the readings need of a first-order model: the chain, its modal data and the
    coordinates of each link's modes, and ξ_k = [ρx, ρy, θ1, q_k] from z."""

    chain: Chain
    modal: list[ModalData]
    bodies: list[LinkBody]

    def xi_states(self, frames: FrameMotion, k: int, z: np.ndarray, zd: np.ndarray,
                  zdd: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...


def sensor_values(model: ElasticModel, frames: FrameMotion, solution: Solution,
                  sensors: tuple[Sensor, ...]) -> dict[str, np.ndarray]:
    """Each sensor's reading at the solution's times, by sensor name."""
    return {s.name: _read(model, frames, solution, s) for s in sensors}


def tip_values(model: ElasticModel, frames: FrameMotion, z: np.ndarray) -> dict[str, np.ndarray]:
    """Global X and Y (m) of every link's deformed tip, by channel name."""
    out = {}
    for k, link in enumerate(model.chain.links):
        tip = tip_position(model, frames, z, k)
        out[tip_name(link.name, "X")] = tip[:, 0]
        out[tip_name(link.name, "Y")] = tip[:, 1]
    return out


def tip_deflections(model: ElasticModel, z: np.ndarray) -> np.ndarray:
    """|w(L)| of every link in its clamped frame, (nt, links), m."""
    return np.abs(np.column_stack([z[:, b.slice] @ b.data.tip_value for b in model.bodies]))


def tip_position(model: ElasticModel, frames: FrameMotion, z: np.ndarray, k: int) -> np.ndarray:
    """Global position (nt, 2) of link k's deformed tip, m."""
    # link_points at x = L, written out for one point (a tenth of its cost)
    d = model.modal[k]
    rho = frames.head(k, z)
    across = rho[:, 1] + d.length * rho[:, 2] + z[:, model.bodies[k].slice] @ d.tip_value
    along = d.length + rho[:, 0]
    c, s = frames.cos_sin(k)
    out = np.empty((z.shape[0], 2))
    out[:, 0] = frames.origin[:, k, 0] + c * along - s * across
    out[:, 1] = frames.origin[:, k, 1] + s * along + c * across
    return out


def link_points(model: ElasticModel, frames: FrameMotion, z: np.ndarray, k: int, x: np.ndarray,
                phi: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Global X and Y, (nt, len(x)) each, m, of the points x (m from the joint) of link k:
    origin_k + A(θ_k)·[x + ρx, ρy + x·θ1 + Φ(x)q_k]. ``phi``: Φ(x) (len(x), n_k) if known."""
    d = model.modal[k]
    if phi is None:
        phi = d.shapes.evaluate(x, 0)
    rho = frames.head(k, z)
    q = z[:, model.bodies[k].slice]
    c, s = frames.cos_sin(k)
    # Linear in per-time factors: one small matrix product per axis instead of elementwise
    # arithmetic on (nt, len(x)) arrays (a quarter of the cost on a paper run).
    grid = np.vstack([np.ones_like(x), x, x, phi.T])  # (3 + n_k, len(x))
    origin = frames.origin[:, k]
    fx = np.column_stack([origin[:, 0] + c * rho[:, 0] - s * rho[:, 1], c, -s * rho[:, 2],
                          -s[:, None] * q])
    fy = np.column_stack([origin[:, 1] + s * rho[:, 0] + c * rho[:, 1], s, c * rho[:, 2],
                          c[:, None] * q])
    return fx @ grid, fy @ grid


def shape_values(model: ElasticModel, frames: FrameMotion, z: np.ndarray,
                 points: int = POINTS) -> list[LinkShape]:
    """Every link's deformed shape on `points` evenly spaced points, and its rigid frame."""
    out = []
    for k, link in enumerate(model.chain.links):
        fraction = fractions(points)
        X, Y = link_points(model, frames, z, k, fraction * link.length)
        out.append(LinkShape(link.name, link.length, fraction, X, Y,
                             frames.origin[:, k], frames.theta[:, k]))
    return out


def _read(model: ElasticModel, frames: FrameMotion, solution: Solution,
          sensor: Sensor) -> np.ndarray:
    k = sensor.link
    shapes = model.modal[k].shapes
    q = solution.q[:, model.bodies[k].slice]
    reading = modal_reading(sensor, shapes, q, model.chain)
    if reading is not None:
        return reading
    assert isinstance(sensor, PointSensor)
    if sensor.kind == "deflection":
        return q @ shape_row(shapes, sensor.x, 0)
    return _normal_acceleration(model, frames, solution, k, sensor.x)


def _normal_acceleration(model: ElasticModel, frames: FrameMotion, solution: Solution, k: int,
                         x: float) -> np.ndarray:
    # ξ_k = [ρx, ρy, θ1, q_k] and its derivatives, read as their parts (frames.heads and
    # q_k) rather than joined into one array (a copy per sensor and output time saved).
    head, head_d, head_dd = frames.heads(k, solution.q, solution.q_dot, solution.q_ddot)
    own = model.bodies[k].slice
    shapes = model.modal[k].shapes
    phi = shape_row(shapes, x, 0)
    dphi = shape_row(shapes, x, 1)

    def transverse(v: np.ndarray, q: np.ndarray) -> np.ndarray:
        return v[:, 1] + x * v[:, 2] + q[:, own] @ phi

    w, wd = frames.omega[:, k], frames.alpha[:, k]
    ax, ay = frames.origin_accel[:, k, 0], frames.origin_accel[:, k, 1]
    a0x, a0y = ax - w**2 * x, ay + wd * x
    a1y = (transverse(head_dd, solution.q_ddot) + 2 * w * head_d[:, 0] + wd * head[:, 0]
           - w**2 * transverse(head, solution.q))
    rotation_angle = head[:, 2] + solution.q[:, own] @ dphi
    return a0y + a1y - a0x * rotation_angle
