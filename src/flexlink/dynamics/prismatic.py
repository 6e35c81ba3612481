"""Sliders inside a chain (model/joints.py `PrismaticJoint`, docs/prismatic_joints.md): the
first-order model's kinematics and the one second-order term they add (numpy; the compiled
twin is in `_forward_numba.frames` and `_prismatic_numba.py`).

Slider k rides on a line fixed in the deformed section of link j = k − 1 at x_a
(`PrismaticJoint.at`, m from link j's joint; its tip by default), through that section's
point, along u = [cos a, sin a] of its axes. Its coordinate s_k (m) takes the place of the
joint angle in p = [base, β_1 … β_N, …]; link k's frame sits on the block, turned by the
constant γ (`link_angle`) from the parent's section. With that point's displacement and
rotation φ = [P̃(x_a) T̂_j x]₂ (frame j axes; P̃(x_a) the point map `hang_map`, the tip map
at x_a = L), the block is at

    r = r_j(x_a) + s A(φ) u = r_j(x_a) + s u + s φ S u − ½ s φ² u + …,

so frame k's perturbation maps are blockdiag(A(−γ), 1) L(s) P̃(x_a) T̂_j with the lever
L(s) = [[1, 0, −s u_y], [0, 1, s u_x], [0, 0, 1]] (time derivatives through ṡ, s̈: L' ṡ),
plus the column A(−γ) u of δs; the origin's acceleration gains
(s̈ − ω² s) u + (2 ω ṡ + ω̇ s) S u. At second order, δs φ S u − ½ s φ² u acted on by the
outboard inertia force F (frame j axes) give

    K ∋ (F·Su)(e_s φᵀ + φ e_sᵀ) − s (F·u) φ φᵀ,

the line turning with the section (the slider's row: F·(u + φ Su)) and the centrifugal
lever that stiffens the section's rotation, as the outboard axial force does at a revolute
tip. The outboard force F acts on link j at x_a: its second-order work on link j's own
deflection takes x_a, Φ(x_a) and S(x_a) in place of the tip's L, Φ(L) and S(L)
(`first_order.second_order_stiffness`, ``at``). The block's mass is a point body at link
k's root (`with_slider_masses`), so every inertia term of the links carries it.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..model import Body, Chain, PrismaticJoint
from ..modes import ModalData
from ..modes.integrals import _shortening
from .kinematics import section_map

# 90° turn S v = ẑ × v (the same as kinematics.TURN)
_TURN = np.array([[0.0, -1.0], [1.0, 0.0]])


def sliders(joints: tuple | list) -> list[int]:
    """Indices of the joints that are sliders."""
    return [k for k, joint in enumerate(joints) if isinstance(joint, PrismaticJoint)]


@dataclass(frozen=True, eq=False)
class Hang:
    """The section of link j that link j + 1 hangs on: ``x`` (m from link j's joint along its
    undeformed axis), Φ(x) ``value``, Φ'(x) ``slope`` (1/m) and S(x) = ∫₀ˣ Φ'ᵀΦ' ds
    ``shortening`` (1/m, the axis' foreshortening −½ qᵀS(x)q)."""

    x: float
    value: np.ndarray
    slope: np.ndarray
    shortening: np.ndarray


def hang_points(chain: Chain, modal: list[ModalData]) -> list[Hang]:
    """Per link j the section link j + 1 hangs on: a slider's `PrismaticJoint.at`, else (a
    revolute joint, a slider on the tip, the last link, a branch's end) the tip, whose
    values are the modal data's own arrays (the tip case is today's arithmetic)."""
    out = []
    for j, data in enumerate(modal):
        joint = chain.joints[j + 1] if j + 1 < len(chain.joints) else None
        at = joint.at if isinstance(joint, PrismaticJoint) else None
        if at is None or at == data.length:
            out.append(Hang(data.length, data.tip_value, data.tip_slope,
                            data.foreshortening_tip))
            continue
        x = np.array([float(at)])
        out.append(Hang(float(at), data.shapes.evaluate(x)[0], data.shapes.evaluate(x, 1)[0],
                        _shortening(data.shapes, float(at))))
    return out


def hang_map(hang: Hang) -> np.ndarray:
    """P̃(x): ξ = [ρx, ρy, θ1, q] → the displacement (frame axes) and rotation of the section
    ``hang``, (3, 3 + n); at the tip `kinematics.tip_map`."""
    return section_map(hang.x, hang.value, hang.slope)


def with_slider_masses(chain: Chain) -> Chain:
    """``chain`` with each slider's block as a point body at the root of the link it carries
    (unchanged when there is no slider with mass)."""
    links = list(chain.links)
    for k in sliders(chain.joints):
        mass = chain.joints[k].mass  # type: ignore[union-attr]
        if mass > 0.0:
            links[k] = replace(links[k], bodies=(*links[k].bodies,
                                                 Body(0.0, mass, name="slider block")))
    return chain if links == list(chain.links) else Chain(tuple(links), chain.joints)


def joint_angles(joints: tuple | list, p: np.ndarray, pd: np.ndarray, pdd: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The joint angles β, rates, accelerations (nt, N) of the joints' columns p, ṗ, p̈
    (nt, N): a slider's column is its travel; its angle is the constant γ."""
    beta, beta_d, beta_dd = p.copy(), pd.copy(), pdd.copy()
    for k in sliders(joints):
        beta[:, k] = joints[k].link_angle
        beta_d[:, k] = beta_dd[:, k] = 0.0
    return beta, beta_d, beta_dd


def lever(joint: PrismaticJoint, s: np.ndarray, sd: np.ndarray, sdd: np.ndarray,
          omega: np.ndarray, alpha: np.ndarray, U: np.ndarray, U_d: np.ndarray,
          U_dd: np.ndarray) -> np.ndarray:
    """Carry the parent's tip maps U = P̃ T̂_j, U̇, Ü (nt, 3, n_x) to the block in place
    (L(s) U, L U̇ + ṡ L' U, L Ü + 2ṡ L' U̇ + s̈ L' U) and return the block's acceleration
    relative to the tip (nt, 2), frame j axes, for the parent frame's rate ω and ω̇ (nt,)."""
    ux, uy = joint.direction
    # L' adds [−u_y, u_x] times the rotation row (row 2, which L keeps) to rows 0 and 1.
    for row, c in ((0, -uy), (1, ux)):
        U_dd[:, row] += c * (s[:, None] * U_dd[:, 2] + 2.0 * sd[:, None] * U_d[:, 2]
                             + sdd[:, None] * U[:, 2])
        U_d[:, row] += c * (s[:, None] * U_d[:, 2] + sd[:, None] * U[:, 2])
        U[:, row] += c * s[:, None] * U[:, 2]
    u = np.array([ux, uy])
    along = sdd - omega**2 * s
    across = 2.0 * omega * sd + alpha * s
    return along[:, None] * u + across[:, None] * (_TURN @ u)


def lever_stiffness(system: object, p: np.ndarray, fr: object, outboard: np.ndarray,
                    K: np.ndarray) -> None:
    """Add each slider's second-order terms (module docstring) to K (nt, n_x, n_x) in place;
    ``outboard`` (nt, N, 2): Σ_{i>j} ∫_i a0 dm in frame j's axes, ``fr`` the frames at the
    rigid states p (nt, n_rigid) (with the maps over x), ``system`` a `ForwardSystem`."""
    joints = system.chain.joints  # type: ignore[attr-defined]
    for k in sliders(joints):
        joint, j = joints[k], k - 1
        u = np.array(joint.direction)
        F = outboard[:, j]
        Fu, FSu = F @ u, F @ (_TURN @ u)
        phi = fr.T[k][:, 2, :]  # type: ignore[attr-defined]
        e = system.joint_index(k)  # type: ignore[attr-defined]
        s = p[:, e]
        K -= (s * Fu)[:, None, None] * phi[:, :, None] * phi[:, None, :]
        K[:, e, :] += FSu[:, None] * phi
        K[:, :, e] += FSu[:, None] * phi
