"""Free hub–beam system: exact natural frequencies (reference problem as code).

A rigid hub of inertia J_h turns freely about its fixed centre; a uniform Euler–Bernoulli beam
(EI, mass per length m, length L) is clamped to it at radius r and points radially outwards.
With y(x) = (r + x)Θ + w(x) the beam's total transverse displacement, a mode
y = A cosh λx + B sinh λx + C cos λx + D sin λx, λ⁴ = m ω²/EI, must satisfy the clamp
y(0) = rΘ, y'(0) = Θ, the free tip y''(L) = y'''(L) = 0, and the hub's balance
J_h ω² Θ + EI (y''(0) − r y'''(0)) = 0 (the beam's root moment and shear about the centre).
In μ = λL, ρ = r/L, η = J_h/(m L³) the five conditions on (A, B, C, D, ΘL) are

    A + C − ρΘL = 0,                       μ(B + D) − ΘL = 0,
    A ch μ + B sh μ − C cos μ − D sin μ = 0,  A sh μ + B ch μ + C sin μ − D cos μ = 0,
    η μ⁴ ΘL + μ²(A − C) − ρ μ³ (B − D) = 0,

and det = 0 is the frequency equation: ω = μ² √(EI/(m L⁴)). η → ∞ gives the cantilever
(cos μ cosh μ = −1), η = ρ = 0 the pinned–free beam (tan μ = tanh μ). Derivation:
docs/derivation.md, "Forward dynamics".
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import brentq


def _det(mu: float, rho: float, eta: float, tip_mass: float = 0.0,
         tip_inertia: float = 0.0) -> float:
    """The frequency determinant; η = inf clamps the beam (Θ = 0, the hub's row left out)."""
    ch, sh, c, s = np.cosh(mu), np.sinh(mu), np.cos(mu), np.sin(mu)
    t, sech = sh / ch, 1.0 / ch  # the tip rows divided by cosh μ stay O(1)
    moment = np.array([1.0, t, -c * sech, -s * sech])  # y''(L) L²/μ² per (A, B, C, D)
    slope = np.array([t, 1.0, -s * sech, c * sech])  # y'(L) L/μ
    shear = np.array([t, 1.0, s * sech, -c * sech])  # y'''(L) L³/μ³
    value = np.array([1.0, t, c * sech, s * sech])  # y(L)
    a = np.zeros((5, 5))
    a[0] = [1.0, 0.0, 1.0, 0.0, -rho]
    a[1] = [0.0, mu, 0.0, mu, -1.0]
    a[2, :4] = moment - tip_inertia * mu**3 * slope
    a[3, :4] = shear + tip_mass * mu * value
    if np.isinf(eta):
        return float(np.linalg.det(a[:4, :4]))
    a[4] = [mu**2, -rho * mu**3, -mu**2, rho * mu**3, eta * mu**4]
    return float(np.linalg.det(a)) / mu**4


def hub_beam_frequencies(count: int, EI: float, mass_per_length: float, length: float,
                         radius: float, hub_inertia: float, tip_mass: float = 0.0,
                         tip_inertia: float = 0.0) -> np.ndarray:
    """The first ``count`` non-zero natural frequencies (rad/s), ascending, of the hub–beam
    with a tip mass (kg) and a rotary tip inertia (kg·m²); ``hub_inertia = math.inf``
    clamps the beam."""
    rho = radius / length
    eta = hub_inertia / (mass_per_length * length**3)
    args = (rho, eta, tip_mass / (mass_per_length * length),
            tip_inertia / (mass_per_length * length**3))
    grid = np.linspace(0.3, 4.0 * (count + 2), 4000 * (count + 2))
    values = np.array([_det(m, *args) for m in grid])
    roots = [brentq(_det, grid[i], grid[i + 1], args=args, xtol=1e-14)
             for i in np.nonzero(np.sign(values[:-1]) != np.sign(values[1:]))[0]]
    mu = np.array(roots[:count])
    if mu.size < count:
        raise ValueError("fewer roots than asked for: widen the search grid")
    return mu**2 * np.sqrt(EI / (mass_per_length * length**4))
