"""Modal integrals of one flexible link, in the link frame (x along the undeformed link, m).

The measure dm is the beam's mass per length m dx on [0, L] plus each rigid body's mass
(`model.Body`; the tip mass is the body at x = L without offset) as a point mass at its centre:
a body at section x_b with centre offset c = [c_x, c_y] in the section's frame sits at
(x_b + c_x, c_y) and moves across the link with Φ(x_b) + c_x Φ'(x_b) and along it with
−c_y Φ'(x_b) (to first order: the section turns by Φ'(x_b)q); ``lateral_*`` hold what c_y adds
beyond the integrals of a measure on the link's axis. The bodies' rotary inertias J_b about their centres turn with their
sections: ``rotary_*``. All quantities are in SI units; Φ is dimensionless.
"""

from __future__ import annotations

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np
from scipy.linalg import eigh

from flexlink.model import Link
from flexlink.modes.shapes import ModeShapes, gauss_rule, mode_shapes_for

__all__ = ["ModalData", "highest_frequency", "modal_data", "modal_data_for_stiffness",
           "unit_stiffness_modal_data"]

_POINTS_PER_PANEL = 20
_LAMBDA_PER_PANEL = 3.0  # max β_n · (panel width) — keeps e^{±2βx} resolved to round-off


@dataclass(frozen=True, eq=False)
class ModalData:
    """Integrals of the link's n assumed modes Φ(x) (a row vector) over the measure dm.

    With S(x) = ∫₀ˣ Φ'ᵀΦ' ds (the foreshortening of the link's axis is −½ qᵀS(x)q):
    ``foreshortening_tip`` = S(L), ``foreshortening_mass`` = ∫S dm [kg],
    ``foreshortening_moment`` = ∫x S dm [kg·m]; a body adds the second-order shortening of
    its offset, ½ c_x (Φ'(x_b)q)², to its S (docs/derivation.md §12).
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
    rotary_inertia: float  # kg·m², Σ J_b of the bodies about their centres
    rotary_slope: np.ndarray  # (n,) kg·m²/m, Σ J_b Φ'(x_b)
    rotary_matrix: np.ndarray  # (n, n) kg, Σ J_b Φ'(x_b)ᵀΦ'(x_b)
    foreshortening_tip: np.ndarray  # (n, n) 1/m
    foreshortening_mass: np.ndarray  # (n, n) kg/m
    foreshortening_moment: np.ndarray  # (n, n) kg
    # A body's centre across the link (offset c_y) moves along it by −c_y Φ'(x_b)q:
    lateral: bool  # whether any body with mass has c_y ≠ 0 (the lateral_* terms count)
    lateral_moment: float  # kg·m, ∫y dm = Σ m_b c_y
    lateral_slope: np.ndarray  # (n,) kg, Σ m_b c_y Φ'(x_b) (−∫ of the axial motion per q)
    lateral_tilde: np.ndarray  # (n,) kg·m, Σ m_b c_y (x_b Φ'(x_b) − Φ(x_b))
    lateral_shortening: np.ndarray  # (n, n) kg/m, Σ m_b c_y Φ'ᵀΦ'(x_b)
    lateral_shortening_moment: np.ndarray  # (n, n) kg, Σ m_b c_y (x_b Φ'ᵀΦ' − S(x_b))
    lateral_gyroscopic: np.ndarray  # (3+n, 3+n) kg·m^k, the bodies' part of G₀ past ∫p_y dm
    clamped_mass_matrix: np.ndarray  # (n, n) kg, mass_matrix + rotary_matrix
    damping_matrix: np.ndarray  # (n, n) N·s/m, modal damping of the clamped link
    natural_frequencies_hz: np.ndarray  # (n,) Hz, clamped link, ascending


def _gauss_legendre(length: float, beta_l_max: float, points: int | None,
                    breaks: tuple[float, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
    """Composite Gauss–Legendre nodes (m) and weights (m) on [0, length].

    Default: panels of 20 points, each at most 3/β_n wide, so that products of mode
    functions (spatial rates up to 2β_n) are integrated to round-off.  ``points`` overrides
    the total node count (split into panels of ≤ 20 points). ``breaks`` (m): sections inside
    where the shapes' derivatives jump (`SectionLoadedModes`), made panel edges.
    """
    if points is None:
        panels = max(2, int(np.ceil(beta_l_max / _LAMBDA_PER_PANEL)))
        per_panel = _POINTS_PER_PANEL
    else:
        if points < 1:
            raise ValueError("quadrature_points must be positive")
        panels = int(np.ceil(points / _POINTS_PER_PANEL))
        per_panel = int(np.ceil(points / panels))
    g, w = gauss_rule(per_panel)
    edges = np.linspace(0.0, length, panels + 1)
    inside = [b for b in breaks if 0.0 < b < length]
    if inside:
        edges = np.unique(np.concatenate([edges, inside]))
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
    L, m = link.length, link.mass_per_length
    x, w = _gauss_legendre(L, float(shapes.beta_l.max(initial=0.0)), quadrature_points,
                           getattr(shapes, "breaks", ()))
    phi = shapes.evaluate(x)
    dphi = shapes.evaluate(x, 1)
    ddphi = shapes.evaluate(x, 2)
    end = np.array([L])
    tip = shapes.evaluate(end)[0]
    slope = shapes.evaluate(end, 1)[0]

    wm = w * m
    fore = _weighted_gram(dphi, w)
    b = body_integrals(link, shapes, lambda at: fore if at == L else _shortening(shapes, at))
    mass_matrix = _weighted_gram(phi, wm) + b.mass_matrix
    clamped = mass_matrix + b.rotary_matrix
    empty = _ro(np.empty(0))

    data = ModalData(
        length=L,
        n=shapes.n,
        shapes=shapes,
        mass=m * L + b.mass,
        first_moment=0.5 * m * L**2 + b.first_moment,
        second_moment=m * L**3 / 3.0 + b.second_moment,
        phi_bar=_ro(wm @ phi + b.phi_bar),
        phi_tilde=_ro((wm * x) @ phi + b.phi_tilde),
        mass_matrix=_sym(mass_matrix),
        stiffness_matrix=empty,
        tip_value=_ro(tip),
        tip_slope=_ro(slope),
        rotary_inertia=b.rotary_inertia,
        rotary_slope=_ro(b.rotary_slope),
        rotary_matrix=_sym(b.rotary_matrix),
        foreshortening_tip=fore,
        # ∫S dm = ∫ Φ'ᵀΦ'(s) (beam mass outboard of s) ds, and ∫xS dm alike, plus the bodies'
        foreshortening_mass=_sym(_weighted_gram(dphi, w * (m * (L - x))) + b.shortening_mass),
        foreshortening_moment=_sym(_weighted_gram(dphi, w * (0.5 * m * (L**2 - x**2)))
                                   + b.shortening_moment),
        lateral=any(body.mass and body.offset[1] for body in link.all_bodies()),
        lateral_moment=b.lateral_moment,
        lateral_slope=_ro(b.lateral_slope),
        lateral_tilde=_ro(b.lateral_tilde),
        lateral_shortening=_sym(b.lateral_shortening),
        lateral_shortening_moment=_sym(b.lateral_shortening_moment),
        lateral_gyroscopic=_ro(b.lateral_gyroscopic),
        clamped_mass_matrix=_sym(clamped),
        damping_matrix=empty,
        natural_frequencies_hz=empty,
    )
    return UnitStiffnessModes(data, _ro(ddphi), _ro(w), _ro(clamped))


def _shortening(shapes: ModeShapes, at: float) -> np.ndarray:
    """S(at) = ∫₀^at Φ'ᵀΦ' ds (1/m), (n, n)."""
    if at <= 0.0:
        return np.zeros((shapes.n, shapes.n))
    x, w = _gauss_legendre(at, float(shapes.beta_l.max(initial=0.0)) * at / shapes.length, None,
                           getattr(shapes, "breaks", ()))
    return _weighted_gram(shapes.evaluate(x, 1), w)


@dataclass(frozen=True)
class BodyIntegrals:
    """The rigid bodies' share of a link's modal integrals (`ModalData`'s fields of the same
    names; ``shortening_*`` the bodies' parts of ``foreshortening_*``)."""

    mass: float
    first_moment: float
    second_moment: float
    phi_bar: np.ndarray
    phi_tilde: np.ndarray
    mass_matrix: np.ndarray
    rotary_inertia: float
    rotary_slope: np.ndarray
    rotary_matrix: np.ndarray
    shortening_mass: np.ndarray
    shortening_moment: np.ndarray
    lateral_moment: float
    lateral_slope: np.ndarray
    lateral_tilde: np.ndarray
    lateral_shortening: np.ndarray
    lateral_shortening_moment: np.ndarray
    lateral_gyroscopic: np.ndarray


def body_integrals(link: Link, shapes: ModeShapes, shortening) -> BodyIntegrals:
    """Every rigid body's contribution (`Link.all_bodies`) to the modal integrals: the one
    place a body's mass, offset and inertia enter the first-order model (docs/derivation.md
    §12). ``shortening(at)``: S(at) (n, n) of the link's modes."""
    n = shapes.n
    mass = first = second = rot = lateral = 0.0
    phi_bar, phi_tilde, rot_slope = np.zeros(n), np.zeros(n), np.zeros(n)
    lat_slope, lat_tilde = np.zeros(n), np.zeros(n)
    mm, rot_mm, s_mass, s_moment, lat_s, lat_s_moment = (np.zeros((n, n)) for _ in range(6))
    lat_N = np.zeros((3 + n, 3 + n))
    for body in link.all_bodies():
        cx, cy = body.offset
        at = np.array([body.at])
        value, slope = shapes.evaluate(at)[0], shapes.evaluate(at, 1)[0]
        u = value + cx * slope  # the centre's displacement across the link per q
        px, mb = body.at + cx, body.mass
        if mb:
            S = shortening(body.at)
            ss = np.outer(slope, slope)
            mass += mb
            first += mb * px
            second += mb * px * px
            phi_bar += mb * u
            phi_tilde += mb * px * u
            mm += mb * np.outer(u, u)
            s_mass += mb * (S + cx * ss)
            s_moment += mb * (px * S + cx * px * ss)
            if cy:
                # along the link the centre moves by −c_y Φ'(x_b) q (the section's turn)
                second += mb * cy * cy
                phi_tilde += mb * cy * cy * slope
                mm += mb * cy * cy * ss
                s_moment += mb * cy * cy * ss
                lateral += mb * cy
                lat_slope += mb * cy * slope
                lat_tilde += mb * cy * (body.at * slope - value)
                lat_s += mb * cy * ss
                lat_s_moment += mb * cy * (body.at * ss - S)
                # ∫ P̂_yᵀ P̂_x dm past its first column, P̂_x = [1, 0, −c_y, −c_y Φ'(x_b)]
                py = np.concatenate([[0.0, 1.0, px], u])
                lat_N[:, 2] -= mb * cy * py
                lat_N[:, 3:] -= mb * cy * np.outer(py, slope)
        if body.inertia:
            rot += body.inertia
            rot_slope += body.inertia * slope
            rot_mm += body.inertia * np.outer(slope, slope)
    return BodyIntegrals(mass, first, second, phi_bar, phi_tilde, mm, rot, rot_slope, rot_mm,
                         s_mass, s_moment, lateral, lat_slope, lat_tilde, lat_s, lat_s_moment,
                         lat_N - lat_N.T)


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
    key = dataclasses.replace(link, name="", EI=1.0, damping_ratio=0.0, thickness=None,
                              initial_modal_rates=())
    if key != link:
        return unit_stiffness_modal_data(key)
    return _stiffness_free(link, None, None)


def modal_data_for_stiffness(link: Link) -> ModalData:
    """`modal_data` of a clamped–free or tip-loaded link from `unit_stiffness_modal_data`: the
    same operations on the same numbers, so equal to a fresh computation bit for bit
    (tests/unit/test_startup.py)."""
    if link.mode_shapes not in ("clamped_free", "tip_loaded", "pinned_pinned", "pinned_loaded"):
        raise ValueError(f"mode shapes {link.mode_shapes!r} depend on more than the link")
    return _with_stiffness(unit_stiffness_modal_data(link), link.EI, link.damping_ratio)


def highest_frequency(modal: list[ModalData]) -> float:
    """Highest clamped natural frequency of any link, rad/s; 0 when every link is rigid."""
    return float(max((2 * np.pi * d.natural_frequencies_hz.max(initial=0.0) for d in modal),
                     default=0.0))
