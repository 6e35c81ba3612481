"""Composite Gauss–Legendre quadrature along a link, with cumulative (running) integrals.

The nonlinear model obtains positions by integrating (cos ψ, sin ψ) along the link. With the
integrand known at the Gauss nodes only, ∫₀ˢ f dσ for any s is the integral of f's Lagrange
interpolant on the panel that holds s (plus the full Gauss sums of the panels before it): a
linear row of weights, exact for polynomials of degree < points per panel on every panel.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import numpy as np
from numpy.polynomial import legendre

POINTS_PER_PANEL = 12
# λ = βL of the highest mode per panel: with 12 Gauss points per λ ≤ 12 the mass matrix gives
# every clamped frequency to < 1e-6 and the low ones to ~1e-11 (docs/nonlinear.md §1); the node
# count sets the cost of every step (products with G grow as its square).
LAMBDA_PER_PANEL = 12.0
# Above λ = 12 and up to ONE_PANEL_LAMBDA a link without breaks takes one panel of ⌈λ⌉ +
# ONE_PANEL_EXTRA points instead of two of 12: fewer nodes, and each clamped frequency of the
# linearised model as close to its value with 8 panels as with two (measured on a beam with
# tip masses 0, 0.2 and 2 kg: 5 modes 3e-11 against 1e-11, 6 modes 3e-12 against 9e-10,
# 7 modes 2e-13 against 1e-8; a panel's Gauss rule converges faster in its point count than
# the composite rule in its panels).
ONE_PANEL_LAMBDA = 22.0
ONE_PANEL_EXTRA = 2


@dataclass(frozen=True, eq=False)
class ArcQuadrature:
    """Nodes x (m) and weights w (m) of a composite Gauss–Legendre rule on [0, length]:
    ``panels`` equal panels, each split where one of ``breaks`` (m) falls inside it (a
    section where the shapes' derivatives jump: `modes.section_loaded`)."""

    length: float
    panels: int
    points_per_panel: int
    breaks: tuple[float, ...] = ()
    x: np.ndarray = field(init=False, repr=False)
    w: np.ndarray = field(init=False, repr=False)
    _antiderivative: np.ndarray = field(init=False, repr=False)  # Legendre coefficients
    _edges: np.ndarray | None = field(init=False, repr=False)  # with breaks: panel edges (m)

    def __post_init__(self) -> None:
        if self.panels < 1 or self.points_per_panel < 1:
            raise ValueError("quadrature needs at least one panel of one point")
        g, wg = legendre.leggauss(self.points_per_panel)
        inside = [b for b in self.breaks if 0.0 < b < self.length]
        if inside:
            edges = np.unique(np.concatenate([np.linspace(0.0, self.length, self.panels + 1),
                                              inside]))
            half = 0.5 * np.diff(edges)[:, None]
            object.__setattr__(self, "_edges", edges)
            object.__setattr__(self, "x", (edges[:-1, None] + half * (g + 1.0)[None, :]).ravel())
            object.__setattr__(self, "w", (half * wg[None, :]).ravel())
        else:
            h = self.length / self.panels
            starts = np.arange(self.panels) * h
            object.__setattr__(self, "_edges", None)
            object.__setattr__(self, "x",
                               (starts[:, None] + 0.5 * h * (g + 1.0)[None, :]).ravel())
            object.__setattr__(self, "w", np.tile(0.5 * h * wg, self.panels))
        # Column j: Legendre coefficients of ∫₋₁^η ℓ_j, ℓ_j the Lagrange basis of the nodes g.
        basis = np.linalg.inv(legendre.legvander(g, self.points_per_panel - 1))
        object.__setattr__(self, "_antiderivative", legendre.legint(basis, lbnd=-1.0, axis=0))

    @property
    def size(self) -> int:
        return self.x.size

    def cumulative(self, s: np.ndarray) -> np.ndarray:
        """Rows R (len(s), size) with ∫₀ˢ f dσ ≈ R @ f(x), for 0 ≤ s ≤ length (m)."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        if np.any(s < -1e-12 * self.length) or np.any(s > self.length * (1 + 1e-12)):
            raise ValueError(f"positions must lie in [0, {self.length:g}] m")
        p = self.points_per_panel
        if self._edges is None:
            h = self.length / self.panels
            panel = np.clip((s // h).astype(int), 0, self.panels - 1)
            eta = np.clip(2.0 * (s - panel * h) / h - 1.0, -1.0, 1.0)
        else:
            edges = self._edges
            panel = np.clip(np.searchsorted(edges, s, side="right") - 1, 0, edges.size - 2)
            h = np.diff(edges)[panel]
            eta = np.clip(2.0 * (s - edges[panel]) / h - 1.0, -1.0, 1.0)
            h = h[:, None]
        rows = np.where(np.arange(self.size)[None, :] < (panel * p)[:, None], self.w[None, :], 0.0)
        partial = 0.5 * h * legendre.legval(eta, self._antiderivative).T  # (len(s), p)
        columns = panel[:, None] * p + np.arange(p)[None, :]
        rows[np.arange(s.size)[:, None], columns] = partial
        return rows


@functools.lru_cache(maxsize=128)
def arc_quadrature(length: float, beta_l_max: float, panels: int | None = None,
                   points_per_panel: int | None = None,
                   breaks: tuple[float, ...] = ()) -> ArcQuadrature:
    """The default rule for a link whose highest mode has βL = ``beta_l_max``; ``breaks``:
    its shapes' sections of jumping derivatives (`ArcQuadrature`). Neither ``panels`` nor
    ``points_per_panel`` given: one panel of 12 points up to λ = 12, one of ⌈λ⌉ + 2 points
    up to λ = 22 (without breaks inside the link), else panels of 12 points, one per λ ≤ 12;
    one of them given: the other as by that last rule (12 points a panel)."""
    inside = any(0.0 < b < length for b in breaks)
    if (panels is None and points_per_panel is None and not inside
            and LAMBDA_PER_PANEL < beta_l_max <= ONE_PANEL_LAMBDA):
        panels, points_per_panel = 1, int(np.ceil(beta_l_max)) + ONE_PANEL_EXTRA
    if panels is None:
        panels = max(1, int(np.ceil(beta_l_max / LAMBDA_PER_PANEL)))
    if points_per_panel is None:
        points_per_panel = POINTS_PER_PANEL
    return ArcQuadrature(length, panels, points_per_panel, tuple(breaks))
