"""An independent, geometrically exact reference for flexlink, built with Exudyn.

Each link is a chain of Exudyn ``ObjectBeamGeometricallyExact2D`` elements (2-node Simo–Reissner
beams on ``NodeRigidBody2D`` nodes: x, y and the cross-section angle ψ per node; exact strain
measures, no small-deflection assumption anywhere). The joint angles are prescribed through
*linear* coordinate constraints on the nodal angles:

* hub (joint 1): the root node of link 1 is held at the origin (x = y = 0) and its section angle
  follows ψ = β₁(t) — a ``CoordinateConstraint`` between a ground coordinate and the node's
  angle with an ``offsetUserFunction`` that calls the flexlink motion object;
* joint k > 1: the root node of link k sits on the tip node of link k−1 (two position
  constraints) and ψ_root,k − ψ_tip,k−1 = β_k(t), again one ``CoordinateConstraint`` with an
  offset user function. The tip *section* of link k−1 is its deformed tip tangent up to the
  (negligible, ~1e-7) shear angle, so link k is clamped to link k−1's deformed tip turned by β_k,
  exactly the flexlink convention.

Tip point masses and rotary inertias, and every body of ``Link.bodies`` without offset, are
``ObjectRigidBody2D`` objects sharing their section's node; a body with an offset centre is an
``ObjectRigidBody2D`` on a node of its own, held rigidly to the section (`_add_body`).
There is no gravity and no damping (flexlink must be run with damping_ratio = 0).

How the signals are extracted (all from nodal coordinates and accelerations, ``SensorNode``):

* ``tip_deflection[k]`` = n_root · (r_tip − r_root), n_root = (−sin ψ_root, cos ψ_root):
  the component of the tip position perpendicular to the clamped root tangent, i.e. the transverse
  deflection w(L) in link k's clamped frame (exact kinematics: r = R + A(θ+θ1)[x + u_x, w]ᵀ);
* ``tip_acceleration_normal[k]`` = n_tip · a_tip, a_tip the absolute acceleration of the tip node
  (Exudyn's ``Coordinates_tt``, the accelerations of the generalized-α solution — no finite
  differences), n_tip the normal of the deformed tip section;
* ``slope[k][x]`` = ψ(x) − ψ_root: section rotation at x relative to the clamped root. Every
  requested x becomes a mesh node, so this is a nodal value, not an interpolation;
* ``tip_axial[k]`` = t_root · (r_tip − r_root) − L (foreshortening + stretch), ``tip_position[k]``
  (global X, Y), ``root_angle[k]`` (ψ_root), ``joint_angle[k]`` (the realised β_k).

docs/exudyn_reference.md describes the model, its convergence and the comparison with flexlink.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from flexlink.model import JointMotion, Link

from .exudyn_pieces import (
    BeamSection,
    coord,
    default_section,
    fix,
    integration_step,
    new_system,
    node_sensor,
    node_series,
    pin,
    solve_dynamic,
)


def _mesh(length: float, elements: int, extra: Sequence[float]) -> np.ndarray:
    """Uniform node positions plus the requested sensor positions (each becomes a node)."""
    x = np.linspace(0.0, length, elements + 1)
    for xs in extra:
        if not 0.0 <= xs <= length:
            raise ValueError(f"sensor position {xs} outside [0, {length}]")
    x = np.unique(np.concatenate([x, np.asarray(extra, dtype=float)]))
    keep = np.concatenate([[True], np.diff(x) > 1e-9 * length])
    return x[keep]


class _Memo:
    """β(t) for an Exudyn offset user function. Exudyn calls it several times per step (every
    Newton iteration, residual and Jacobian) with the same t: cache the last few values."""

    def __init__(self, motion: JointMotion, which: int, beta0: float) -> None:
        self.motion, self.which, self.beta0 = motion, which, beta0
        self.cache: dict[float, float] = {}

    def __call__(self, mbs: Any, t: float, item: int, offset: float) -> float:
        v = self.cache.get(t)
        if v is None:
            if len(self.cache) > 64:
                self.cache.clear()
            v = float(self.motion.evaluate(np.asarray(t))[self.which])
            if self.which == 0:
                v -= self.beta0
            self.cache[t] = v
        return v


def _add_body(mbs: Any, body: Any, node: int, point: np.ndarray, theta: float,
              velocity: np.ndarray, omega: float) -> None:
    """A rigid body (flexlink.model.Body) on the section node ``node`` at reference ``point``
    (m), angle ``theta`` (rad), moving rigidly with ``velocity`` (m/s) and ``omega`` (rad/s) at
    t = 0. Without offset an ``ObjectRigidBody2D`` sharing the node; with one, its own node at
    the centre, held by a ``RevoluteJoint2D`` at the section point and an angle constraint
    ψ_body = ψ_section (a rigid connection, exact for any rotation)."""
    from exudyn.itemInterface import (
        CoordinateConstraint,
        MarkerBodyPosition,
        MarkerNodeCoordinate,
        MarkerNodePosition,
        NodeRigidBody2D,
        ObjectRigidBody2D,
        RevoluteJoint2D,
    )

    c = np.asarray(body.offset, dtype=float)
    if not c.any():
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=body.mass, inertia=body.inertia))
        return
    turn = np.array([[math.cos(theta), -math.sin(theta)], [math.sin(theta), math.cos(theta)]])
    arm = turn @ c
    centre = point + arm
    v = velocity + omega * np.array([-arm[1], arm[0]])
    own = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[centre[0], centre[1], theta],
                                      initialVelocities=[v[0], v[1], omega]))
    rigid = mbs.AddObject(ObjectRigidBody2D(nodeNumber=own, mass=body.mass,
                                            inertia=body.inertia))
    mbs.AddObject(RevoluteJoint2D(markerNumbers=[
        mbs.AddMarker(MarkerBodyPosition(bodyNumber=rigid, localPosition=[-c[0], -c[1], 0.0])),
        mbs.AddMarker(MarkerNodePosition(nodeNumber=node))]))
    mbs.AddObject(CoordinateConstraint(markerNumbers=[
        mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=2)),
        mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=own, coordinate=2))]))


def simulate_chain_exudyn(
    links: Sequence[Link],
    joints: Sequence[JointMotion],
    t_end: float,
    dt_out: float,
    elements_per_link: int | Sequence[int],
    *,
    slope_positions: Mapping[int, Sequence[float]] | None = None,
    dt: float | None = None,
    sections: Sequence[BeamSection] | None = None,
    spectral_radius: float = 0.9,
    newton_abs_tol: float = 1e-6,
    newton_rel_tol: float = 1e-8,
    verbose: int = 0,
) -> dict[str, Any]:
    """Simulate a chain with prescribed joint angles in Exudyn; return time histories.

    links, joints: as for flexlink's Chain (damping_ratio is ignored: the reference is undamped).
    elements_per_link: uniform elements per link (sensor positions add nodes).
    slope_positions: {link index: [x, ...]} where ``slope[k][x]`` is wanted (0 and L always).
    dt: time step of the generalized-α integrator (default dt_out, at most 5e-4 s); it must
        divide dt_out. spectral_radius: ρ∞ of generalized-α (1 = no numerical dissipation).
    newton_abs_tol: Exudyn's absolute residual tolerance; the default 1e-10 is below round-off
        of the stiff axial terms and makes Newton fail and the step size collapse.

    Returns a dict with ``t`` and per link k (lists indexed by k): ``tip_deflection``,
    ``tip_acceleration_normal``, ``slope`` ({x: array}), ``tip_axial``, ``tip_position`` (n×2),
    ``root_angle``, ``joint_angle``; plus ``wall_time_s``, ``steps``, ``coordinates``,
    ``nodes_per_link``.
    """
    import exudyn as exu
    from exudyn.itemInterface import (
        CoordinateConstraint,
        NodeRigidBody2D,
        ObjectBeamGeometricallyExact2D,
    )

    n_links = len(links)
    if len(joints) != n_links or n_links == 0:
        raise ValueError("one joint per link, at least one link")
    if isinstance(elements_per_link, int):
        elements_per_link = [elements_per_link] * n_links
    if sections is None:
        sections = [default_section(link) for link in links]
    slope_positions = dict(slope_positions or {})
    dt = integration_step(dt_out, dt)

    beta0 = [float(j.evaluate(np.asarray(0.0))[0]) for j in joints]
    rate0 = [float(j.evaluate(np.asarray(0.0))[1]) for j in joints]

    _container, mbs, m_ground = new_system()
    user_functions = []  # keep references alive
    link_nodes: list[list[int]] = []
    link_x: list[np.ndarray] = []
    root = np.zeros(2)  # reference (undeformed, t = 0) position of the current joint
    theta = 0.0  # reference angle of the current link
    omega = 0.0  # rigid angular velocity at t = 0
    joint_pos: list[np.ndarray] = []  # reference joint positions, for initial velocities
    v_root = np.zeros(2)
    for k, (link, sec) in enumerate(zip(links, sections)):
        theta += beta0[k]
        omega += rate0[k]
        e = np.array([math.cos(theta), math.sin(theta)])
        x = _mesh(link.length, elements_per_link[k], list(slope_positions.get(k, ()))
                  + [b.at for b in link.all_bodies()])
        nodes = []
        for xi in x:
            p = root + xi * e
            v = v_root + omega * xi * np.array([-e[1], e[0]])
            nodes.append(mbs.AddNode(NodeRigidBody2D(
                referenceCoordinates=[p[0], p[1], theta],
                initialVelocities=[v[0], v[1], omega])))
        for a, b, la in zip(nodes[:-1], nodes[1:], np.diff(x)):
            mbs.AddObject(ObjectBeamGeometricallyExact2D(
                nodeNumbers=[a, b], length=float(la), massPerLength=link.mass_per_length,
                crossSectionInertia=sec.rhoI, bendingStiffness=link.EI, axialStiffness=sec.EA,
                shearStiffness=sec.GA))
        for body in link.all_bodies():
            _add_body(mbs, body, nodes[int(np.argmin(np.abs(x - body.at)))], root + body.at * e,
                      theta, v_root + omega * body.at * np.array([-e[1], e[0]]), omega)
        # joint k: position and angle constraints on the root node
        uf = _Memo(joints[k], 0, beta0[k])
        uf_t = _Memo(joints[k], 1, 0.0)
        user_functions += [uf, uf_t]
        if k == 0:
            fix(mbs, m_ground, nodes[0])
            held = m_ground
        else:
            prev = link_nodes[-1][-1]
            pin(mbs, prev, nodes[0])
            held = coord(mbs, prev, 2)
        mbs.AddObject(CoordinateConstraint(markerNumbers=[held, coord(mbs, nodes[0], 2)],
                                           offsetUserFunction=uf, offsetUserFunction_t=uf_t))
        link_nodes.append(nodes)
        link_x.append(x)
        joint_pos.append(root.copy())
        root = root + link.length * e
        v_root = v_root + omega * link.length * np.array([-e[1], e[0]])

    # sensors: coordinates (displacements + angle) of root, tip and slope nodes; tip accelerations
    pos_sensors: dict[tuple[int, int], int] = {}
    acc_sensors: dict[int, int] = {}
    for k, nodes in enumerate(link_nodes):
        wanted = {0, len(nodes) - 1}
        for xs in slope_positions.get(k, ()):
            wanted.add(int(np.argmin(np.abs(link_x[k] - xs))))
        for i in sorted(wanted):
            pos_sensors[(k, i)] = node_sensor(mbs, nodes[i])
        acc_sensors[k] = node_sensor(mbs, nodes[-1], exu.OutputVariableType.Coordinates_tt)

    wall, t_grid = solve_dynamic(exu, mbs, t_end, dt, dt_out, newton_abs_tol, newton_rel_tol,
                                 spectral_radius, verbose)

    def total(k: int, i: int) -> np.ndarray:
        return node_series(mbs, pos_sensors[(k, i)], t_grid, link_nodes[k][i])

    result: dict[str, Any] = {
        "t": t_grid, "tip_deflection": [], "tip_acceleration_normal": [], "slope": [],
        "tip_axial": [], "tip_position": [], "root_angle": [], "joint_angle": [],
    }
    prev_tip_angle = None
    for k, link in enumerate(links):
        last = len(link_nodes[k]) - 1
        r0, r1 = total(k, 0), total(k, last)
        psi0, psi1 = r0[:, 2], r1[:, 2]
        d = r1[:, :2] - r0[:, :2]
        n0 = np.stack([-np.sin(psi0), np.cos(psi0)], axis=1)
        t0 = np.stack([np.cos(psi0), np.sin(psi0)], axis=1)
        acc = node_series(mbs, acc_sensors[k], t_grid)
        n1 = np.stack([-np.sin(psi1), np.cos(psi1)], axis=1)
        slopes = {}
        for xs in slope_positions.get(k, ()):
            i = int(np.argmin(np.abs(link_x[k] - xs)))
            slopes[float(xs)] = total(k, i)[:, 2] - psi0
        slopes[float(link.length)] = psi1 - psi0
        result["tip_deflection"].append(np.sum(n0 * d, axis=1))
        result["tip_axial"].append(np.sum(t0 * d, axis=1) - link.length)
        result["tip_acceleration_normal"].append(np.sum(n1 * acc[:, :2], axis=1))
        result["slope"].append(slopes)
        result["tip_position"].append(r1[:, :2])
        result["root_angle"].append(psi0)
        result["joint_angle"].append(psi0 - (prev_tip_angle if prev_tip_angle is not None else 0.0))
        prev_tip_angle = psi1
    result["wall_time_s"] = wall
    result["steps"] = round(t_end / dt)
    result["dt"] = dt
    result["coordinates"] = mbs.systemData.ODE2Size()
    result["nodes_per_link"] = [len(n) for n in link_nodes]
    return result


# ---------------------------------------------------------------------------------------------
# Kane, Ryan & Banerjee (1987) spin-up beam

KRB_LENGTH = 10.0  # m
KRB_RHOA = 1.2  # kg/m
KRB_EI = 14_000.0  # N·m²
KRB_EA = 2.8e7  # N
KRB_T = 15.0  # s, spin-up time


def krb_link(modes: int = 6) -> Link:
    return Link("krb", KRB_LENGTH, KRB_RHOA, KRB_EI, modes=modes)


def krb_motion(omega: float) -> JointMotion:
    """The KRB spin-up to omega (rad/s) in 15 s, as a flexlink motion."""
    from flexlink.motion import Spinup

    return Spinup(math.degrees(omega), start=0.0, duration=KRB_T)


def simulate_krb_exudyn(omega: float, elements: int = 16, t_end: float = 20.0,
                        dt_out: float = 0.01, dt: float = 2e-3, **kw: Any) -> dict[str, Any]:
    """Tip deflection of the KRB beam in the rotating clamped frame (``tip_deflection[0]``)."""
    link = krb_link()
    section = default_section(link, EA=KRB_EA)
    return simulate_chain_exudyn([link], [krb_motion(omega)], t_end, dt_out, elements, dt=dt,
                                 sections=[section], **kw)
