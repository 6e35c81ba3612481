"""Natural frequencies of a chain with locked joints from a geometrically exact FE model (Exudyn).

Each link is a chain of ``ObjectBeamGeometricallyExact2D`` elements (Simo–Reissner, as in
exudyn_reference.py, with its sections: EA from the rectangular section, shear GA, and the
section's rotary inertia ρI = ρA·h²/12 that flexlink's Euler–Bernoulli links leave out: the FE
mass matrix needs it, and it lowers the frequencies by ~(h/L)²(βL)²/24, below 1e-5 for the
paper's arm's lower modes). Link 1's
root node is clamped to the ground; link k's root node sits on link k−1's tip node (two
position constraints) with its section angle locked at β_k from the tip section (one
coordinate constraint on the angle increments). Tip masses and rotary inertias are
``ObjectRigidBody2D`` on the tip node. ``mbs.ComputeODE2Eigenvalues`` projects the mass and
stiffness matrices on the null space of the constraint Jacobian (SVD) at the undeformed rest
configuration and returns ω² of the constrained system.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np

from flexlink.model import Link
from tests.validation.exudyn_reference import default_section


def locked_chain_frequencies(links: Sequence[Link], angles: Sequence[float], elements: int,
                             count: int) -> np.ndarray:
    """The lowest ``count`` natural frequencies (Hz) of the chain clamped at the hub with
    joint k locked at angles[k] (rad), ``elements`` per link."""
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

    root = np.zeros(2)
    theta = 0.0
    previous_tip = None
    for link, beta in zip(links, angles):
        theta += beta
        sec = default_section(link)
        e = np.array([math.cos(theta), math.sin(theta)])
        x = np.linspace(0.0, link.length, elements + 1)
        nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[*(root + xi * e), theta]))
                 for xi in x]
        for a, b in itertools.pairwise(nodes):
            mbs.AddObject(ObjectBeamGeometricallyExact2D(
                nodeNumbers=[a, b], length=float(x[1] - x[0]),
                massPerLength=link.mass_per_length, crossSectionInertia=sec.rhoI,
                bendingStiffness=link.EI, axialStiffness=sec.EA, shearStiffness=sec.GA))
        if link.tip_mass > 0.0 or link.tip_inertia > 0.0:
            mbs.AddObject(ObjectRigidBody2D(nodeNumber=nodes[-1], mass=link.tip_mass,
                                            inertia=link.tip_inertia))
        for c in range(3):  # coordinates are increments from the reference: lock them
            if previous_tip is None:
                markers = [m_ground, coord(nodes[0], c)]
            else:
                markers = [coord(previous_tip, c), coord(nodes[0], c)]
            mbs.AddObject(CoordinateConstraint(markerNumbers=markers))
        previous_tip = nodes[-1]
        root = root + link.length * e
    mbs.Assemble()
    values, _ = mbs.ComputeODE2Eigenvalues(ignoreAlgebraicEquations=False,
                                          useAbsoluteValues=True)
    omega2 = np.sort(np.asarray(values))
    omega2 = omega2[omega2 > (2 * np.pi * 1e-3) ** 2]  # no rigid modes: drop round-off zeros
    return np.sqrt(omega2[:count]) / (2 * np.pi)
