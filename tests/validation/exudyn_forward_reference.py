"""A geometrically exact reference for flexlink's *forward* dynamics (driven hubs), in Exudyn.

The same beams as tests/validation/exudyn_reference.py — each appendage a chain of Exudyn
``ObjectBeamGeometricallyExact2D`` (Simo–Reissner) elements on ``NodeRigidBody2D`` nodes — but
nothing is prescribed: a rigid hub (``ObjectRigidBody2D`` on its own ``NodeRigidBody2D`` at the
hub's centre) carries the appendages and a moment history M(t) turns it.

* hub: pinned (its centre held at the origin by two ``CoordinateConstraint`` on x, y) or free
  in the plane; the moment is a ``LoadCoordinate`` on the hub's angle coordinate with a user
  function (the generalised force of the rotation coordinate *is* the moment, exactly);
* clamp of appendage k at the hub-frame point p_k, pointing along the hub-frame angle α_k:
  a ``RevoluteJoint2D`` between the hub point p_k (``MarkerBodyPosition``) and the beam's root
  node (``MarkerNodePosition``) plus a ``CoordinateConstraint`` ψ_root − θ_hub = 0 on the
  angle displacements: position and slope of the root follow the hub exactly (any rotation).

* elastic joint (``rotor``): a second pinned rigid body on its own node, the motor's rotor
  reflected through the gear (angle θ_m/N, inertia N² J_m), coupled to the hub's angle by a
  ``CoordinateSpringDamper`` (k, c); the moment then turns the rotor (N τ_m), not the hub.

A cart (``rail = True``): the hub slides along the global X axis, its y and angle held by
``CoordinateConstraint`` to the ground, and the history drives its x coordinate (a force
along the rail, N) instead of its angle.

Signals, from nodal coordinates (``SensorNode``): the hub angle θ, its rate and centre; per
appendage ``tip_deflection`` = n_root · (r_tip − r_root) (transverse deflection in the clamped
root frame, as flexlink's ``deflection`` sensor at x = L) and the tip position. Undamped, no
gravity. ``hub_beam_eigenfrequencies`` gives the linearised frequencies of the same model
(Exudyn's constrained eigenvalue solver), checked against tests/validation/hub_beam.py.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from flexlink.model import Link

from .exudyn_pieces import (
    BeamSection,
    coord,
    fix,
    integration_step,
    load_history,
    new_system,
    node_sensor,
    node_series,
    solve_dynamic,
    uniform_beam,
)


@dataclass(frozen=True)
class Appendage:
    """A flexible link clamped to the hub at ``point`` (m, hub frame) along ``angle`` (rad,
    hub frame); ``section``: EA, GA, ρI (default: default_section(link) or from ``EA``)."""

    link: Link
    point: tuple[float, float] = (0.0, 0.0)
    angle: float = 0.0
    section: BeamSection | None = None


def _build(appendages: Sequence[Appendage], hub_mass: float, hub_inertia: float, pinned: bool,
           elements: int, moment: Callable[[float], float] | None, dt: float = 0.0,
           gravity: tuple[float, float] = (0.0, 0.0),
           rotor: tuple[float, float, float] | None = None, rail: bool = False
           ) -> dict[str, Any]:
    """The Exudyn system (not assembled); returns mbs, the container and the node numbers.
    ``rail``: a cart on a rail along X driven by the history as a force (module doc).
    ``gravity`` (m/s²): the weights as nodal forces, each element's half on each of its
    nodes, the tip masses' on the tip node and (free hub) the hub's on the hub. ``rotor``:
    (reflected inertia N² J_m kg·m², stiffness N·m/rad, damping N·m·s/rad) of an elastic
    joint between a pinned rotor, which the moment turns, and the hub."""
    from exudyn.itemInterface import (
        CoordinateConstraint,
        CoordinateSpringDamper,
        LoadForceVector,
        MarkerBodyPosition,
        MarkerNodePosition,
        NodeRigidBody2D,
        ObjectRigidBody2D,
        RevoluteJoint2D,
    )

    SC, mbs, m_ground = new_system()
    hub_node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
    # A pinned hub's mass does nothing but must not make the mass matrix singular.
    hub = mbs.AddObject(ObjectRigidBody2D(nodeNumber=hub_node, mass=hub_mass if hub_mass > 0
                                          else 1.0, inertia=hub_inertia))
    if any(gravity) and not pinned and hub_mass > 0.0:
        mbs.AddLoad(LoadForceVector(
            markerNumber=mbs.AddMarker(MarkerNodePosition(nodeNumber=hub_node)),
            loadVector=[hub_mass * gravity[0], hub_mass * gravity[1], 0.0]))
    if pinned:
        fix(mbs, m_ground, hub_node)
    m_hub_angle = coord(mbs, hub_node, 2)
    m_driven, rotor_node = m_hub_angle, None
    if rotor is not None:
        rotor_node = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, 0.0]))
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=rotor_node, mass=1.0, inertia=rotor[0]))
        fix(mbs, m_ground, rotor_node)
        m_driven = coord(mbs, rotor_node, 2)
        mbs.AddObject(CoordinateSpringDamper(markerNumbers=[m_hub_angle, m_driven],
                                             stiffness=rotor[1], damping=rotor[2]))
    if rail:
        fix(mbs, m_ground, hub_node, (1, 2))
    keep: list[Any] = []
    if moment is not None:
        driven = coord(mbs, hub_node, 0) if rail else m_driven
        keep.append(load_history(mbs, driven, moment, dt))
    nodes: list[list[int]] = []
    for app in appendages:
        link = app.link
        chain = uniform_beam(mbs, link, elements, np.asarray(app.point, dtype=float),
                             app.angle, app.section)
        if any(gravity):
            element = link.mass_per_length * link.length / elements
            for i, node in enumerate(chain):
                mass = element * (0.5 if i in (0, elements) else 1.0)
                mass += link.tip_mass if i == elements else 0.0
                mbs.AddLoad(LoadForceVector(
                    markerNumber=mbs.AddMarker(MarkerNodePosition(nodeNumber=node)),
                    loadVector=[mass * gravity[0], mass * gravity[1], 0.0]))
        # the clamp: root position on the hub point, root section turning with the hub
        m_point = mbs.AddMarker(MarkerBodyPosition(bodyNumber=hub,
                                                   localPosition=[*app.point, 0.0]))
        mbs.AddObject(RevoluteJoint2D(markerNumbers=[
            m_point, mbs.AddMarker(MarkerNodePosition(nodeNumber=chain[0]))]))
        mbs.AddObject(CoordinateConstraint(markerNumbers=[m_hub_angle, coord(mbs, chain[0], 2)]))
        nodes.append(chain)
    return {"SC": SC, "mbs": mbs, "hub_node": hub_node, "nodes": nodes, "keep": keep,
            "rotor_node": rotor_node}


def hub_beam_eigenfrequencies(link: Link, radius: float, hub_inertia: float, elements: int,
                              count: int, section: BeamSection | None = None,
                              rotor: tuple[float, float, float] | None = None) -> np.ndarray:
    """The first ``count`` non-zero natural frequencies (rad/s) of the pinned hub with one
    beam clamped at ``radius`` (m), linearised about the undeformed state by Exudyn;
    ``rotor``: the hub on an elastic joint (`_build`)."""
    built = _build([Appendage(link, (radius, 0.0), 0.0, section)], 0.0, hub_inertia, True,
                   elements, None, rotor=rotor)
    mbs = built["mbs"]
    mbs.Assemble()
    values, _ = mbs.ComputeODE2Eigenvalues()
    omega = np.sqrt(np.sort(np.abs(np.asarray(values))))
    flexible = omega[omega > 1e-6 * omega.max()]
    # the rigid rotation of the hub leaves one (numerically) zero eigenvalue
    return flexible[:count]


def simulate_hub_exudyn(
    appendages: Sequence[Appendage],
    hub_inertia: float,
    moment: Callable[[float], float],
    t_end: float,
    dt_out: float,
    elements: int,
    *,
    pinned: bool = True,
    hub_mass: float = 0.0,
    dt: float | None = None,
    spectral_radius: float = 1.0,
    newton_abs_tol: float = 1e-6,
    newton_rel_tol: float = 1e-8,
    gravity: tuple[float, float] = (0.0, 0.0),
    rotor: tuple[float, float, float] | None = None,
    rail: bool = False,
) -> dict[str, Any]:
    """A hub turned by the moment M(t) (N·m, about its centre), its appendages free to bend.

    elements: elements per appendage (uniform); dt: generalized-α step (default dt_out, at
    most 5e-4 s; it must divide dt_out — put bang-bang switches on the step grid);
    spectral_radius: ρ∞ (1 = no numerical dissipation); gravity: uniform field (m/s²,
    lumped nodal weights); rotor: an elastic joint's reflected rotor, spring and damper
    (`_build`; adds ``rotor_angle``, rad, θ_m/N); rail: a cart on a rail along X, ``moment``
    then the force along it (N), ``hub_mass`` its mass. Starts at rest, undeformed.

    Returns ``t`` (s); ``hub_angle`` (rad), ``hub_rate`` (rad/s), ``hub_position`` (n×2, m);
    per appendage (lists) ``tip_deflection`` (m, clamped root frame) and ``tip_position``
    (n×2, m, inertial); ``wall_time_s`` (solver only), ``coordinates``, ``dt``.
    """
    import exudyn as exu

    dt = integration_step(dt_out, dt)
    built = _build(appendages, hub_mass, hub_inertia, pinned and not rail, elements, moment,
                   dt, gravity, rotor=rotor, rail=rail)
    mbs, nodes = built["mbs"], built["nodes"]

    hub_pos = node_sensor(mbs, built["hub_node"], exu.OutputVariableType.Coordinates)
    hub_vel = node_sensor(mbs, built["hub_node"], exu.OutputVariableType.Coordinates_t)
    rotor_node = built["rotor_node"]
    rotor_pos = (node_sensor(mbs, rotor_node, exu.OutputVariableType.Coordinates)
                 if rotor_node is not None else None)
    ends = [(node_sensor(mbs, c[0], exu.OutputVariableType.Coordinates),
             node_sensor(mbs, c[-1], exu.OutputVariableType.Coordinates)) for c in nodes]
    wall, t_grid = solve_dynamic(exu, mbs, t_end, dt, dt_out, newton_abs_tol, newton_rel_tol,
                                 spectral_radius)

    hub = node_series(mbs, hub_pos, t_grid, built["hub_node"])
    result: dict[str, Any] = {"t": t_grid, "hub_angle": hub[:, 2],
                              "hub_rate": node_series(mbs, hub_vel, t_grid)[:, 2],
                              "hub_position": hub[:, :2], "tip_deflection": [],
                              "tip_position": []}
    for chain, (s0, s1) in zip(nodes, ends):
        r0, r1 = node_series(mbs, s0, t_grid, chain[0]), node_series(mbs, s1, t_grid, chain[-1])
        normal = np.stack([-np.sin(r0[:, 2]), np.cos(r0[:, 2])], axis=1)
        result["tip_deflection"].append(np.sum(normal * (r1[:, :2] - r0[:, :2]), axis=1))
        result["tip_position"].append(r1[:, :2])
    if rotor_pos is not None:
        result["rotor_angle"] = node_series(mbs, rotor_pos, t_grid, rotor_node)[:, 2]
    result.update(wall_time_s=wall, coordinates=mbs.systemData.ODE2Size(), dt=dt)
    return result
