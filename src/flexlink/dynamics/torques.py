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
    """Zero- plus first-order moment of link j's inertia forces about P (frame-j axes)."""
    data = system.modal[j]
    m, s1, J = data.mass, data.first_moment, data.second_moment
    w, wd = fr.omega[:, j], fr.alpha[:, j]
    ax, ay = fr.origin_accel[:, j, 0], fr.origin_accel[:, j, 1]
    force = np.stack([m * ax - w**2 * s1, m * ay + wd * s1], -1)  # ∫ a⁰ dm
    moment0 = _cross(d, force) + s1 * ay + (J + data.rotary_inertia) * wd

    ny = np.concatenate([[0.0, m, s1], data.phi_bar])  # ∫ g_y dm = ny·ξ
    hy = np.concatenate([[0.0, s1, J], data.phi_tilde])  # ∫ x g_y dm = hy·ξ
    Gy, Gy_d, Gy_dd = xi @ ny, xi_d @ ny, xi_dd @ ny
    Hy, Hy_dd = xi @ hy, xi_dd @ hy
    rx, rx_d, rx_dd = xi[:, 0], xi_d[:, 0], xi_dd[:, 0]
    accel1 = np.stack([  # ∫ a¹ dm
        m * rx_dd - 2 * w * Gy_d - wd * Gy - w**2 * m * rx,
        Gy_dd + 2 * w * m * rx_d + wd * m * rx - w**2 * Gy,
    ], -1)
    x_accel1_y = Hy_dd + 2 * w * s1 * rx_d + wd * s1 * rx - w**2 * Hy  # ∫ x a¹_y dm
    # ∫ g × a⁰ dm with g = [ρx, ρy + xθ1 + Φq]
    g_cross_a0 = (rx * (m * ay + s1 * wd)
                  - xi[:, 1] * (m * ax - w**2 * s1)
                  - xi[:, 2] * (s1 * ax - w**2 * J)
                  - xi[:, 3:] @ data.phi_bar * ax + w**2 * (xi[:, 3:] @ data.phi_tilde))
    moment1 = (g_cross_a0 - _cross(p1, force) + _cross(d, accel1) + x_accel1_y
               + data.rotary_inertia * xi_dd[:, 2] + xi_dd[:, 3:] @ data.rotary_slope)
    return moment0 + moment1
