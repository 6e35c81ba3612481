"""A finite-element eigenanalysis of a planar four-bar linkage at rest, independent of
flexlink's assumed modes and closure kinematics: 2-D frame elements (axial and Euler–Bernoulli
bending, consistent mass) along each link, the links pinned to each other by shared
translations (each link keeps its own rotation at the pin), the ground pivots by fixed
translations. A rigid link is a frame of stiffness ``RIGID`` times the flexible one's."""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh

RIGID = 1e4
RIGID_ELEMENTS = 2  # few: stiff elements of a rigid link on a fine grid spoil the conditioning


def _element(EA: float, EI: float, m: float, L: float, angle: float
             ) -> tuple[np.ndarray, np.ndarray]:
    """Global stiffness and consistent mass (6 × 6: u, v, θ at both ends) of a frame element."""
    k = np.zeros((6, 6))
    a = EA / L
    k[np.ix_([0, 3], [0, 3])] = a * np.array([[1, -1], [-1, 1]])
    b = EI / L**3 * np.array([[12, 6 * L, -12, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                              [-12, -6 * L, 12, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]])
    bend = [1, 2, 4, 5]
    k[np.ix_(bend, bend)] = b
    mm = np.zeros((6, 6))
    mm[np.ix_([0, 3], [0, 3])] = m * L / 6 * np.array([[2, 1], [1, 2]])
    mm[np.ix_(bend, bend)] = m * L / 420 * np.array(
        [[156, 22 * L, 54, -13 * L], [22 * L, 4 * L**2, 13 * L, -3 * L**2],
         [54, 13 * L, 156, -22 * L], [-13 * L, -3 * L**2, -22 * L, 4 * L**2]])
    c, s = np.cos(angle), np.sin(angle)
    r = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1]])
    T = np.zeros((6, 6))
    T[:3, :3] = T[3:, 3:] = r
    return T.T @ k @ T, T.T @ mm @ T


def four_bar_frequencies(crank: tuple[float, float, float], coupler: tuple[float, float, float],
                         rocker: tuple[float, float, float], pivot: tuple[float, float],
                         angles: tuple[float, float, float], EA: float,
                         elements: int = 40, count: int = 4, held_crank: bool = False,
                         coupler_tip: tuple[float, float] = (0.0, 0.0),
                         crank_spring: float = 0.0, crank_tip: float = 0.0) -> np.ndarray:
    """The lowest ``count`` natural frequencies (Hz, the mechanism's zero included) of the
    four-bar: crank from the origin, coupler from the crank's tip, rocker from ``pivot``
    (the pivot's position enters through the angles), their tips pinned. Each link is (length m, mass per length kg/m, EI N·m², inf: rigid) at
    its absolute angle (rad) in ``angles``; EA (N) the flexible links' axial stiffness;
    ``held_crank``: the crank's rotation at the origin fixed too (a crank held by its motor:
    no mechanism motion); ``coupler_tip``: a body (mass kg, rotary inertia kg·m²) on the
    coupler's tip, lumped on its node (it turns with the coupler's end section);
    ``crank_spring``: a torsional spring (N·m/rad) from the ground to the crank's root
    rotation (an elastic joint whose motor is held); ``crank_tip``: a point mass (kg) on the
    crank's tip (the crank pin's)."""
    flexible_EI = max(ei for _, _, ei in (crank, coupler, rocker) if np.isfinite(ei))
    dof = 0
    nodes: list[list[list[int]]] = []  # per link, per node: [u, v, θ] global indices
    fixed: set[int] = set()
    counts = [elements if np.isfinite(ei) else RIGID_ELEMENTS for _, _, ei in
              (crank, coupler, rocker)]
    for k, ((L, _, _), angle) in enumerate(zip((crank, coupler, rocker), angles)):
        link_nodes = []
        for i in range(counts[k] + 1):
            if k == 1 and i == 0:  # the coupler's root shares the crank tip's translation
                link_nodes.append([*nodes[0][-1][:2], dof])
                dof += 1
                continue
            link_nodes.append([dof, dof + 1, dof + 2])
            dof += 3
        nodes.append(link_nodes)
        if k != 1:
            fixed |= set(link_nodes[0][:2])  # ground pivots
        if k == 0 and held_crank:
            fixed.add(link_nodes[0][2])
    tip_c, tip_r = nodes[1][-1], nodes[2][-1]  # the closure: shared translation
    merge = {tip_r[0]: tip_c[0], tip_r[1]: tip_c[1]}
    K = np.zeros((dof, dof))
    M = np.zeros((dof, dof))
    for k, ((L, m, EI), angle) in enumerate(zip((crank, coupler, rocker), angles)):
        stiff = EI if np.isfinite(EI) else RIGID * flexible_EI
        axial = EA if np.isfinite(EI) else RIGID * EA
        ke, me = _element(axial, stiff, m, L / counts[k], angle)
        for i in range(counts[k]):
            idx = [merge.get(j, j) for j in nodes[k][i] + nodes[k][i + 1]]
            K[np.ix_(idx, idx)] += ke
            M[np.ix_(idx, idx)] += me
    K[nodes[0][0][2], nodes[0][0][2]] += crank_spring
    tip_u, tip_v, tip_th = nodes[1][-1]
    M[tip_u, tip_u] += coupler_tip[0]
    M[tip_v, tip_v] += coupler_tip[0]
    M[tip_th, tip_th] += coupler_tip[1]
    for i in nodes[0][-1][:2]:
        M[i, i] += crank_tip
    keep = [i for i in range(dof) if i not in fixed and i not in merge]
    w2 = eigh(K[np.ix_(keep, keep)], M[np.ix_(keep, keep)], eigvals_only=True,
              subset_by_index=[0, count - 1])
    return np.sqrt(np.clip(w2, 0.0, None)) / (2 * np.pi)
