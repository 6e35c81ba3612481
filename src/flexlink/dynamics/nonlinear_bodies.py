"""Rigid bodies (`model.Body`; the tip mass and tip inertia are the body at the tip without
offset) in the nonlinear models' point-mass description: the one place they enter both the
prescribed (`nonlinear.NonlinearSystem`) and the forward (`nonlinear_forward`) model.

Positions there are sums Σ_j W_j e(α_j) over nodes j with section angles α_j = A_j q + B_j p
(e(α) = [cos α, sin α]). A body at section x_b of link k turns with the section, α_b =
root angle of link k + Φ'(x_b) q exactly; its centre r(x_b) + c_x e(α_b) is the position row of
x_b plus one node of its own with angle α_b + atan2(c_y, c_x) (a constant offset of the node's
angle) and weight |c| (none when c = 0), and its inertia J about the centre is a rotary row
(α_b, J).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..model import Chain, Link
from ..modes import ModalData


def body_nodes(chain: Chain) -> int:
    """The number of nodes the bodies add to the node axis: one per body with mass whose
    centre is off its section point."""
    return sum(1 for link in chain.links for b in link.all_bodies()
               if b.mass and any(b.offset))


@dataclass(frozen=True)
class BodyRows:
    """One link's bodies in the point-mass description: ``W`` (b, nodes) and ``mass`` (b,) kg
    of their centres; rotary rows ``rot_A`` (r, n) on q, ``rot_B`` (r, ·) on the rigid
    coordinates and ``rot_J`` (r,) kg·m²; the nodes they add, ``nodes`` (indices), with their
    angle rows ``node_A``, ``node_B`` and constant angle offsets ``node_offset`` (rad)."""

    W: np.ndarray
    mass: np.ndarray
    rot_A: np.ndarray
    rot_B: np.ndarray
    rot_J: np.ndarray
    nodes: list[int]
    node_A: np.ndarray
    node_B: np.ndarray
    node_offset: np.ndarray


def body_rows(link: Link, data: ModalData, coords: slice, root_A: np.ndarray,
              root_B: np.ndarray, position_rows: Callable[[np.ndarray], np.ndarray],
              first_node: int) -> BodyRows:
    """Link's bodies (`Link.all_bodies`): ``coords`` its q in q, ``root_A``/``root_B`` the
    angle rows of its clamped frame, ``position_rows(x)`` the W rows of its points x (m),
    ``first_node`` the index of the first node its offset bodies may take."""
    W, mass, rot_A, rot_B, rot_J, nodes, node_A, node_B, node_offset = ([] for _ in range(9))
    node = first_node
    for body in link.all_bodies():
        section_A = root_A.copy()
        section_A[coords] += data.shapes.evaluate(np.array([body.at]), 1)[0]
        if body.mass:
            row = position_rows(np.array([body.at]))[0]
            if any(body.offset):
                row[node] = math.hypot(*body.offset)
                nodes.append(node)
                node_A.append(section_A)
                node_B.append(root_B)
                node_offset.append(math.atan2(body.offset[1], body.offset[0]))
                node += 1
            W.append(row)
            mass.append(body.mass)
        if body.inertia:
            rot_A.append(section_A)
            rot_B.append(root_B)
            rot_J.append(body.inertia)
    n_nodes, n, m = position_rows(np.zeros(1)).shape[1], root_A.size, root_B.size
    return BodyRows(np.array(W, dtype=float).reshape(len(W), n_nodes),
                    np.array(mass, dtype=float),
                    np.array(rot_A, dtype=float).reshape(len(rot_A), n),
                    np.array(rot_B, dtype=float).reshape(len(rot_B), m),
                    np.array(rot_J, dtype=float), nodes,
                    np.array(node_A, dtype=float).reshape(len(node_A), n),
                    np.array(node_B, dtype=float).reshape(len(node_B), m),
                    np.array(node_offset, dtype=float))
