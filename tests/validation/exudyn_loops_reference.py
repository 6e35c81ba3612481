"""A geometrically exact reference for closed loops in Exudyn: the slider-crank with a
prescribed crank and an elastic connecting rod (Simo–Reissner beams,
``ObjectBeamGeometricallyExact2D`` on ``NodeRigidBody2D`` nodes, as
tests/validation/exudyn_reference.py).

The crank is one element of stiffness ``STIFF`` times the rod's, its root node held at the
origin and turned by the prescribed angle (a ``CoordinateConstraint`` with offset user
functions); the rod's root node shares the crank tip's position (two coordinate constraints,
its rotation free: the crank pin), its tip node stays on the X axis (the piston: one
coordinate constraint) and carries the piston's mass. Starts undeformed in the closed
rigid configuration, the bars turning with the crank's rate at t = 0 (at rest when it is
zero) and the rod, if asked, with a transverse velocity of sine shapes. Output: the rod's midpoint deflection from its chord,
n_chord · (r_mid − (r_root + r_tip)/2), the piston's X and the crank angle."""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from flexlink.model import JointMotion, Link

from .exudyn_pieces import (
    coord,
    coupler_and_rocker,
    default_section,
    fix,
    new_system,
    node_sensor,
    node_series,
    pin,
    solve_dynamic,
    uniform_beam,
)
from .exudyn_reference import _Memo

STIFF = 1e3  # the crank's bending and axial stiffness, times the rod's: rigid
CRANK_ELEMENTS = 4


def simulate_slider_crank_exudyn(crank: float, rod: Link, motion: JointMotion, EA: float,
                                 t_end: float, dt_out: float, elements: int = 16,
                                 dt: float = 5e-5, newton_rel_tol: float = 1e-8,
                                 sine_rates: Sequence[float] = ()) -> dict[str, Any]:
    """``crank`` (m) turned by ``motion`` (its angle from the X axis); ``rod``: the elastic
    connecting rod (its tip mass: the piston); EA (N) the rod's axial stiffness (Exudyn's
    beams stretch). At t = 0 the bars move rigidly with the crank's rate (the rod's rate
    closes the loop) plus, across the rod's chord, Σ sine_rates[i-1] sin(iπx/L) (m/s).
    Returns t, mid_deflection (m), piston_x (m), crank_angle (rad)."""
    import exudyn as exu
    from exudyn.itemInterface import (
        CoordinateConstraint,
        NodeRigidBody2D,
        ObjectBeamGeometricallyExact2D,
        ObjectRigidBody2D,
    )

    if elements % 2:
        raise ValueError("an even number of elements: the midpoint is a node")
    theta0, omega0 = (float(v) for v in motion.evaluate(np.asarray(0.0))[:2])
    phi0 = -math.asin(crank * math.sin(theta0) / rod.length)
    phi_rate = -crank * math.cos(theta0) * omega0 / (rod.length * math.cos(phi0))
    _container, mbs, m_ground = new_system()
    sec = default_section(rod, EA)
    crank_tip = crank * np.array([math.cos(theta0), math.sin(theta0)])
    pin_rate = omega0 * np.array([-crank_tip[1], crank_tip[0]])
    c0 = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[0.0, 0.0, theta0],
                                     initialVelocities=[0.0, 0.0, omega0]))
    c1 = mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[crank_tip[0], crank_tip[1], theta0],
                                     initialVelocities=[*pin_rate, omega0]))
    mbs.AddObject(ObjectBeamGeometricallyExact2D(
        nodeNumbers=[c0, c1], length=crank, massPerLength=rod.mass_per_length,
        crossSectionInertia=sec.rhoI, bendingStiffness=STIFF * rod.EI,
        axialStiffness=STIFF * EA, shearStiffness=STIFF * sec.GA))
    keep = [_Memo(motion, 0, theta0), _Memo(motion, 1, 0.0)]
    fix(mbs, m_ground, c0)
    mbs.AddObject(CoordinateConstraint(markerNumbers=[m_ground, coord(mbs, c0, 2)],
                                       offsetUserFunction=keep[0], offsetUserFunction_t=keep[1]))
    e = np.array([math.cos(phi0), math.sin(phi0)])
    x = np.linspace(0.0, rod.length, elements + 1)
    n = np.array([-e[1], e[0]])
    nodes = []
    for xi in x:
        k = np.arange(1, len(sine_rates) + 1) * math.pi / rod.length
        across = float(np.dot(sine_rates, np.sin(k * xi)))
        turn = float(np.dot(sine_rates, k * np.cos(k * xi)))
        v = pin_rate + (phi_rate * xi + across) * n
        nodes.append(mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[*(crank_tip + xi * e), phi0],
                                                 initialVelocities=[*v, phi_rate + turn])))
    for a, b in itertools.pairwise(nodes):
        mbs.AddObject(ObjectBeamGeometricallyExact2D(
            nodeNumbers=[a, b], length=float(rod.length / elements),
            massPerLength=rod.mass_per_length, crossSectionInertia=sec.rhoI,
            bendingStiffness=rod.EI, axialStiffness=EA, shearStiffness=sec.GA))
    pin(mbs, c1, nodes[0])  # the crank pin
    fix(mbs, m_ground, nodes[-1], (1,))
    if rod.tip_mass > 0.0:  # the piston: a point mass (a vanishing rotary inertia)
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=nodes[-1], mass=rod.tip_mass,
                                        inertia=1e-9))
    watched = (c0, nodes[0], nodes[elements // 2], nodes[-1])
    sensors = [node_sensor(mbs, n) for n in watched]
    wall, t = solve_dynamic(exu, mbs, t_end, dt, dt_out, 1e-5, newton_rel_tol, 1.0)
    crank_c, root, mid, tip = (node_series(mbs, s, t, n) for s, n in zip(sensors, watched))
    return {"t": t, "mid_deflection": _chord_deflection(root, mid, tip), "piston_x": tip[:, 0],
            "crank_angle": crank_c[:, 2], "wall_time_s": wall, "keep": keep}


def simulate_four_bar_exudyn(crank: float, coupler: Link, rocker: Link,
                             pivot: tuple[float, float], motion: JointMotion,
                             angles: tuple[float, float, float], EA: float, t_end: float,
                             dt_out: float, elements: int = 16, dt: float = 5e-5,
                             newton_rel_tol: float = 1e-8, crank_spring: float = 0.0,
                             crank_mass_per_length: float | None = None,
                             crank_tip_mass: float = 0.0, crank_EI: float = math.inf,
                             crank_EA: float | None = None) -> dict[str, Any]:
    """A four-bar: the crank (one element, ``STIFF`` times the coupler's stiffness) turned by
    ``motion`` about the origin, the elastic coupler pinned to its tip, the rocker (elastic
    beams of its own EI; ``EA`` for both) pinned to the ground at ``pivot`` and to the
    coupler's tip. ``angles``: the absolute angles (rad) of crank, coupler and rocker that
    close the loop at t = 0 (at rest, undeformed). ``crank_spring`` (N·m/rad): the crank
    turned through a torsional spring instead (an elastic joint: ``motion`` the motor's
    angle over the gear ratio), its root's rotation free; ``crank_mass_per_length``
    (kg/m, default the coupler's) the crank's, whose inertia the spring then feels;
    ``crank_tip_mass`` (kg) a point mass on the crank's tip node (the crank pin's);
    ``crank_EI`` (N·m², default rigid) and ``crank_EA`` (N, default ``EA``): a flexible crank,
    ``elements`` elements clamped to its turned root section. Returns
    t, mid_deflection (the coupler's midpoint from its chord, m), rocker_angle (rad, of the
    rocker's chord), crank_angle (rad, of the crank's root section); with a flexible rocker
    also rocker_mid_deflection (m, likewise); mid_curvature and rocker_mid_curvature (1/m):
    the midpoint's curvature, the central difference of the section angles of the nodes
    beside it (second order in the element length)."""
    import exudyn as exu
    from exudyn.itemInterface import CoordinateConstraint

    if elements % 2:
        raise ValueError("an even number of elements: the midpoint is a node")
    theta0 = float(motion.evaluate(np.asarray(0.0))[0])
    _container, mbs, m_ground = new_system()
    flexible_crank = math.isfinite(crank_EI)
    crank_link = Link("crank", crank, crank_mass_per_length or coupler.mass_per_length,
                      crank_EI if flexible_crank else coupler.EI, tip_mass=crank_tip_mass)
    # a turning crank's inertia is felt through a spring: elements enough for its mass's
    # distribution (one element lumps it at the ends)
    crank_section = default_section(crank_link, (crank_EA or EA) if flexible_crank else EA)
    cn = uniform_beam(mbs, crank_link,
                      elements if flexible_crank else
                      CRANK_ELEMENTS if crank_spring > 0.0 else 1,
                      np.zeros(2), theta0, crank_section, 1.0 if flexible_crank else STIFF)
    fix(mbs, m_ground, cn[0])
    keep = [_Memo(motion, 0, theta0), _Memo(motion, 1, 0.0)]
    if crank_spring > 0.0:
        from exudyn.itemInterface import CoordinateSpringDamper

        def spring(mbs: Any, t: float, item: int, u: float, v: float, k: float, d: float,
                   offset: float) -> float:  # k (β − θ_m/N) on the root's rotation
            return k * (u - keep[0](mbs, t, item, 0.0)) + d * (v - keep[1](mbs, t, item, 0.0))

        mbs.AddObject(CoordinateSpringDamper(markerNumbers=[m_ground, coord(mbs, cn[0], 2)],
                                             stiffness=crank_spring,
                                             springForceUserFunction=spring))
    else:
        mbs.AddObject(CoordinateConstraint(markerNumbers=[m_ground, coord(mbs, cn[0], 2)],
                                           offsetUserFunction=keep[0],
                                           offsetUserFunction_t=keep[1]))
    kn, rn = coupler_and_rocker(mbs, m_ground, cn[-1],
                                crank * np.array([math.cos(theta0), math.sin(theta0)]), coupler,
                                rocker, pivot, angles[1:], EA, elements, STIFF)
    h = elements // 2
    flexible_rocker = len(rn) > 3
    watched = [kn[0], kn[h], kn[-1], rn[0], rn[-1], cn[0], kn[h - 1], kn[h + 1]]
    if flexible_rocker:
        watched += [rn[h - 1], rn[h], rn[h + 1]]
    sensors = [node_sensor(mbs, n) for n in watched]
    wall, t = solve_dynamic(exu, mbs, t_end, dt, dt_out, 1e-5, newton_rel_tol, 1.0)
    series = [node_series(mbs, s, t, n) for s, n in zip(sensors, watched)]
    root, mid, end, r0, r1, c0 = series[:6]
    arm = r1[:, :2] - r0[:, :2]
    out = {"t": t, "mid_deflection": _chord_deflection(root, mid, end),
           "mid_curvature": _curvature(series[6], series[7], coupler.length / elements),
           "rocker_angle": np.unwrap(np.arctan2(arm[:, 1], arm[:, 0])), "wall_time_s": wall,
           "crank_angle": c0[:, 2], "keep": keep}
    if flexible_rocker:
        out["rocker_mid_deflection"] = _chord_deflection(r0, series[9], r1)
        out["rocker_mid_curvature"] = _curvature(series[8], series[10],
                                                 rocker.length / elements)
    return out


def _chord_deflection(root: np.ndarray, mid: np.ndarray, end: np.ndarray) -> np.ndarray:
    """The midpoint's distance (m) from the chord root–end, along the chord's normal (the
    chord turned +90°); rows of node series (x, y, angle)."""
    chord = end[:, :2] - root[:, :2]
    normal = np.stack([-chord[:, 1], chord[:, 0]], 1) / np.linalg.norm(chord, axis=1)[:, None]
    return np.sum(normal * (mid[:, :2] - 0.5 * (root[:, :2] + end[:, :2])), 1)


def _curvature(before: np.ndarray, after: np.ndarray, h: float) -> np.ndarray:
    """The curvature (1/m) between two nodes 2h apart: the difference of their section
    angles over 2h."""
    return (after[:, 2] - before[:, 2]) / (2.0 * h)
