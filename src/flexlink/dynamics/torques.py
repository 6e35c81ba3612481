"""Joint torques of a prescribed motion (inverse dynamics of the first-order model).

The motor of joint k carries everything outboard of it (links k…N with their bodies); the
joint force passes through the joint, so its torque is the moment of the outboard inertia
forces about the (moving) joint point P_k:

    τ_k = Σ_{j≥k} [ ∫_j (r − P_k) × r̈ dm + Σ_b J_b ϑ̈_b ],

expanded to first order in z like the equations of motion (docs/derivation.md, "Joint torques").
Every quantity of link j is taken in its zero-order frame; a × b = a_x b_y − a_y b_x.
"""

from __future__ import annotations

import numpy as np

from .first_order import FirstOrderSystem
from .kinematics import FrameMotion, rotation


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def joint_torques(
    system: FirstOrderSystem, t: np.ndarray, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray,
    frames: FrameMotion | None = None,
) -> np.ndarray:
    """Motor torque of every joint, (nt, N) in N·m, positive counter-clockwise on link k.
    ``frames``: the frame motion at t if known (a run's SolvedFrames for this z, ż, z̈)."""
    fr = system.frames(t) if frames is None else frames
    nt, n_links = fr.theta.shape
    torque = np.zeros((nt, n_links))
    states = [system.xi_states(fr, j, z, zd, zdd) for j in range(n_links)]

    for k in range(n_links):
        for j in range(k, n_links):
            e_j = rotation(fr.theta[:, j])
            d = np.einsum("tji,tj->ti", e_j, fr.origin[:, j] - fr.origin[:, k])
            p1 = np.einsum("tij,tj->ti", rotation(fr.theta[:, k] - fr.theta[:, j]),
                           states[k][0][:, :2])
            torque[:, k] += _link_moment(system, fr, j, d, p1, *states[j])
    return torque


def _link_moment(system, fr, j, d, p1, xi, xi_d, xi_dd) -> np.ndarray:
    """Zero- plus first-order moment of link j's inertia forces about P (frame-j axes).

    X = [x, y] the zero-order position of a mass point in frame j (y = c_y for a body's
    centre across the link), g = P̂ξ its first-order displacement."""
    data = system.modal[j]
    m, s1, J = data.mass, data.first_moment, data.second_moment
    sy = data.lateral_moment  # ∫ y dm
    w, wd = fr.omega[:, j], fr.alpha[:, j]
    ax, ay = fr.origin_accel[:, j, 0], fr.origin_accel[:, j, 1]
    force = np.stack([m * ax - w**2 * s1 - wd * sy, m * ay + wd * s1 - w**2 * sy], -1)  # ∫ a⁰ dm
    moment0 = _cross(d, force) + s1 * ay - sy * ax + (J + data.rotary_inertia) * wd

    nx = system.bodies[j].M0[0]  # ∫ g_x dm = nx·ξ
    ny = np.concatenate([[0.0, m, s1], data.phi_bar])  # ∫ g_y dm = ny·ξ
    hy = np.concatenate([[-sy, s1, J], data.phi_tilde])  # ∫ X × g dm = hy·ξ
    Gx, Gx_d, Gx_dd = xi @ nx, xi_d @ nx, xi_dd @ nx
    Gy, Gy_d, Gy_dd = xi @ ny, xi_d @ ny, xi_dd @ ny
    Hy, Hy_dd = xi @ hy, xi_dd @ hy
    # ∫ X·g dm = s1 ρx + (∫ y dm) ρy − lateral_tilde·q
    dot = s1 * xi[:, 0] + sy * xi[:, 1] - xi[:, 3:] @ data.lateral_tilde
    dot_d = s1 * xi_d[:, 0] + sy * xi_d[:, 1] - xi_d[:, 3:] @ data.lateral_tilde
    accel1 = np.stack([  # ∫ a¹ dm
        Gx_dd - 2 * w * Gy_d - wd * Gy - w**2 * Gx,
        Gy_dd + 2 * w * Gx_d + wd * Gx - w**2 * Gy,
    ], -1)
    x_accel1_y = Hy_dd + 2 * w * dot_d + wd * dot - w**2 * Hy  # ∫ X × a¹ dm
    g_cross_a0 = ay * Gx - ax * Gy + wd * dot + w**2 * Hy  # ∫ g × a⁰ dm
    moment1 = (g_cross_a0 - _cross(p1, force) + _cross(d, accel1) + x_accel1_y
               + data.rotary_inertia * xi_dd[:, 2] + xi_dd[:, 3:] @ data.rotary_slope)
    return moment0 + moment1
