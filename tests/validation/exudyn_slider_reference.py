"""A geometrically exact reference for a slider inside a chain (dynamics/prismatic.py), in
Exudyn: a flexible beam on a block sliding along a line at the tip of a rotating rigid link.

* the rigid link: an ``ObjectRigidBody2D`` pinned at the origin (its node's centre held by two
  ``CoordinateConstraint``), of inertia ``link_inertia`` about the pin, turned by a moment
  history M(t) on its angle coordinate (`exudyn_pieces.StepMean`: the step mean);
* the block: the beam's root node carries an ``ObjectRigidBody2D`` of the block's mass; a
  ``PrismaticJoint2D`` holds it on the line through the link's point (L1, 0) along the
  link-frame direction u, its rotation fixed to the link's (the beam at γ from the link);
* the slider's drive: an ``ObjectConnectorLinearSpringDamper`` along the same axis, without
  stiffness, whose force user function returns the history F(t) (its sign: a positive
  connector force pulls the two markers together, so it returns −F, F pushing the block
  out along u);
* the beam: ``ObjectBeamGeometricallyExact2D`` elements (Simo–Reissner) from the block.

Signals: the link's angle and its rate, the block's travel s along the line and its rate, and
the beam's tip deflection n_root · (r_tip − r_root) in the clamped root frame (flexlink's
deflection sensor at x = L).
Undamped, no gravity.

On a cart (``cart_mass``): the pin rides on a free cart (an ``ObjectRigidBody2D`` held to the
x axis, its y and rotation fixed by ``CoordinateConstraint``), the rigid link is a body of
``link_mass`` centred at half its length, pinned to the cart by a ``RevoluteJoint2D``; the
moment still turns the link (the cart's fixed rotation takes the reaction). The cart's
position is one more signal.
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

VERBOSE = 0


def simulate_slider_exudyn(link_length: float, link_inertia: float, beam: Link, block: float,
                           axis: float, gamma: float, s0: float,
                           moment: Callable[[float], float], force: Callable[[float], float],
                           t_end: float, dt_out: float, elements: int,
                           dt: float | None = None, cart_mass: float | None = None,
                           link_mass: float = 0.0) -> dict[str, Any]:
    """The system of the module docstring from rest, the block at travel s0 (m); angles in
    rad (axis: the line's direction, gamma: the beam's, both from the rigid link);
    ``cart_mass`` (kg): the pin on a free cart along x (None: fixed), the link then of
    ``link_mass`` (kg) centred at half its length, ``link_inertia`` still about the pin.

    Returns ``t`` (s), ``angle`` (rad), ``rate`` (rad/s), ``travel`` (m), ``travel_rate``
    (m/s), ``tip_deflection`` (m), on a cart ``cart`` (m), ``wall_time_s`` (the solver's),
    ``cpu_time_s`` (the process's during the solve)."""
    import time

    import exudyn as exu
    from exudyn.itemInterface import (
        MarkerBodyRigid,
        NodeRigidBody2D,
        ObjectRigidBody2D,
        RevoluteJoint2D,
    )

    dt = integration_step(dt_out, dt)
    _container, mbs, ground = new_system()

    # the link's body: about the pin (fixed hub), or centred at half its length on a cart
    centre = 0.0 if cart_mass is None else 0.5 * link_length
    hub_node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[centre, 0.0, 0.0]))
    if cart_mass is None:
        hub = mbs.AddObject(ObjectRigidBody2D(nodeNumber=hub_node, mass=1.0,
                                              inertia=link_inertia))
        fix(mbs, ground, hub_node)
    else:
        hub = mbs.AddObject(ObjectRigidBody2D(nodeNumber=hub_node, mass=link_mass,
                                              inertia=link_inertia - link_mass * centre**2))
        cart_node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
        cart = mbs.AddObject(ObjectRigidBody2D(nodeNumber=cart_node, mass=cart_mass,
                                               inertia=1.0))
        fix(mbs, ground, cart_node, (1, 2))
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[
            mbs.AddMarker(MarkerBodyRigid(bodyNumber=cart, localPosition=[0.0, 0.0, 0.0])),
            mbs.AddMarker(MarkerBodyRigid(bodyNumber=hub, localPosition=[-centre, 0.0,
                                                                         0.0]))]))
    load_history(mbs, coord(mbs, hub_node, 2), moment, dt)
    u = np.array([math.cos(axis), math.sin(axis)])
    root = np.array([link_length, 0.0]) + s0 * u
    chain = beam_nodes(mbs, beam, np.linspace(0.0, beam.length, elements + 1), root, gamma)
    on_link = mbs.AddMarker(MarkerBodyRigid(bodyNumber=hub, localPosition=[
        link_length - centre, 0.0, 0.0]))
    add_slider(mbs, on_link, point_mass(mbs, chain[0], block), axis, gamma, force, dt)

    s_hub = node_sensor(mbs, hub_node, exu.OutputVariableType.Coordinates)
    s_root = node_sensor(mbs, chain[0], exu.OutputVariableType.Coordinates)
    s_tip = node_sensor(mbs, chain[-1], exu.OutputVariableType.Coordinates)
    v_hub = node_sensor(mbs, hub_node, exu.OutputVariableType.Coordinates_t)
    v_root = node_sensor(mbs, chain[0], exu.OutputVariableType.Coordinates_t)
    cpu = time.process_time()
    wall, t_grid = solve_dynamic(exu, mbs, t_end, dt, dt_out, 1e-6, 1e-8, 1.0, verbose=VERBOSE)
    cpu = time.process_time() - cpu
    hub_q, r0, r1 = (node_series(mbs, s, t_grid, n) for s, n in
                     ((s_hub, hub_node), (s_root, chain[0]), (s_tip, chain[-1])))
    angle = hub_q[:, 2]
    pin = hub_q[:, :2] - centre * np.stack([np.cos(angle), np.sin(angle)], 1)
    tip_point = pin + link_length * np.stack([np.cos(angle), np.sin(angle)], 1)
    line = np.stack([np.cos(angle + axis), np.sin(angle + axis)], 1)
    normal_root = np.stack([-np.sin(r0[:, 2]), np.cos(r0[:, 2])], 1)
    hub_v = node_series(mbs, v_hub, t_grid)  # rates: no reference part
    root_velocity = node_series(mbs, v_root, t_grid)[:, :2]
    rate = hub_v[:, 2]
    across = np.stack([-np.sin(angle + axis), np.cos(angle + axis)], 1)  # d line / d angle
    tip_velocity = hub_v[:, :2] + (link_length - centre) * rate[:, None] * np.stack(
        [-np.sin(angle), np.cos(angle)], 1)
    travel_rate = (np.sum((root_velocity - tip_velocity) * line, 1)
                   + rate * np.sum((r0[:, :2] - tip_point) * across, 1))
    return {"t": t_grid, "angle": angle, "rate": rate, "travel_rate": travel_rate,
            "travel": np.sum((r0[:, :2] - tip_point) * line, 1),
            "tip_deflection": np.sum(normal_root * (r1[:, :2] - r0[:, :2]), 1),
            **({} if cart_mass is None else {"cart": pin[:, 0]}),
            "wall_time_s": wall, "cpu_time_s": cpu, "coordinates": mbs.systemData.ODE2Size()}
