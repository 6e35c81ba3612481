"""Independent reference values for a beam clamped to a cart that slides on a rail across
the beam (tests/validation/test_cart.py): nothing here uses flexlink.

* `cart_beam_frequencies`: natural frequencies of a uniform Euler–Bernoulli beam clamped at
  x = 0 to a cart of mass M that slides freely across the beam (the root's transverse
  displacement is the cart's travel s = w(0), its slope zero), carrying an axial load from
  gravity along the beam as in `gravity_beam.loaded_beam_frequencies` (hanging: tension,
  standing: compression) and a tip mass. The cart's balance M s̈ = −EI w'''(0) (the beam's
  shear on it; w'(0) = 0 so the axial load has no share) gives w'''(0) = μ λ² w(0) in
  ξ = x/L, λ² = ρ ω² L⁴/EI, μ = M/(ρL). Chebyshev collocation with the boundary rows
  replacing collocation rows; μ → ∞ gives the cantilever, μ = 0 the beam on a massless
  slider (the test checks both and convergence in the number of points).
* `cart_pendulum_frequency`: the small-oscillation frequency of a rigid body hanging from a
  pivot on a free cart: ω² = g s₁ (M + m) / ((M + m) J − s₁²), with m, s₁ = m d and J the
  body's mass, first moment and inertia about the pivot (the point pendulum's
  g (M + m)/(M l)).
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eig

from .gravity_beam import _chebyshev


def cart_beam_frequencies(cart_ratio: float, count: int, gamma: float = 0.0,
                          sign: float = 1.0, tip_ratio: float = 0.0,
                          points: int = 40) -> np.ndarray:
    """The first ``count`` non-zero values of λ = ω L² √(ρ/EI) (ω in rad/s) of the beam on
    a cart of mass ratio μ = M/(ρL), with γ = ρ g L³/EI, the tip mass P = tip_ratio · ρ L,
    hanging (sign = +1) or standing (−1). The rigid translation (λ = 0 when μ is finite) is
    left out."""
    x, D = _chebyshev(points)
    xi = (1.0 - x) / 2.0
    d1 = -2.0 * D
    d2, d3 = d1 @ d1, d1 @ d1 @ d1
    d4 = d2 @ d2
    tension = sign * gamma * (1.0 - xi + tip_ratio)
    A = d4 - (tension[:, None] * d2 - sign * gamma * d1)
    B = np.eye(points + 1)
    root, tip = np.flatnonzero(xi == 0.0)[0], np.flatnonzero(xi == 1.0)[0]
    e = np.eye(points + 1)
    rows = [root, root + 1, tip, tip - 1]
    conditions = [d3[root], d1[root], d2[tip], d3[tip] - sign * gamma * tip_ratio * d1[tip]]
    for row, condition in zip(rows, conditions):
        A[row] = condition
        B[row] = 0.0
    B[root] = cart_ratio * e[root]  # w''' = μ λ² w at the root: the cart's inertia
    B[tip - 1] = -tip_ratio * e[tip]  # w''' − T w' = −r λ² w at the tip
    values = eig(A, B, right=False)
    values = values[np.isfinite(values)]
    values = np.sort(values[np.abs(values.imag) < 1e-6 * (1.0 + np.abs(values))].real)
    values = values[values > 1e-3]  # the rigid translation: λ² ≈ 0 to round-off
    return np.sqrt(values[:count])


def cart_pendulum_frequency(cart_mass: float, mass: float, first_moment: float,
                            inertia: float, g: float) -> float:
    """ω (rad/s) of small oscillations of a rigid body (mass kg, first moment kg·m and
    inertia kg·m² about its pivot) hanging from a pivot on a cart of mass kg on a level,
    frictionless rail, in the field g (m/s²). From T = ½(M + m)ṡ² + s₁ ṡ φ̇ + ½ J φ̇²,
    V = ½ g s₁ φ²: det([[M + m, s₁], [s₁, J]] ω² − diag(0, g s₁)) = 0."""
    total = cart_mass + mass
    return float(np.sqrt(g * first_moment * total / (total * inertia - first_moment**2)))
