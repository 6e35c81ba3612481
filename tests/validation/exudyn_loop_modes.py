"""Natural frequencies of a four-bar at rest from a geometrically exact FE model (Exudyn):
Simo–Reissner beams (``ObjectBeamGeometricallyExact2D``, the sections of exudyn_pieces.py)
along each link, the pins as equal node translations, the ground pivots' translations fixed
(and, for a held crank, its rotation), a body on the coupler's tip as ``ObjectRigidBody2D``.
``mbs.ComputeODE2Eigenvalues`` projects mass and stiffness on the null space of the
constraints' Jacobian at the undeformed configuration."""

from __future__ import annotations

import math

import numpy as np

from flexlink.model import Link
from tests.validation.exudyn_pieces import (
    coupler_and_rocker,
    default_section,
    fix,
    new_system,
    uniform_beam,
)

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
    _container, mbs, m_ground = new_system()

    crank_link = Link("crank", crank, rocker.mass_per_length, coupler.EI)
    cn = uniform_beam(mbs, crank_link, 2, np.zeros(2), angles[0],
                      default_section(crank_link, EA), STIFF)
    fix(mbs, m_ground, cn[0], (0, 1, 2) if held_crank else (0, 1))
    coupler_and_rocker(mbs, m_ground, cn[-1],
                       crank * np.array([math.cos(angles[0]), math.sin(angles[0])]), coupler,
                       rocker, pivot, angles[1:], EA, elements, STIFF)
    mbs.Assemble()
    values, _ = mbs.ComputeODE2Eigenvalues(ignoreAlgebraicEquations=False,
                                          useAbsoluteValues=True)
    omega2 = np.sort(np.asarray(values))
    # a free crank's mechanism motion comes out below 1 Hz here, not at zero: left out
    omega2 = omega2[omega2 > (2 * np.pi * 5.0) ** 2]
    return np.sqrt(omega2[:count]) / (2 * np.pi)
