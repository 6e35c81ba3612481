"""Natural frequencies of a four-bar at rest from a geometrically exact FE model (Exudyn):
Simo–Reissner beams (``ObjectBeamGeometricallyExact2D``, the sections of exudyn_reference.py)
along each link, the pins as equal node translations, the ground pivots' translations fixed
(and, for a held crank, its rotation), a body on the coupler's tip as ``ObjectRigidBody2D``.
``mbs.ComputeODE2Eigenvalues`` projects mass and stiffness on the null space of the
constraints' Jacobian at the undeformed configuration."""

from __future__ import annotations

import itertools
import math

import numpy as np

from flexlink.model import Link
from tests.validation.exudyn_reference import default_section

STIFF = 1e4  # a rigid link: beams this many times stiffer than the coupler


def four_bar_frequencies_exudyn(crank: float, coupler: Link, rocker: Link,
                                pivot: tuple[float, float], angles: tuple[float, float, float],
                                EA: float, elements: int, count: int, held_crank: bool = True
                                ) -> np.ndarray:
    """The lowest ``count`` frequencies above 5 Hz (Hz): crank (rigid, length m, the coupler's
    mass per length unless a rigid rocker's) from the origin, ``coupler`` from its tip,
    ``rocker`` (EI = inf: rigid) from ``pivot``, at the absolute angles (rad) that close the
    loop; EA (N) the beams' axial stiffness; the coupler's tip body from its tip_mass and
    tip_inertia."""
    import exudyn as exu
    from exudyn.itemInterface import (
        CoordinateConstraint,
        MarkerNodeCoordinate,
        NodePointGround,
        NodeRigidBody2D,
        ObjectBeamGeometricallyExact2D,
        ObjectRigidBody2D,
    )

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddNode(NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    m_ground = mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=ground, coordinate=0))

    def coord(node: int, c: int) -> int:
        return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=c))

    def beam(start: np.ndarray, angle: float, link: Link, n: int, stiff: float) -> list[int]:
        sec = default_section(link, EA)
        e = np.array([math.cos(angle), math.sin(angle)])
        x = np.linspace(0.0, link.length, n + 1)
        nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[*(start + xi * e), angle]))
                 for xi in x]
        for a, b in itertools.pairwise(nodes):
            mbs.AddObject(ObjectBeamGeometricallyExact2D(
                nodeNumbers=[a, b], length=float(link.length / n),
                massPerLength=link.mass_per_length, crossSectionInertia=sec.rhoI,
                bendingStiffness=stiff * link.EI, axialStiffness=stiff * EA,
                shearStiffness=stiff * sec.GA))
        return nodes

    def fix(node: int, cs: tuple[int, ...]) -> None:
        for c in cs:
            mbs.AddObject(CoordinateConstraint(markerNumbers=[m_ground, coord(node, c)]))

    def pin(a: int, b: int) -> None:
        for c in (0, 1):
            mbs.AddObject(CoordinateConstraint(markerNumbers=[coord(a, c), coord(b, c)]))

    crank_link = Link("crank", crank, rocker.mass_per_length, coupler.EI)
    cn = beam(np.zeros(2), angles[0], crank_link, 2, STIFF)
    fix(cn[0], (0, 1, 2) if held_crank else (0, 1))
    tip = crank * np.array([math.cos(angles[0]), math.sin(angles[0])])
    kn = beam(tip, angles[1], coupler, elements, 1.0)
    pin(cn[-1], kn[0])
    rigid_rocker = not math.isfinite(rocker.EI)
    rocker_beam = Link("rocker", rocker.length, rocker.mass_per_length,
                       coupler.EI if rigid_rocker else rocker.EI)
    rn = beam(np.asarray(pivot, dtype=float), angles[2], rocker_beam,
              2 if rigid_rocker else elements, STIFF if rigid_rocker else 1.0)
    fix(rn[0], (0, 1))
    pin(kn[-1], rn[-1])
    if coupler.tip_mass > 0.0 or coupler.tip_inertia > 0.0:
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=kn[-1], mass=coupler.tip_mass,
                                        inertia=coupler.tip_inertia))
    mbs.Assemble()
    values, _ = mbs.ComputeODE2Eigenvalues(ignoreAlgebraicEquations=False,
                                          useAbsoluteValues=True)
    omega2 = np.sort(np.asarray(values))
    # a free crank's mechanism motion comes out below 1 Hz here, not at zero: left out
    omega2 = omega2[omega2 > (2 * np.pi * 5.0) ** 2]
    return np.sqrt(omega2[:count]) / (2 * np.pi)
