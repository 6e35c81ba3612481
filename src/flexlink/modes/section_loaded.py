"""Exact modes of a link that carries a rigid body at a section inside its span.

A slider's line can pass through any section x_a of its parent (`PrismaticJoint.at`): the
parent then carries the block and everything beyond it at x_a, not at its tip. The natural
modes of the link with that body (mass m_a, rotary inertia J_a about the section point) at
x_a are piecewise: on each side of x_a the beam's solution of φ'''' = β⁴φ, with φ and φ'
continuous and the body's inertia as a jump in moment and shear,

    EI (φ''(x_a⁺) − φ''(x_a⁻)) = −J_a ω² φ'(x_a),
    EI (φ'''(x_a⁺) − φ'''(x_a⁻)) = m_a ω² φ(x_a),

clamped at the joint (or on a free hub, as `hub_loaded_modes`) and with the link's own tip
body at x = L (as `tip_loaded_modes`). A basis of smooth shapes (clamped–free, or the
tip-loaded modes with the body moved to the tip) cannot carry the jump in curvature and
converges on it only like N⁻¹ (docs/modes.md, "outboard_loaded").

Each side is written in its own bounded basis, y = G e^{β(u−ℓ)} + H e^{−βu} + C cos βu
+ D sin βu (u from the side's start, ℓ its length), so every entry of the 8 × 8 (9 × 9 on a
hub) condition matrix stays bounded for any λ = βL.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from .shapes import _determinant_roots, gauss_rule

__all__ = ["SectionLoadedModes", "section_loaded_modes"]

_POINTS = 20  # Gauss–Legendre points per panel of the normalisation integral


def _rows(lam: float, start: float, end: float) -> np.ndarray:
    """(4 derivatives, 4 terms) of a side on [start, end] (fractions of L) at its start
    (row block 0) and at its end (row block 1), the k-th derivative divided by β^k."""
    ell = lam * (end - start)
    e = math.exp(-ell)
    out = np.empty((2, 4, 4))
    for side, (grow, decay, co, si) in enumerate(((e, 1.0, 1.0, 0.0),
                                                  (1.0, e, math.cos(ell), math.sin(ell)))):
        out[side] = [[grow, decay, co, si],
                     [grow, -decay, -si, co],
                     [grow, decay, -co, -si],
                     [grow, -decay, si, -co]]
    return out


def _matrix(lam: float, a: float, mu_a: float, j_a: float, mu_t: float, j_t: float,
            hub: tuple[float, float] | None) -> np.ndarray:
    """The conditions on (G₁, H₁, C₁, D₁, G₂, H₂, C₂, D₂[, ΘL]) at λ = βL; a = x_a/L,
    μ = m/(mL), j = J/(mL³) of the body at x_a (``_a``) and of the tip body (``_t``), ``hub``
    = (J_h/(mL³), r/L) or None for a clamp."""
    one, two = _rows(lam, 0.0, a), _rows(lam, a, 1.0)
    size = 8 if hub is None else 9
    m = np.zeros((size, size))
    m[0, :4], m[1, :4] = one[0, 0], one[0, 1]  # y(0) = 0, y'(0) = 0 (a clamp)
    for k in range(4):  # continuity of y, y', then the body's jumps in y'' and y'''
        m[2 + k, :4], m[2 + k, 4:8] = -one[1, k], two[0, k]
    m[4, :4] += j_a * lam**3 * one[1, 1]
    m[5, :4] -= mu_a * lam * one[1, 0]
    m[6, 4:8] = two[1, 2] - j_t * lam**3 * two[1, 1]  # EI y''(L) = J_t ω² y'(L)
    m[7, 4:8] = two[1, 3] + mu_t * lam * two[1, 0]  # EI y'''(L) = −m_t ω² y(L)
    if hub is not None:  # the joint on a free hub: as `shapes._hub_matrix`
        eta, rho = hub
        m[0, 8], m[1, 8] = -rho, -1.0 / lam
        m[8, :4] = one[0, 2] - rho * lam * one[0, 3]
        m[8, 8] = eta * lam**2
    return m


@functools.lru_cache(maxsize=64)
def _roots(n: int, args: tuple) -> tuple[float, ...]:
    return tuple(_determinant_roots(lambda x: float(np.linalg.det(_matrix(x, *args))), n,
                                    (n + 2) * np.pi, "section-loaded"))


@dataclass(frozen=True, eq=False)
class SectionLoadedModes:
    """n modes of a link with a body at the section ``at`` (m), piecewise on [0, at] and
    [at, L]: the `ModeShapes` interface (``length``, ``n``, ``beta_l``, ``kind``,
    ``evaluate``) plus ``breaks``, the section where φ'' and φ''' jump (quadratures put a
    panel edge there). Normalised as the other kinds, with the section's body in the mass:
    m∫φ² dx + m_a φ(x_a)² + J_a φ'(x_a)² + m_t φ(L)² + J_t φ'(L)² = mL, φ(L) > 0."""

    length: float  # m
    n: int
    beta_l: np.ndarray  # (n,) λ_i = β_i L
    at: float  # m, the loaded section
    coefficients: np.ndarray = field(repr=False)  # (n, 9): the null vectors of `_matrix`
    scale: np.ndarray = field(repr=False)  # (n,)
    kind: str = "outboard_loaded"  # or "hub_loaded" on a free hub
    hub_radius: float = 0.0  # m

    @property
    def breaks(self) -> tuple[float, ...]:
        return (self.at,)

    @property
    def beta(self) -> np.ndarray:
        """Wavenumbers β_i (1/m)."""
        return self.beta_l / self.length

    def evaluate(self, x: np.ndarray, derivative: int = 0) -> np.ndarray:
        """Φ or its ``derivative``-th x-derivative (1/m^k) at points x (m): (len(x), n)."""
        if derivative not in (0, 1, 2, 3):
            raise ValueError(f"derivative must be 0, 1, 2 or 3, got {derivative}")
        k = derivative
        x = np.asarray(x, dtype=float).reshape(-1, 1)
        beta, c = self.beta[None, :], self.coefficients
        inner = x <= self.at
        start = np.where(inner, 0.0, self.at)
        end = np.where(inner, self.at, self.length)
        first = np.where(inner, 0, 4)
        z = beta * (x - start)
        cz, sz = np.cos(z), np.sin(z)
        terms = (np.exp(beta * (x - end)), (-1.0) ** k * np.exp(-z),
                 (cz, -sz, -cz, sz)[k], (sz, cz, -sz, -cz)[k])
        value = sum(np.where(first == 0, c[:, i], c[:, 4 + i]) * t
                    for i, t in enumerate(terms)) * beta**k
        if k < 2:  # the hub's rigid turn, −Θ (r + x) (zero on a clamp)
            value = value - c[:, 8] / self.length * (((self.hub_radius + x), 1.0)[k])
        return value * self.scale[None, :]


def section_loaded_modes(length: float, n: int, mass_per_length: float, at: float,
                         mass: float, inertia: float, tip_mass: float = 0.0,
                         tip_inertia: float = 0.0, hub_inertia: float | None = None,
                         radius: float = 0.0) -> SectionLoadedModes:
    """Exact modes of a link of ``length`` (m), ``mass_per_length`` (kg/m) carrying a body of
    ``mass`` (kg) and ``inertia`` (kg·m², about the section point) at ``at`` (m, 0 < at < L),
    its own ``tip_mass`` and ``tip_inertia`` at its tip, clamped at its joint or, with
    ``hub_inertia`` (kg·m²), on a free hub at ``radius`` (m; the shapes then less their rigid
    turn, as `hub_loaded_modes`). EI cancels from the shapes. Roots by a sign scan and
    bisection of the condition determinant, each mode from its null vector."""
    if n < 0:
        raise ValueError("the number of modes must be >= 0")
    if mass_per_length <= 0 or length <= 0:
        raise ValueError("length and mass_per_length must be positive")
    if not 0.0 < at < length:
        raise ValueError(f"the loaded section must lie inside the link, got {at:g} m")
    if min(mass, inertia, tip_mass, tip_inertia, radius) < 0 or (hub_inertia or 0.0) < 0:
        raise ValueError("bodies, hub inertia and radius must be non-negative")
    mL, mL3 = mass_per_length * length, mass_per_length * length**3
    hub = None if hub_inertia is None else (hub_inertia / mL3, radius / length)
    args = (at / length, mass / mL, inertia / mL3, tip_mass / mL, tip_inertia / mL3, hub)
    lam = np.array(_roots(n, args)) if n else np.empty(0)
    size = 8 if hub is None else 9
    coefficients = np.zeros((n, 9))
    for i in range(n):
        coefficients[i, :size] = np.linalg.svd(_matrix(lam[i], *args))[2][-1]
    r = 0.0 if hub is None else radius
    kind = "outboard_loaded" if hub is None else "hub_loaded"
    raw = SectionLoadedModes(length, n, lam, at, coefficients, np.ones(n), kind, r)
    if n == 0:
        return raw
    # m∫φ² + the bodies' inertia, per mL; panels break at the section
    g, w = gauss_rule(_POINTS)
    panels = max(2, int(np.ceil(0.5 * lam.max())))
    edges = np.unique(np.concatenate([np.linspace(0.0, length, panels + 1), [at]]))
    half = 0.5 * np.diff(edges)
    x = ((edges[:-1] + half)[:, None] + half[:, None] * g[None, :]).ravel()
    wx = (half[:, None] * w[None, :]).ravel()
    ends = np.array([at, length])
    value, slope = raw.evaluate(ends), raw.evaluate(ends, 1)
    norm = (wx @ raw.evaluate(x) ** 2 / length + (mass * value[0] ** 2 + inertia * slope[0] ** 2
            + tip_mass * value[1] ** 2 + tip_inertia * slope[1] ** 2) / mL)
    sign = np.where(value[1] != 0.0, np.sign(value[1]), 1.0)
    return SectionLoadedModes(length, n, lam, at, coefficients, sign / np.sqrt(norm), kind, r)
