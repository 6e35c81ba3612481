"""The pieces every Exudyn reference under tests/validation is built from: the beam sections,
the system with its ground, coordinate markers and constraints, Simo–Reissner beams between
nodes, point masses, a slider (a prismatic joint pushed by a force history), the step-mean
load history, node sensors read back on the output grid, and the generalized-α solve.

Exudyn is imported inside the functions: the module imports without it (the tests that need
it skip)."""

from __future__ import annotations

import itertools
import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from flexlink.model import Link

POISSON = 0.3  # for the default shear stiffness only (its effect is ~EI/(GA L²) ≈ 1e-6)


@dataclass(frozen=True)
class BeamSection:
    """The beam properties Exudyn needs beyond flexlink's Link (Euler–Bernoulli, inextensible)."""

    EA: float  # N, axial stiffness
    GA: float  # N, shear stiffness (incl. shear correction factor)
    rhoI: float  # kg·m, rotary inertia of the cross section per length


def default_section(link: Link, EA: float | None = None,
                    rotary_inertia: bool = True) -> BeamSection:
    """EA from the rectangular section (12 EI / h²) unless given, GA = κ G A with ν = 0.3,
    ρI = ρA · EI / EA (the homogeneous section's rotary inertia; flexlink neglects it)."""
    if EA is None:
        if link.thickness is None:
            raise ValueError(f"{link.name}: give EA (no thickness to derive it from)")
        EA = 12.0 * link.EI / link.thickness**2
    kappa = 10.0 * (1.0 + POISSON) / (12.0 + 11.0 * POISSON)
    GA = kappa * EA / (2.0 * (1.0 + POISSON))
    rhoI = link.mass_per_length * link.EI / EA if rotary_inertia else 0.0
    return BeamSection(EA=EA, GA=GA, rhoI=rhoI)


def integration_step(dt_out: float, dt: float | None = None) -> float:
    """The generalized-α step (s): ``dt`` (default dt_out, at most 5e-4 s), which must divide
    the output step ``dt_out`` (s); rounded so that it divides it exactly."""
    if dt is None:
        dt = min(dt_out, 5e-4)
    ratio = dt_out / dt
    if abs(ratio - round(ratio)) > 1e-6:
        raise ValueError(f"dt = {dt} must divide dt_out = {dt_out}")
    return dt_out / round(ratio)


def new_system() -> tuple[Any, Any, int]:
    """An Exudyn system container (keep it alive as long as the system), its system, and a
    marker on a ground node's coordinate (0: what the constraints hold coordinates to)."""
    import exudyn as exu
    from exudyn.itemInterface import NodePointGround

    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddNode(NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    return SC, mbs, coord(mbs, ground, 0)


def coord(mbs: Any, node: int, c: int) -> int:
    """A marker on coordinate ``c`` of ``node`` (0: x, 1: y, 2: the rotation, as displacements
    from the reference)."""
    from exudyn.itemInterface import MarkerNodeCoordinate

    return mbs.AddMarker(MarkerNodeCoordinate(nodeNumber=node, coordinate=c))


def fix(mbs: Any, ground: int, node: int, coordinates: Sequence[int] = (0, 1)) -> None:
    """Hold ``coordinates`` of ``node`` at their reference values (``ground``: `new_system`'s
    marker); the default (0, 1) pins its position."""
    from exudyn.itemInterface import CoordinateConstraint

    for c in coordinates:
        mbs.AddObject(CoordinateConstraint(markerNumbers=[ground, coord(mbs, node, c)]))


def pin(mbs: Any, a: int, b: int) -> None:
    """A pin: node ``b``'s position on node ``a``'s (both started at the same point), their
    rotations free."""
    from exudyn.itemInterface import CoordinateConstraint

    for c in (0, 1):
        mbs.AddObject(CoordinateConstraint(markerNumbers=[coord(mbs, a, c), coord(mbs, b, c)]))


def beam_nodes(mbs: Any, link: Link, x: np.ndarray, root: np.ndarray, angle: float,
               section: BeamSection | None = None, stiff: float = 1.0,
               element_length: float | None = None) -> list[int]:
    """Simo–Reissner elements of ``link`` between nodes at ``x`` (m from ``root``, m, along
    ``angle``, rad), undeformed; its tip mass and rotary inertia on the last node (a rigid
    body). ``section``: Exudyn's section (default: `default_section` of the link); ``stiff``
    multiplies its stiffnesses (a rigid member); ``element_length`` (m): every element's
    length on a uniform mesh (default: the spacing of ``x``). Returns the nodes."""
    from exudyn.itemInterface import (
        NodeRigidBody2D,
        ObjectBeamGeometricallyExact2D,
        ObjectRigidBody2D,
    )

    e = np.array([math.cos(angle), math.sin(angle)])
    sec = section or default_section(link)
    nodes = [mbs.AddNode(NodeRigidBody2D(referenceCoordinates=[*(root + xi * e), angle]))
             for xi in x]
    lengths = np.diff(x) if element_length is None else np.full(len(x) - 1, element_length)
    for (a, b), h in zip(itertools.pairwise(nodes), lengths):
        mbs.AddObject(ObjectBeamGeometricallyExact2D(
            nodeNumbers=[a, b], length=float(h), massPerLength=link.mass_per_length,
            crossSectionInertia=sec.rhoI, bendingStiffness=stiff * link.EI,
            axialStiffness=stiff * sec.EA, shearStiffness=stiff * sec.GA))
    if link.tip_mass > 0.0 or link.tip_inertia > 0.0:
        mbs.AddObject(ObjectRigidBody2D(nodeNumber=nodes[-1], mass=link.tip_mass,
                                        inertia=link.tip_inertia))
    return nodes


def uniform_beam(mbs: Any, link: Link, elements: int, root: np.ndarray, angle: float,
                 section: BeamSection | None = None, stiff: float = 1.0) -> list[int]:
    """`beam_nodes` on ``elements`` equal elements of length L/elements over the link."""
    return beam_nodes(mbs, link, np.linspace(0.0, link.length, elements + 1), root, angle,
                      section, stiff, element_length=link.length / elements)


def coupler_and_rocker(mbs: Any, ground: int, crank_tip: int, at: np.ndarray, coupler: Link,
                       rocker: Link, pivot: tuple[float, float], angles: tuple[float, float],
                       EA: float, elements: int, stiff: float) -> tuple[list[int], list[int]]:
    """A four-bar's outboard beams, at rest in the closed configuration: ``coupler``
    (``elements`` elements) from the crank's tip node ``crank_tip`` (at ``at``, m), pinned to
    it; ``rocker`` (EI = inf: rigid, two elements of the coupler's EI times ``stiff``) pinned
    to the ground at ``pivot`` (m) and to the coupler's tip. ``angles``: the coupler's and
    the rocker's absolute angles (rad) that close the loop; ``EA`` (N): their axial
    stiffness. Returns the coupler's and the rocker's nodes."""
    kn = uniform_beam(mbs, coupler, elements, at, angles[0], default_section(coupler, EA))
    pin(mbs, crank_tip, kn[0])
    rigid_rocker = not math.isfinite(rocker.EI)
    rocker_beam = Link("rocker", rocker.length, rocker.mass_per_length,
                       coupler.EI if rigid_rocker else rocker.EI)
    rn = uniform_beam(mbs, rocker_beam, 2 if rigid_rocker else elements,
                      np.asarray(pivot, dtype=float), angles[1],
                      default_section(rocker_beam, EA), stiff if rigid_rocker else 1.0)
    fix(mbs, ground, rn[0])  # the rocker's pivot: its root node stays where it is
    pin(mbs, kn[-1], rn[-1])
    return kn, rn


def point_mass(mbs: Any, node: int, mass: float) -> int:
    """A point mass of ``mass`` kg (no rotary inertia) on ``node``; returns the node's rigid
    marker."""
    from exudyn.itemInterface import MarkerNodeRigid, ObjectRigidBody2D

    mbs.AddObject(ObjectRigidBody2D(nodeNumber=node, mass=mass, inertia=0.0))
    return mbs.AddMarker(MarkerNodeRigid(nodeNumber=node))


class StepMean:
    """M (N·m, or N) for Exudyn's load user function: the mean of M(t) over the step ending
    at t.

    Generalized-α evaluates the load at the step's end: a bang-bang switch on the step grid
    would then act one step early (an impulse error of 2 M dt per switch, 0.4% of the slew
    angle at dt = 1 ms); the step mean (midpoint rule on 8 panels) gives the exact impulse of a
    piecewise-constant history whose switches lie on the grid."""

    def __init__(self, moment: Callable[[float], float], dt: float) -> None:
        self.moment, self.dt, self.cache = moment, dt, {}
        self.offsets = (np.arange(8) + 0.5) / 8 * dt - dt

    def __call__(self, mbs: Any, t: float, load: Any) -> float:
        v = self.cache.get(t)
        if v is None:
            if len(self.cache) > 64:
                self.cache.clear()
            v = self.cache[t] = float(np.mean([self.moment(t + o) for o in self.offsets]))
        return v


def load_history(mbs: Any, marker: int, history: Callable[[float], float], dt: float
                 ) -> StepMean:
    """Load the coordinate ``marker`` (`coord`) by a history (N·m on a rotation, N on a
    position), its mean over each step of ``dt`` s (`StepMean`); returns the user function."""
    from exudyn.itemInterface import LoadCoordinate

    mean = StepMean(history, dt)
    mbs.AddLoad(LoadCoordinate(markerNumber=marker, load=0.0, loadUserFunction=mean))
    return mean


def add_slider(mbs: Any, on_line: int, on_block: int, axis: float, gamma: float,
               force: Callable[[float], float], dt: float) -> None:
    """Hold the rigid marker ``on_block`` (the block) on the line through the rigid marker
    ``on_line`` along ``axis`` (rad, in that marker's frame) by a ``PrismaticJoint2D``, its
    rotation fixed at ``gamma`` (rad) from the line's frame, and push it along the line by
    F(t) (N; `StepMean` over each step of ``dt`` s) through a connector without stiffness
    (a positive connector force pulls the markers together: it returns −F)."""
    from exudyn.itemInterface import LinearSpringDamper, PrismaticJoint2D

    u = [math.cos(axis), math.sin(axis), 0.0]
    # The normal to the line in the block's frame: S u turned back by γ.
    normal = [-math.sin(axis - gamma), math.cos(axis - gamma), 0.0]
    mbs.AddObject(PrismaticJoint2D(markerNumbers=[on_line, on_block], axisMarker0=u,
                                   normalMarker1=normal, constrainRotation=True))
    push = StepMean(force, dt)

    def connector_force(mbs_: Any, t: float, item: int, *args: Any) -> float:
        return -push(mbs_, t, item)

    mbs.AddObject(LinearSpringDamper(markerNumbers=[on_line, on_block], stiffness=0.0,
                                     damping=0.0, axisMarker0=u,
                                     springForceUserFunction=connector_force))


def node_sensor(mbs: Any, node: int, kind: Any = None) -> int:
    """A sensor storing ``kind`` (an ``exu.OutputVariableType``; default ``Coordinates``) of
    ``node`` in memory."""
    import exudyn as exu
    from exudyn.itemInterface import SensorNode

    return mbs.AddSensor(SensorNode(
        nodeNumber=node, storeInternal=True, writeToFile=False,
        outputVariableType=exu.OutputVariableType.Coordinates if kind is None else kind))


def node_series(mbs: Any, sensor: int, t_grid: np.ndarray, node: int | None = None
                ) -> np.ndarray:
    """The sensor's values on the output times ``t_grid`` (s; it writes at t = 0 and after
    each write period), one column per component; with ``node``: plus the node's reference
    coordinates (positions and angles instead of displacements)."""
    data = np.asarray(mbs.GetSensorStoredData(sensor))
    out = np.stack([np.interp(t_grid, data[:, 0], data[:, c])
                    for c in range(1, data.shape[1])], axis=1)
    if node is not None:
        out = out + np.asarray(mbs.GetNodeParameter(node, "referenceCoordinates"))[None, :]
    return out


def solve_dynamic(exu: Any, mbs: Any, t_end: float, dt: float, dt_out: float,
                  newton_abs_tol: float, newton_rel_tol: float, spectral_radius: float,
                  verbose: int = 0) -> tuple[float, np.ndarray]:
    """Assemble and run Exudyn's generalized-α solver; its wall time (s, solver only) and the
    sensors' output times (s)."""
    mbs.Assemble()
    s = exu.SimulationSettings()
    s.timeIntegration.numberOfSteps = round(t_end / dt)
    s.timeIntegration.endTime = t_end
    s.timeIntegration.verboseMode = verbose
    s.timeIntegration.newton.absoluteTolerance = newton_abs_tol
    s.timeIntegration.newton.relativeTolerance = newton_rel_tol
    s.timeIntegration.generalizedAlpha.spectralRadius = spectral_radius
    s.solution.file.write = False
    s.solution.sensors.writePeriod = dt_out
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    started = time.perf_counter()
    ok = mbs.SolveDynamic(s)
    wall = time.perf_counter() - started
    if not ok:
        raise RuntimeError("Exudyn dynamic solver failed")
    n_out = int(np.floor(t_end / dt_out + 1e-9)) + 1
    return wall, np.arange(n_out) * dt_out
