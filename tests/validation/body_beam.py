"""Independent reference values for a cantilever carrying rigid bodies (tests/validation/
test_bodies.py): nothing here uses flexlink.

* `fe_frequencies`: natural frequencies (Hz) of a uniform Euler–Bernoulli cantilever with rigid
  bodies fixed to sections, by cubic Hermite finite elements (consistent mass matrices). A body
  of mass m, centre offset c = [c_x, c_y] in the section's frame and inertia J about its centre
  adds [[m, m c_x], [m c_x, J + m |c|²]] on the (deflection, slope) of its node: the kinetic
  energy ½ m ((ẇ + c_x ẇ')² + (c_y ẇ')²) + ½ J ẇ'² of an axially rigid beam (the centre moves
  along the link by −c_y w').
* `static_tip_deflection`: the tip deflection of a horizontal cantilever under its weight and
  a body's weight m g applied at its centre, x_b + c: the force at x_b plus the moment m g c;
  `hanging_tip_deflection`: of a hanging one, bent only by the moment of the weight of a body
  whose centre is c_y across the link.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import eigh


def fe_frequencies(length: float, rho: float, EI: float, bodies: list[tuple[float, float,
                   tuple[float, float], float]], elements: int = 120) -> np.ndarray:
    """Ascending natural frequencies (Hz); ``bodies``: (at m, mass kg, offset [c_x, c_y] m,
    inertia kg·m²), each ``at`` on an element node."""
    h = length / elements
    k = EI / h**3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                              [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
    m = rho * h / 420 * np.array([[156, 22 * h, 54, -13 * h],
                                  [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                  [54, 13 * h, 156, -22 * h],
                                  [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
    size = 2 * (elements + 1)
    K, M = np.zeros((size, size)), np.zeros((size, size))
    for e in range(elements):
        dofs = slice(2 * e, 2 * e + 4)
        K[dofs, dofs] += k
        M[dofs, dofs] += m
    for at, mass, offset, inertia in bodies:
        node = round(at / h)
        assert abs(node * h - at) < 1e-9 * length, "a body must sit on a node"
        dofs = slice(2 * node, 2 * node + 2)
        cx, cy = offset
        M[dofs, dofs] += [[mass, mass * cx], [mass * cx, inertia + mass * (cx**2 + cy**2)]]
    # clamped: w(0) = w'(0) = 0; 1/ω² from (M, K) keeps the lowest frequencies to round-off
    inverse = eigh(M[2:, 2:], K[2:, 2:], eigvals_only=True)[::-1]
    return 1.0 / np.sqrt(inverse) / (2 * np.pi)


def static_tip_deflection(length: float, rho: float, EI: float, g: float, at: float,
                          mass: float, offset: float) -> float:
    """Tip deflection (m, + up) of a horizontal cantilever in gravity g (m/s², down) with a
    body's weight at x = at + offset: −ρgL⁴/8EI − mg a²(3L − a)/6EI − mg c a(2L − a)/2EI."""
    a, L = at, length
    return (-rho * g * L**4 / (8 * EI) - mass * g * a**2 * (3 * L - a) / (6 * EI)
            - mass * g * offset * a * (2 * L - a) / (2 * EI))


def hanging_tip_deflection(length: float, EI: float, g: float, at: float, mass: float,
                           across: float) -> float:
    """Tip deflection (m, along the link's y) of a cantilever hanging in gravity g (m/s²) with
    a body whose centre is ``across`` (c_y, m) off the link at x = at: the moment −m g c_y at
    at, M a(2L − a)/2EI (linear: without the tension's stiffening)."""
    moment = -mass * g * across
    return moment * at * (2 * length - at) / (2 * EI)
