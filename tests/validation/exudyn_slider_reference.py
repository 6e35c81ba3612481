"""A geometrically exact reference for a slider inside a chain (dynamics/prismatic.py), in
Exudyn: a flexible beam on a block sliding along a line at the tip of a rotating rigid link.

* the rigid link: an ``ObjectRigidBody2D`` pinned at the origin (its node's centre held by two
  ``CoordinateConstraint``), of inertia ``link_inertia`` about the pin, turned by a moment
  history M(t) on its angle coordinate (`exudyn_forward_reference._Moment`: the step mean);
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

import itertools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from flexlink.model import Link

from .exudyn_forward_reference import _Moment
from .exudyn_reference import BeamSection, default_section, solve_dynamic

VERBOSE = 0


def beam_nodes(mbs: Any, link: Link, x: np.ndarray, root: np.ndarray, angle: float,
               section: BeamSection | None = None, stiff: float = 1.0) -> list[int]:
    """Simo–Reissner elements of ``link`` between nodes at ``x`` (m from ``root``, m, along
    ``angle``, rad), undeformed; its tip mass on the last node (a point mass). ``section``:
    Exudyn's section (default: `default_section` of the link); ``stiff`` multiplies its
    stiffnesses (a rigid member). Returns the nodes."""
    from exudyn.itemInterface import (
        NodeRigidBody2D,
        ObjectBeamGeometricallyExact2D,
        ObjectRigidBody2D,
    )

    e = np.array([math.cos(angle), math.sin(angle)])
    sec = section or default_section(link)
    nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[*(root + xi * e), angle]))
             for xi in x]
    for (a, b), h in zip(itertools.pairwise(nodes), np.diff(x)):
        mbs.AddObject(ObjectBeamGeometricallyExact2D(
            nodeNumbers=[a, b], length=float(h), massPerLength=link.mass_per_length,
            crossSectionInertia=sec.rhoI, bendingStiffness=stiff * link.EI,
            axialStiffness=stiff * sec.EA, shearStiffness=stiff * sec.GA))
    if link.tip_mass > 0.0:
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=nodes[-1], mass=link.tip_mass, inertia=0.0))
    return nodes


def point_mass(mbs: Any, node: int, mass: float) -> int:
    """A point mass of ``mass`` kg (no rotary inertia) on ``node``; returns the node's rigid
    marker."""
    from exudyn.itemInterface import MarkerNodeRigid, ObjectRigidBody2D

    mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=mass, inertia=0.0))
    return mbs.AddMarker(MarkerNodeRigid(nodeNumber=node))


def add_slider(mbs: Any, on_line: int, on_block: int, axis: float, gamma: float,
               force: Callable[[float], float], dt: float) -> None:
    """Hold the rigid marker ``on_block`` (the block) on the line through the rigid marker
    ``on_line`` along ``axis`` (rad, in that marker's frame) by a ``PrismaticJoint2D``, its
    rotation fixed at ``gamma`` (rad) from the line's frame, and push it along the line by
    F(t) (N; `_Moment`: the mean over each step of ``dt`` s) through a connector without
    stiffness (a positive connector force pulls the markers together: it returns −F)."""
    from exudyn.itemInterface import LinearSpringDamper, PrismaticJoint2D

    u = [math.cos(axis), math.sin(axis), 0.0]
    # The normal to the line in the block's frame: S u turned back by γ.
    normal = [-math.sin(axis - gamma), math.cos(axis - gamma), 0.0]
    mbs.AddObject(PrismaticJoint2D(markerNumbers=[on_line, on_block], axisMarker0=u,
                                   normalMarker1=normal, constrainRotation=True))
    push = _Moment(force, dt)

    def connector_force(mbs_: Any, t: float, item: int, *args: Any) -> float:
        return -push(mbs_, t, item)

    mbs.AddObject(LinearSpringDamper(markerNumbers=[on_line, on_block], stiffness=0.0,
                                     damping=0.0, axisMarker0=u,
                                     springForceUserFunction=connector_force))


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
        CoordinateConstraint,
        LoadCoordinate,
        MarkerBodyRigid,
        MarkerNodeCoordinate,
        NodePointGround,
        NodeRigidBody2D,
        ObjectRigidBody2D,
        RevoluteJoint2D,
        SensorNode,
    )

    if dt is None:
        dt = min(dt_out, 5e-4)
    dt = dt_out / round(dt_out / dt)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddNode(NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))

    def coord(node: int, c: int) -> int:
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=c))

    # the link's body: about the pin (fixed hub), or centred at half its length on a cart
    centre = 0.0 if cart_mass is None else 0.5 * link_length
    hub_node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[centre, 0.0, 0.0]))
    if cart_mass is None:
        hub = mbs.AddObject(ObjectRigidBody2D(nodeNumber=hub_node, mass=1.0,
                                              inertia=link_inertia))
        for c in (0, 1):
            mbs.AddObject(CoordinateConstraint(markerNumbers=[coord(ground, 0),
                                                              coord(hub_node, c)]))
    else:
        hub = mbs.AddObject(ObjectRigidBody2D(nodeNumber=hub_node, mass=link_mass,
                                              inertia=link_inertia - link_mass * centre**2))
        cart_node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
        cart = mbs.AddObject(ObjectRigidBody2D(nodeNumber=cart_node, mass=cart_mass,
                                               inertia=1.0))
        for c in (1, 2):
            mbs.AddObject(CoordinateConstraint(markerNumbers=[coord(ground, 0),
                                                              coord(cart_node, c)]))
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[
            mbs.AddMarker(MarkerBodyRigid(bodyNumber=cart, localPosition=[0.0, 0.0, 0.0])),
            mbs.AddMarker(MarkerBodyRigid(bodyNumber=hub, localPosition=[-centre, 0.0,
                                                                         0.0]))]))
    turn = _Moment(moment, dt)
    mbs.AddLoad(LoadCoordinate(markerNumber=coord(hub_node, 2), load=0.0,
                               loadUserFunction=turn))
    u = np.array([math.cos(axis), math.sin(axis)])
    root = np.array([link_length, 0.0]) + s0 * u
    chain = beam_nodes(mbs, beam, np.linspace(0.0, beam.length, elements + 1), root, gamma)
    on_link = mbs.AddMarker(MarkerBodyRigid(bodyNumber=hub, localPosition=[
        link_length - centre, 0.0, 0.0]))
    add_slider(mbs, on_link, point_mass(mbs, chain[0], block), axis, gamma, force, dt)

    def sensor(node: int, kind: Any) -> int:
        return mbs.AddSensor(SensorNode(nodeNumber=node, storeInternal=True, writeToFile=False,
                                        outputVariableType=kind))

    s_hub = sensor(hub_node, exu.OutputVariableType.Coordinates)
    s_root = sensor(chain[0], exu.OutputVariableType.Coordinates)
    s_tip = sensor(chain[-1], exu.OutputVariableType.Coordinates)
    v_hub = sensor(hub_node, exu.OutputVariableType.Coordinates_t)
    v_root = sensor(chain[0], exu.OutputVariableType.Coordinates_t)
    cpu = time.process_time()
    wall, t_grid = solve_dynamic(exu, mbs, t_end, dt, dt_out, 1e-6, 1e-8, 1.0, verbose=VERBOSE)
    cpu = time.process_time() - cpu

    def series(number: int, node: int | None) -> np.ndarray:
        data = np.asarray(mbs.GetSensorStoredData(number))
        out = np.stack([np.interp(t_grid, data[:, 0], data[:, c]) for c in range(1, 4)], 1)
        if node is None:  # rates: no reference part
            return out
        return out + np.asarray(mbs.GetNodeParameter(node, "referenceCoordinates"))[None, :]

    hub_q, r0, r1 = series(s_hub, hub_node), series(s_root, chain[0]), series(s_tip, chain[-1])
    angle = hub_q[:, 2]
    pin = hub_q[:, :2] - centre * np.stack([np.cos(angle), np.sin(angle)], 1)
    tip_point = pin + link_length * np.stack([np.cos(angle), np.sin(angle)], 1)
    line = np.stack([np.cos(angle + axis), np.sin(angle + axis)], 1)
    normal_root = np.stack([-np.sin(r0[:, 2]), np.cos(r0[:, 2])], 1)
    hub_v, root_velocity = series(v_hub, None), series(v_root, None)[:, :2]
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
