"""A geometrically exact reference for a slider whose line passes through a section inside a
flexible parent (`PrismaticJoint.at`, scenario key `line_at`), in Exudyn.

* the hub: an ``ObjectRigidBody2D`` of inertia ``hub_inertia`` on the parent beam's root node,
  that node's centre held at the origin by two ``CoordinateConstraint``; a moment history M(t)
  on its angle coordinate (`exudyn_pieces.StepMean`: the step mean). The beam's
  root node is the hub's node: the parent is clamped to the hub exactly;
* the parent: ``ObjectBeamGeometricallyExact2D`` elements (Simo–Reissner), a node at x_a;
* the block: an ``ObjectRigidBody2D`` of the block's mass on the carried beam's root node; a
  ``PrismaticJoint2D`` holds it on the line through the parent's node at x_a along the
  node-frame direction u (the line turns with that section), its rotation fixed to the
  section's (the carried beam at γ from the section); the slider's force is an
  ``ObjectConnectorLinearSpringDamper`` without stiffness along u whose force user function
  returns −F(t) (tests/validation/exudyn_slider_reference.py);
* the carried beam: Simo–Reissner elements from the block.

Signals: the hub's angle, the block's travel along the line from the section, the parent's
tip deflection in the hub frame and the carried beam's tip deflection in its root frame
(flexlink's deflection sensors at x = L). Undamped, no gravity.
"""

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
    fix,
    integration_step,
    load_history,
    new_system,
    node_sensor,
    node_series,
    point_mass,
    solve_dynamic,
)


def simulate_slider_point_exudyn(parent: Link, line_at: float, hub_inertia: float, beam: Link,
                                 block: float, axis: float, gamma: float, s0: float,
                                 moment: Callable[[float], float],
                                 force: Callable[[float], float], t_end: float, dt_out: float,
                                 elements: int, dt: float | None = None) -> dict[str, Any]:
    """The system of the module docstring from rest, the block at travel s0 (m); ``elements``
    per beam (the parent's mesh puts a node at ``line_at``); angles in rad from the section.

    Returns ``t`` (s), ``angle`` (rad), ``travel`` (m), ``parent_deflection`` and
    ``tip_deflection`` (m)."""
    import exudyn as exu
    from exudyn.itemInterface import MarkerNodeRigid, ObjectRigidBody2D

    dt = integration_step(dt_out, dt)
    _container, mbs, ground = new_system()

    inboard = max(1, round(elements * line_at / parent.length))
    outboard = (np.linspace(line_at, parent.length, max(1, elements - inboard) + 1)[1:]
                if line_at < parent.length else np.empty(0))
    x_parent = np.concatenate([np.linspace(0.0, line_at, inboard + 1), outboard])
    hub = beam_nodes(mbs, parent, x_parent, np.zeros(2), 0.0)
    mbs.AddObject(ObjectRigidBody2D(nodeNumber=hub[0], mass=1.0, inertia=hub_inertia))
    fix(mbs, ground, hub[0])
    load_history(mbs, coord(mbs, hub[0], 2), moment, dt)
    section = hub[inboard]
    u = np.array([math.cos(axis), math.sin(axis)])
    carried = beam_nodes(mbs, beam, np.linspace(0.0, beam.length, elements + 1),
                         np.array([line_at, 0.0]) + s0 * u, gamma)
    add_slider(mbs, mbs.AddMarker(MarkerNodeRigid(nodeNumber=section)),
               point_mass(mbs, carried[0], block), axis, gamma, force, dt)
    watched = (hub[0], section, hub[-1], carried[0], carried[-1])
    sensors = [node_sensor(mbs, n) for n in watched]
    _, t_grid = solve_dynamic(exu, mbs, t_end, dt, dt_out, 1e-6, 1e-8, 1.0)
    root, point, tip, r0, r1 = (node_series(mbs, s, t_grid, n)
                                for s, n in zip(sensors, watched))

    def normal_of(q: np.ndarray) -> np.ndarray:
        return np.stack([-np.sin(q[:, 2]), np.cos(q[:, 2])], 1)

    line = np.stack([np.cos(point[:, 2] + axis), np.sin(point[:, 2] + axis)], 1)
    return {"t": t_grid, "angle": root[:, 2],
            "travel": np.sum((r0[:, :2] - point[:, :2]) * line, 1),
            "parent_deflection": np.sum(normal_of(root) * (tip[:, :2] - root[:, :2]), 1),
            "tip_deflection": np.sum(normal_of(r0) * (r1[:, :2] - r0[:, :2]), 1)}
