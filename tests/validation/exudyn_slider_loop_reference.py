"""A geometrically exact reference for a slider inside a closed loop, in Exudyn: the mechanism
of tests/validation/test_nonlinear_slider_loops.py (a crank carrying a slider along its axis,
a post on the block, a rod pinned to the ground), built from the pieces of
exudyn_pieces.py, as exudyn_slider_reference.py.

* the crank: Simo–Reissner elements (`beam_nodes`) from the origin along X, its root node's
  position held by two ``CoordinateConstraint``, carrying the hub's inertia (a motor's) and
  turned by a torque history τ(t) on its rotation (`exudyn_pieces.StepMean`: the
  step mean);
* the block and the rigid post: one ``ObjectRigidBody2D`` (their mass, centre of mass and
  inertia), held on the line through the crank's tip node along its tangent (`add_slider`:
  a ``PrismaticJoint2D`` at the block's point, the post at 90° from the line, and the force
  history F(t) along it). A post of stiff beam elements is not rigid enough: its bending
  under the rod's pin force moved the crank's and the rod's deflections by percents;
* the rod: Simo–Reissner elements from the post's tip (a ``RevoluteJoint2D``), its tip node
  pinned to the ground point (two coordinate constraints).

Starts at rest and undeformed in the closed configuration of the rigid mechanism with the
crank along X: the post's tip at (L_crank + s0, L_post) and the rod along X from it, so the
ground pin is (L_crank + s0 + L_rod, L_post). Undamped, no gravity.

Signals: the crank's root angle, the block's travel along the line from the crank's tip, the
crank's tip deflection in its root frame and the rod's midpoint deflection from its chord."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from flexlink.model import Link

from .exudyn_pieces import (
    add_slider,
    beam_nodes,
    coord,
    default_section,
    fix,
    integration_step,
    load_history,
    new_system,
    node_sensor,
    node_series,
    solve_dynamic,
)


def simulate_slider_loop_exudyn(crank: Link, post: Link, rod: Link, block: float, s0: float,
                                torque: Callable[[float], float],
                                force: Callable[[float], float], t_end: float,
                                dt_out: float, elements: int, dt: float,
                                hub_inertia: float = 0.0, thickness: float = 0.01
                                ) -> dict[str, Any]:
    """The mechanism of the module docstring from rest, the block at travel ``s0`` (m), the
    crank turned by ``torque`` (N·m) on a hub of ``hub_inertia`` (kg·m², a motor's) and the
    block pushed by ``force`` (N); ``elements`` per
    flexible member (even: the rod's midpoint is a node); ``thickness`` (m): the sections'
    depth h, which sets Exudyn's axial stiffness EA = 12 EI / h², its shear stiffness and
    rotary inertia (`default_section`); flexlink's links are inextensible Euler–Bernoulli
    beams, the limit h → 0, and the stretch, shear and rotary inertia lower the loop's
    frequencies by terms in (h/L)². Returns ``t`` (s), ``crank_angle`` (rad), ``travel`` (m),
    ``crank_deflection``, ``rod_deflection`` (m), ``cpu_time_s`` (the process's during the
    solve), ``coordinates``."""
    import time

    import exudyn as exu
    from exudyn.itemInterface import (
        MarkerBodyRigid,
        MarkerNodeRigid,
        NodeRigidBody2D,
        ObjectRigidBody2D,
        RevoluteJoint2D,
    )

    if elements % 2:
        raise ValueError("an even number of elements: the rod's midpoint is a node")
    dt = integration_step(dt_out, dt)
    _container, mbs, ground = new_system()

    def section(link: Link) -> Any:
        return default_section(link, 12.0 * link.EI / thickness**2)

    def mesh(link: Link, n: int) -> np.ndarray:
        return np.linspace(0.0, link.length, n + 1)

    cn = beam_nodes(mbs, crank, mesh(crank, elements), np.zeros(2), 0.0, section(crank))
    if hub_inertia > 0.0:
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=cn[0], mass=1.0, inertia=hub_inertia))
    fix(mbs, ground, cn[0])
    load_history(mbs, coord(mbs, cn[0], 2), torque, dt)
    # the block and the rigid post: one body, its node at their centre of mass, c along the
    # post from the block
    m_post = post.mass_per_length * post.length
    c = m_post * 0.5 * post.length / (block + m_post)
    inertia = (block * c**2 + m_post * post.length**2 / 12.0
               + m_post * (0.5 * post.length - c) ** 2)
    root = np.array([crank.length + s0, 0.0])
    pn = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[root[0], c, 0.5 * math.pi]))
    body = mbs.AddObject(ObjectRigidBody2D(nodeNumber=pn, mass=block + m_post,
                                           inertia=inertia))
    add_slider(mbs, mbs.AddMarker(MarkerNodeRigid(nodeNumber=cn[-1])),
               mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[-c, 0.0, 0.0])),
               0.0, 0.5 * math.pi, force, dt)
    rn = beam_nodes(mbs, rod, mesh(rod, elements), root + np.array([0.0, post.length]), 0.0,
                    section(rod))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[
        mbs.AddMarker(MarkerBodyRigid(bodyNumber=body, localPosition=[post.length - c, 0.0,
                                                                      0.0])),
        mbs.AddMarker(MarkerNodeRigid(nodeNumber=rn[0]))]))
    fix(mbs, ground, rn[-1])
    watched = (cn[0], cn[-1], pn, rn[0], rn[elements // 2], rn[-1])
    sensors = [node_sensor(mbs, n) for n in watched]
    cpu = time.process_time()
    wall, t_grid = solve_dynamic(exu, mbs, t_end, dt, dt_out, 1e-6, 1e-8, 1.0)
    cpu = time.process_time() - cpu
    root, tip, centre, r0, mid, r1 = (node_series(mbs, s, t_grid, n)
                                      for s, n in zip(sensors, watched))
    on_block = centre[:, :2] - c * np.stack([np.cos(centre[:, 2]), np.sin(centre[:, 2])], 1)
    line = np.stack([np.cos(tip[:, 2]), np.sin(tip[:, 2])], 1)
    normal_root = np.stack([-np.sin(root[:, 2]), np.cos(root[:, 2])], 1)
    chord = r1[:, :2] - r0[:, :2]
    normal = np.stack([-chord[:, 1], chord[:, 0]], 1) / np.linalg.norm(chord, axis=1)[:, None]
    return {"t": t_grid, "crank_angle": root[:, 2],
            "travel": np.sum((on_block - tip[:, :2]) * line, 1),
            "crank_deflection": np.sum(normal_root * (tip[:, :2] - root[:, :2]), 1),
            "rod_deflection": np.sum(normal * (mid[:, :2] - 0.5 * (r0[:, :2] + r1[:, :2])), 1),
            "wall_time_s": wall, "cpu_time_s": cpu, "coordinates": mbs.systemData.ODE2Size()}
