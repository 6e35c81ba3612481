"""Independent reference values for beams in a uniform gravity field (tests/validation/
test_gravity.py): nothing here uses flexlink.

* `loaded_beam_frequencies`: natural frequencies of a uniform cantilever carrying an axial
  load from gravity, EI w'''' − (T(x) w')' = ρ ω² w with T(x) = s (ρ g (L − x) + P g),
  s = +1 hanging (tension), −1 inverted (compression), P a tip mass, clamped at x = 0, free
  at x = L (w'' = 0, EI w''' − T w' = 0: the tip mass's weight follows the tip section). Solved by
  Chebyshev collocation (Trefethen, *Spectral Methods in MATLAB*, ch. 6–7) with the boundary
  rows replacing collocation rows; converged in the number of points (the test checks it).
* `greenhill_load`: the self-weight buckling load γ = ρ g L³/EI of an inverted (standing)
  cantilever, the γ at which the first frequency above falls to zero (7.837, Greenhill 1881).
* `static_tip_deflection`: q L⁴/8EI + P L³/3EI of a horizontal cantilever.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eig
from scipy.optimize import brentq


def _chebyshev(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Chebyshev points x_j = cos(πj/n) on [−1, 1] and the differentiation matrix."""
    x = np.cos(np.pi * np.arange(n + 1) / n)
    c = np.ones(n + 1)
    c[0] = c[-1] = 2.0
    c *= (-1.0) ** np.arange(n + 1)
    X = np.tile(x, (n + 1, 1)).T
    dX = X - X.T
    D = np.outer(c, 1.0 / c) / (dX + np.eye(n + 1))
    D -= np.diag(D.sum(axis=1))
    return x, D


def loaded_beam_frequencies(gamma: float, count: int, sign: float = 1.0,
                            tip_ratio: float = 0.0, points: int = 60) -> np.ndarray:
    """The first ``count`` values of λ = ω L² √(ρ/EI) (ω in rad/s) of the cantilever with
    γ = ρ g L³/EI, tip mass P = tip_ratio · ρ L (its weight only: the tip mass's inertia
    adds P ω² w(L) to the shear condition), hanging (sign = +1) or standing (−1)."""
    x, D = _chebyshev(points)
    xi = (1.0 - x) / 2.0  # ξ = x/L from 0 (x = 1) to 1 (x = −1)
    d1 = -2.0 * D  # d/dξ
    d2, d3 = d1 @ d1, d1 @ d1 @ d1
    d4 = d2 @ d2
    # dimensionless: w'''' − s γ ((1 − ξ + r) w')' = λ² w, r the tip ratio
    tension = sign * gamma * (1.0 - xi + tip_ratio)
    A = d4 - (tension[:, None] * d2 - sign * gamma * d1)
    B = np.eye(points + 1)
    root, tip = np.flatnonzero(xi == 0.0)[0], np.flatnonzero(xi == 1.0)[0]
    # Boundary rows replace the collocation rows at and next to each end.
    rows = [root, root + 1, tip, tip - 1]
    conditions = [np.eye(points + 1)[root], d1[root], d2[tip],
                  d3[tip] - sign * gamma * tip_ratio * d1[tip]]
    B_tip = np.zeros(points + 1)
    B_tip[tip] = -tip_ratio  # shear: w''' − T w' = −r λ² w at the tip (tip mass inertia)
    for row, condition in zip(rows, conditions):
        A[row] = condition
        B[row] = 0.0
    B[tip - 1] = B_tip
    values = eig(A, B, right=False)
    values = values[np.isfinite(values)]
    values = np.sort(values[np.abs(values.imag) < 1e-6 * np.abs(values)].real)
    values = values[values > -1e-9]
    return np.sqrt(np.maximum(values[:count], 0.0))


def greenhill_load(points: int = 60) -> float:
    """γ = ρ g L³/EI at which a standing cantilever's first frequency vanishes."""
    return brentq(lambda g: _lowest_squared(g, points), 1.0, 10.0, xtol=1e-12)


def _lowest_squared(gamma: float, points: int) -> float:
    """The smallest real λ² (may be negative: unstable) of the standing cantilever."""
    x, D = _chebyshev(points)
    xi = (1.0 - x) / 2.0
    d1 = -2.0 * D
    d2 = d1 @ d1
    A = d2 @ d2 + gamma * ((1.0 - xi)[:, None] * d2 - d1)
    B = np.eye(points + 1)
    root, tip = np.flatnonzero(xi == 0.0)[0], np.flatnonzero(xi == 1.0)[0]
    for row, condition in zip([root, root + 1, tip, tip - 1],
                              [np.eye(points + 1)[root], d1[root], d2[tip], d2[tip] @ d1]):
        A[row] = condition
        B[row] = 0.0
    values = eig(A, B, right=False)
    values = values[np.isfinite(values) & (np.abs(values.imag) < 1e-6 * (1 + np.abs(values)))]
    return float(np.min(values.real))


def static_tip_deflection(q: float, P: float, L: float, EI: float) -> float:
    """Tip deflection (m) of a horizontal cantilever under a distributed load q (N/m) and a
    tip load P (N): q L⁴/8EI + P L³/3EI."""
    return q * L**4 / (8 * EI) + P * L**3 / (3 * EI)


def heavy_elastica_tip(q: float, P: float, L: float, EI: float,
                       points: int = 2001) -> tuple[float, float]:
    """Tip position (x, y) (m) of an inextensible cantilever clamped horizontally at the
    origin under its weight q (N/m) and a tip load P (N), both along −y, at any deflection:
    the heavy elastica EI θ''(s) = (q (L − s) + P) cos θ(s), θ(0) = 0, θ'(L) = 0, solved by
    collocation (scipy's solve_bvp) from the small-deflection solution, then integrated for
    the tip, x = ∫cos θ ds, y = ∫sin θ ds."""
    from scipy.integrate import solve_bvp, trapezoid

    s = np.linspace(0.0, L, points)

    def rhs(s: np.ndarray, u: np.ndarray) -> np.ndarray:
        return np.vstack([u[1], (q * (L - s) + P) * np.cos(u[0]) / EI])

    def bc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return np.array([a[0], b[1]])

    # small deflection: θ' = −M/EI with M the moment of the loads outboard (hogging)
    slope = -(q * (L**3 - (L - s) ** 3) / 6 + P * (L**2 - (L - s) ** 2) / 2) / EI
    guess = np.vstack([slope, -(q * (L - s) ** 2 / 2 + P * (L - s)) / EI])
    sol = solve_bvp(rhs, bc, s, guess, tol=1e-10, max_nodes=100000)
    if not sol.success:
        raise RuntimeError(sol.message)
    theta = sol.sol(s)[0]
    return float(trapezoid(np.cos(theta), s)), float(trapezoid(np.sin(theta), s))
