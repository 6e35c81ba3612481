"""Modal integrals of one flexible link, in the link frame (x along the undeformed link, m).

The measure dm is the beam's mass per length m dx on [0, L] plus the tip mass m_t as a point
mass at x = L.  The tip's rotary inertia J_t only enters ``clamped_mass_matrix`` (and so the
damping matrix and natural frequencies).  All quantities are in SI units; Φ is dimensionless.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh

from flexlink.model import Link
from flexlink.modes.shapes import ModeShapes, mode_shapes_for

__all__ = ["ModalData", "highest_frequency", "modal_data", "modal_data_for_stiffness",
           "unit_stiffness_modal_data"]

_POINTS_PER_PANEL = 20
_LAMBDA_PER_PANEL = 3.0  # max β_n · (panel width) — keeps e^{±2βx} resolved to round-off


@dataclass(frozen=True, eq=False)
class ModalData:
    """Integrals of the link's n assumed modes Φ(x) (a row vector) over the measure dm.

    With S(x) = ∫₀ˣ Φ'ᵀΦ' ds (the foreshortening of the link's axis is −½ qᵀS(x)q):
    ``foreshortening_tip`` = S(L), ``foreshortening_mass`` = ∫S dm [kg],
    ``foreshortening_moment`` = ∫x S dm [kg·m].
    """

    length: float  # m
    n: int
    shapes: ModeShapes
    mass: float  # kg, ∫dm
    first_moment: float  # kg·m, ∫x dm
    second_moment: float  # kg·m², ∫x² dm
    phi_bar: np.ndarray  # (n,) kg, ∫Φ dm
    phi_tilde: np.ndarray  # (n,) kg·m, ∫xΦ dm
    mass_matrix: np.ndarray  # (n, n) kg, ∫ΦᵀΦ dm
    stiffness_matrix: np.ndarray  # (n, n) N/m, ∫EI Φ''ᵀΦ'' dx
    tip_value: np.ndarray  # (n,) Φ(L)
    tip_slope: np.ndarray  # (n,) 1/m, Φ'(L)
    tip_inertia: float  # kg·m², J_t
    foreshortening_tip: np.ndarray  # (n, n) 1/m
    foreshortening_mass: np.ndarray  # (n, n) kg/m
    foreshortening_moment: np.ndarray  # (n, n) kg
    clamped_mass_matrix: np.ndarray  # (n, n) kg, mass_matrix + J_t Φ'(L)ᵀΦ'(L)
    damping_matrix: np.ndarray  # (n, n) N·s/m, modal damping of the clamped link
    natural_frequencies_hz: np.ndarray  # (n,) Hz, clamped link, ascending


def _gauss_legendre(length: float, beta_l_max: float, points: int | None) -> tuple[np.ndarray,
                                                                                   np.ndarray]:
    """Composite Gauss–Legendre nodes (m) and weights (m) on [0, length].

    Default: panels of 20 points, each at most 3/β_n wide, so that products of mode
    functions (spatial rates up to 2β_n) are integrated to round-off.  ``points`` overrides
    the total node count (split into panels of ≤ 20 points).
    """
    if points is None:
        panels = max(2, int(np.ceil(beta_l_max / _LAMBDA_PER_PANEL)))
        per_panel = _POINTS_PER_PANEL
    else:
        if points < 1:
            raise ValueError("quadrature_points must be positive")
        panels = int(np.ceil(points / _POINTS_PER_PANEL))
        per_panel = int(np.ceil(points / panels))
    g, w = np.polynomial.legendre.leggauss(per_panel)
    edges = np.linspace(0.0, length, panels + 1)
    half = 0.5 * np.diff(edges)[:, None]
    x = (edges[:-1, None] + half + half * g[None, :]).ravel()
    return x, (half * w[None, :]).ravel()


def _sym(a: np.ndarray) -> np.ndarray:
    out = 0.5 * (a + a.T)
    out.flags.writeable = False
    return out


def _ro(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


def _weighted_gram(f: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Σ_k weights_k f_kᵀ f_k for f of shape (points, n)."""
    return _sym(f.T @ (weights[:, None] * f))


@dataclass(frozen=True, eq=False)
class UnitStiffnessModes:
    """What of a link's modal data does not depend on EI or the damping ratio: ``data`` (its
    stiffness, damping and frequencies left empty), Φ'' at the quadrature nodes and the
    weights (for K = EI ∫Φ''ᵀΦ'' dx), and the clamped mass matrix (for the frequencies)."""

    data: ModalData
    second_derivatives: np.ndarray  # (points, n) 1/m², Φ'' at the quadrature nodes
    weights: np.ndarray  # (points,) m
    clamped: np.ndarray  # (n, n) kg


def _stiffness_free(link: Link, quadrature_points: int | None,
                    shapes: ModeShapes | None) -> UnitStiffnessModes:
    shapes = mode_shapes_for(link) if shapes is None else shapes
    L, m, m_t, J_t = link.length, link.mass_per_length, link.tip_mass, link.tip_inertia
    x, w = _gauss_legendre(L, float(shapes.beta_l.max(initial=0.0)), quadrature_points)
    phi = shapes.evaluate(x)
    dphi = shapes.evaluate(x, 1)
    ddphi = shapes.evaluate(x, 2)
    end = np.array([L])
    tip = shapes.evaluate(end)[0]
    slope = shapes.evaluate(end, 1)[0]

    wm = w * m
    mass_matrix = _weighted_gram(phi, wm) + m_t * np.outer(tip, tip)
    clamped = mass_matrix + J_t * np.outer(slope, slope)
    # Mass outboard of s, and its first moment about the joint (tip mass included).
    outboard_mass = m * (L - x) + m_t
    outboard_moment = 0.5 * m * (L**2 - x**2) + m_t * L
    empty = _ro(np.empty(0))

    data = ModalData(
        length=L,
        n=shapes.n,
        shapes=shapes,
        mass=m * L + m_t,
        first_moment=0.5 * m * L**2 + m_t * L,
        second_moment=m * L**3 / 3.0 + m_t * L**2,
        phi_bar=_ro(wm @ phi + m_t * tip),
        phi_tilde=_ro((wm * x) @ phi + m_t * L * tip),
        mass_matrix=_sym(mass_matrix),
        stiffness_matrix=empty,
        tip_value=_ro(tip),
        tip_slope=_ro(slope),
        tip_inertia=J_t,
        foreshortening_tip=_weighted_gram(dphi, w),
        foreshortening_mass=_weighted_gram(dphi, w * outboard_mass),
        foreshortening_moment=_weighted_gram(dphi, w * outboard_moment),
        clamped_mass_matrix=_sym(clamped),
        damping_matrix=empty,
        natural_frequencies_hz=empty,
    )
    return UnitStiffnessModes(data, _ro(ddphi), _ro(w), _ro(clamped))


def _with_stiffness(unit: UnitStiffnessModes, EI: float, damping_ratio: float) -> ModalData:
    """The modal data with K = EI ∫Φ''ᵀΦ'' dx, the clamped frequencies and modal damping."""
    stiffness = _weighted_gram(unit.second_derivatives, unit.weights * EI)
    clamped = unit.clamped
    omega2, vectors = eigh(stiffness, clamped)  # vectorsᵀ M_c vectors = I
    omega = np.sqrt(np.clip(omega2, 0.0, None))
    mv = clamped @ vectors
    damping = mv @ np.diag(2.0 * damping_ratio * omega) @ mv.T
    return dataclasses.replace(unit.data, stiffness_matrix=stiffness,
                               damping_matrix=_sym(damping),
                               natural_frequencies_hz=_ro(omega / (2.0 * np.pi)))


def modal_data(
    link: Link, quadrature_points: int | None = None, shapes: ModeShapes | None = None
) -> ModalData:
    """Compute all modal integrals of ``link`` by composite Gauss–Legendre quadrature."""
    return _with_stiffness(_stiffness_free(link, quadrature_points, shapes), link.EI,
                           link.damping_ratio)


@functools.lru_cache(maxsize=64)
def unit_stiffness_modal_data(link: Link) -> UnitStiffnessModes:
    """What of ``link``'s modal data does not depend on EI or damping, cached per process by
    every field that matters (not the name, EI, damping ratio or section thickness).

    The shapes of clamped–free and tip-loaded modes do not depend on EI (it cancels from the
    dimensionless frequency equation), nor does any modal integral but the stiffness matrix:
    a sweep over EI, E or the damping ratio evaluates the shapes and integrates once, then per
    case only forms K (one small product) and solves the 4 × 4 eigenproblem."""
    key = dataclasses.replace(link, name="", EI=1.0, damping_ratio=0.0, thickness=None)
    if key != link:
        return unit_stiffness_modal_data(key)
    return _stiffness_free(link, None, None)


def modal_data_for_stiffness(link: Link) -> ModalData:
    """`modal_data` of a clamped–free or tip-loaded link from `unit_stiffness_modal_data`: the
    same operations on the same numbers, so equal to a fresh computation bit for bit
    (tests/unit/test_startup.py)."""
    if link.mode_shapes not in ("clamped_free", "tip_loaded", "pinned_pinned"):
        raise ValueError(f"mode shapes {link.mode_shapes!r} depend on more than the link")
    return _with_stiffness(unit_stiffness_modal_data(link), link.EI, link.damping_ratio)


def highest_frequency(modal: list[ModalData]) -> float:
    """Highest clamped natural frequency of any link, rad/s; 0 when every link is rigid."""
    return float(max((2 * np.pi * d.natural_frequencies_hz.max(initial=0.0) for d in modal),
                     default=0.0))
