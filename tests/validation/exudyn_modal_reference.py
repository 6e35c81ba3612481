"""Natural frequencies of a chain with locked joints from a geometrically exact FE model (Exudyn).

Each link is a chain of ``ObjectBeamGeometricallyExact2D`` elements (Simo–Reissner, as in
exudyn_reference.py, with the sections of exudyn_pieces.py: EA from the rectangular section,
shear GA, and the section's rotary inertia ρI = ρA·h²/12 that flexlink's Euler–Bernoulli links
leave out: the FE mass matrix needs it, and it lowers the frequencies by ~(h/L)²(βL)²/24,
below 1e-5 for the paper's arm's lower modes). Link 1's
root node is clamped to the ground; link k's root node sits on link k−1's tip node (two
position constraints) with its section angle locked at β_k from the tip section (one
coordinate constraint on the angle increments). Tip masses and rotary inertias are
``ObjectRigidBody2D`` on the tip node. ``mbs.ComputeODE2Eigenvalues`` projects the mass and
stiffness matrices on the null space of the constraint Jacobian (SVD) at the undeformed rest
configuration and returns ω² of the constrained system.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from flexlink.model import Link
from tests.validation.exudyn_pieces import coord, new_system, uniform_beam


def locked_chain_frequencies(links: Sequence[Link], angles: Sequence[float], elements: int,
                             count: int) -> np.ndarray:
    """The lowest ``count`` natural frequencies (Hz) of the chain clamped at the hub with
    joint k locked at angles[k] (rad), ``elements`` per link."""
    from exudyn.itemInterface import CoordinateConstraint

    _container, mbs, m_ground = new_system()
    root = np.zeros(2)
    theta = 0.0
    previous_tip = None
    for link, beta in zip(links, angles):
        theta += beta
        nodes = uniform_beam(mbs, link, elements, root, theta)
        for c in range(3):  # coordinates are increments from the reference: lock them
            if previous_tip is None:
                markers = [m_ground, coord(mbs, nodes[0], c)]
            else:
                markers = [coord(mbs, previous_tip, c), coord(mbs, nodes[0], c)]
            mbs.AddObject(CoordinateConstraint(markerNumbers=markers))
        previous_tip = nodes[-1]
        root = root + link.length * np.array([math.cos(theta), math.sin(theta)])
    mbs.Assemble()
    values, _ = mbs.ComputeODE2Eigenvalues(ignoreAlgebraicEquations=False,
                                          useAbsoluteValues=True)
    omega2 = np.sort(np.asarray(values))
    omega2 = omega2[omega2 > (2 * np.pi * 1e-3) ** 2]  # no rigid modes: drop round-off zeros
    return np.sqrt(omega2[:count]) / (2 * np.pi)
