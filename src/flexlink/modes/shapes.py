"""Assumed-mode shape functions of a uniform clamped beam on [0, L].

Every mode has the classical form (ζ = βx, λ = βL)

    φ(x) = cosh ζ − cos ζ + c (sinh ζ − sin ζ),

which satisfies φ(0) = φ'(0) = 0 and φ'''' = β⁴ φ.  The constant c and the eigenvalue λ
come from the tip boundary conditions.  To stay finite for large λ the hyperbolic part is
evaluated as

    cosh ζ + c sinh ζ = ½(1 + c) e^λ · e^{β(x−L)} + ½(1 − c) e^{−βx},

with ½(1 + c) e^λ computed without cancellation (see ``_coefficients``).  All evaluations
are in the link frame: x in metres from the joint, derivatives with respect to x.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from flexlink.model import Link

__all__ = ["ModeShapes", "clamped_free_modes", "hub_loaded_modes", "mode_shapes_for",
           "offset_tip_modes", "pinned_loaded_modes", "pinned_pinned_modes", "tip_loaded_modes"]

_NORM_PANELS_PER_LAMBDA = 0.5  # quadrature panels per unit of λ for the normalisation integral
_GAUSS_POINTS = 20  # Gauss–Legendre points per panel


def _readonly(a: np.ndarray) -> np.ndarray:
    a = np.array(a, dtype=float)
    a.flags.writeable = False
    return a


@dataclass(frozen=True, eq=False)
class ModeShapes:
    """n clamped-beam mode shapes Φ(x) = [φ_1 … φ_n] on [0, length] (dimensionless values).

    ``beta_l`` holds the eigenvalues λ_i = β_i L.  Mode i is normalised so that
    m∫φ_i² dx + m_t φ_i(L)² + J_t φ_i'(L)² = m L (bare beam: ∫φ_i² dx = L, φ_i(L) = 2),
    and signed so that φ_i(L) > 0.  φ_i = scale_i [growing_i e^{β(x−L)} + ½(1 − c_i) e^{−βx}
    − cos βx − c_i sin βx + extra_i], where ``extra`` (hub-loaded modes only, else None) holds
    the coefficients of e^{−βx}, cos βx, sin βx, 1 and βx added to the bracket.  Build with the
    factories below, not the constructor.
    """

    length: float  # m
    n: int
    beta_l: np.ndarray  # (n,) dimensionless eigenvalues β_i L
    c: np.ndarray = field(repr=False)  # (n,) coefficient of (sinh − sin)
    growing: np.ndarray = field(repr=False)  # (n,) ½(1 + c) e^{βL}, bounded
    scale: np.ndarray = field(repr=False)  # (n,) normalisation factor with sign
    kind: str = "clamped_free"
    extra: np.ndarray | None = field(default=None, repr=False)  # (5, n) or None

    def __post_init__(self) -> None:
        for name in ("beta_l", "c", "growing", "scale"):
            arr = _readonly(getattr(self, name))
            if arr.shape != (self.n,):
                raise ValueError(f"{name} must have shape ({self.n},), got {arr.shape}")
            object.__setattr__(self, name, arr)
        if self.extra is not None:
            extra = _readonly(self.extra)
            if extra.shape != (5, self.n):
                raise ValueError(f"extra must have shape (5, {self.n}), got {extra.shape}")
            object.__setattr__(self, "extra", extra)

    @property
    def beta(self) -> np.ndarray:
        """Wavenumbers β_i (1/m)."""
        return self.beta_l / self.length

    def evaluate(self, x: np.ndarray, derivative: int = 0) -> np.ndarray:
        """Φ or its ``derivative``-th x-derivative (1/m^k) at points x (m): shape (len(x), n)."""
        if derivative not in (0, 1, 2, 3):
            raise ValueError(f"derivative must be 0, 1, 2 or 3, got {derivative}")
        x = np.asarray(x, dtype=float).reshape(-1, 1)
        beta = self.beta[None, :]
        z = beta * x
        k = derivative
        # ζ-derivatives of −cos ζ − c sin ζ cycle with period 4.
        cz, sz = np.cos(z), np.sin(z)
        cos_part = (-cz, sz, cz, -sz)[k]
        sin_part = (-sz, -cz, sz, cz)[k]
        c = self.c[None, :]
        value = (
            self.growing[None, :] * np.exp(beta * (x - self.length))
            + 0.5 * (1.0 - c) * (-1.0) ** k * np.exp(-z)
            + cos_part
            + c * sin_part
        )
        if self.extra is not None:
            e = self.extra[:, None, :]
            value = value + (e[0] * (-1.0) ** k * np.exp(-z) - e[1] * cos_part
                             - e[2] * sin_part + (e[3] if k == 0 else 0.0)
                             + e[4] * ((z, 1.0, 0.0, 0.0)[k]))
        return value * (self.scale * self.beta**k)[None, :]


def _coefficients(lam: np.ndarray, mu: float) -> tuple[np.ndarray, np.ndarray]:
    """c and ½(1 + c)e^λ from the shear condition φ'''(L) + μλ β³ φ(L) = 0.

    With a_k, b_k the k-th ζ-derivatives of (cosh − cos) and (sinh − sin) at ζ = λ,
    c = −(a_3 + μλ a_0)/(b_3 + μλ b_0).  The denominator D = cosh λ + cos λ
    + μλ(sinh λ − sin λ) is > 0 for λ > 0; 1 + c = N/D with N free of cancellation.
    """
    e = np.exp(-lam)
    s, co = np.sin(lam), np.cos(lam)
    ml = mu * lam
    num = (e + co + s) + ml * (co - s - e)  # (b3 − a3) + μλ(b0 − a0)
    # D·e^{−λ}, i.e. the denominator scaled by e^{−λ}
    den_scaled = 0.5 * (1 + e * e) + co * e + ml * (0.5 * (1 - e * e) - s * e)
    one_plus_c_exp = num / den_scaled  # (1 + c) e^λ
    c = one_plus_c_exp * e - 1.0
    return c, 0.5 * one_plus_c_exp


@functools.lru_cache(maxsize=16)
def gauss_rule(points: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [−1, 1] (`numpy.polynomial.legendre.leggauss`),
    read-only, computed once per count: each link's modes and integrals ask for the same few
    counts again (an eigenvalue problem each time)."""
    nodes, weights = np.polynomial.legendre.leggauss(points)
    nodes.flags.writeable = False
    weights.flags.writeable = False
    return nodes, weights


def _build(length: float, lam: np.ndarray, mu: float, j: float, kind: str) -> ModeShapes:
    """Mode shapes for eigenvalues ``lam``, normalised and signed (see ModeShapes)."""
    lam = np.asarray(lam, dtype=float)
    if lam.size == 0:  # a rigid link: no modes, nothing to normalise
        return ModeShapes(length, 0, lam, lam, lam, lam, kind)
    c, growing = _coefficients(lam, mu)
    raw = ModeShapes(length, lam.size, lam, c, growing, np.ones_like(lam), kind)
    return ModeShapes(length, lam.size, lam, c, growing, _scale(raw, mu, j), kind)


def _scale(raw: ModeShapes, mu: float, j: float) -> np.ndarray:
    """Normalisation factors with sign of ``raw`` (scale 1): ∫φ²dx/L + μ φ(L)² + j L² φ'(L)²
    = 1 by composite Gauss–Legendre, φ(L) > 0."""
    length, lam = raw.length, raw.beta_l
    panels = max(2, int(np.ceil(_NORM_PANELS_PER_LAMBDA * lam.max())))
    g, w = gauss_rule(_GAUSS_POINTS)
    edges = np.linspace(0.0, length, panels + 1)
    half = 0.5 * np.diff(edges)
    x = ((edges[:-1] + half)[:, None] + half[:, None] * g[None, :]).ravel()
    wx = (half[:, None] * w[None, :]).ravel()
    phi = raw.evaluate(x)
    tip = raw.evaluate(np.array([length]))[0]
    slope = raw.evaluate(np.array([length]), 1)[0]
    norm = wx @ phi**2 / length + mu * tip**2 + j * length**2 * slope**2
    sign = np.where(tip != 0.0, np.sign(tip), np.sign(slope))
    return sign / np.sqrt(norm)


def _frequency_function(lam: np.ndarray | float, mu: float, j: float) -> np.ndarray:
    """Frequency determinant divided by cosh λ (bounded, no overflow).

    1 + cos λ cosh λ + μλ(cos λ sinh λ − sin λ cosh λ)
    − jλ³(cos λ sinh λ + sin λ cosh λ) − μjλ⁴(cos λ cosh λ − 1) = 0,
    with μ = m_t/(mL), j = J_t/(mL³).
    """
    lam = np.asarray(lam, dtype=float)
    e2 = np.exp(-2.0 * lam)
    sech, th = 2.0 * np.sqrt(e2) / (1.0 + e2), np.tanh(lam)
    s, co = np.sin(lam), np.cos(lam)
    return (
        sech + co
        + mu * lam * (co * th - s)
        - j * lam**3 * (co * th + s)
        - mu * j * lam**4 * (co - sech)
    )


def _frequency_scalar(lam: float, mu: float, j: float) -> float:
    """`_frequency_function` at one λ, with the math module (no array overhead)."""
    e2 = math.exp(-2.0 * lam)
    sech, th = 2.0 * math.sqrt(e2) / (1.0 + e2), math.tanh(lam)
    s, co = math.sin(lam), math.cos(lam)
    return (sech + co + mu * lam * (co * th - s) - j * lam**3 * (co * th + s)
            - mu * j * lam**4 * (co - sech))


def _root(a: float, b: float, mu: float, j: float) -> float:
    """The root of `_frequency_scalar` in [a, b] (a sign change), by bisection down to
    adjacent floating-point numbers: as exact as the function's evaluation allows, without
    importing scipy.optimize (a noticeable part of a command's start-up)."""
    fa = _frequency_scalar(a, mu, j)
    fb = _frequency_scalar(b, mu, j)
    if fa == 0.0:
        return a
    if fb == 0.0:
        return b
    while True:
        m = 0.5 * (a + b)
        if not a < m < b:
            return a if abs(fa) <= abs(fb) else b
        fm = _frequency_scalar(m, mu, j)
        if fm == 0.0:
            return m
        if (fm < 0.0) == (fa < 0.0):
            a, fa = m, fm
        else:
            b, fb = m, fm


def clamped_free_modes(length: float, n: int) -> ModeShapes:
    """Classical clamped–free eigenfunctions; λ_i are roots of 1 + cos λ cosh λ = 0.

    Root i lies in ((i−1)π, iπ) (where cos λ + sech λ changes sign) and is bisected to full
    precision. n = 0: no modes (a rigid link).
    """
    if n < 0:
        raise ValueError("the number of modes must be >= 0")
    return _build(length, np.array(_clamped_free_roots(n)), 0.0, 0.0, "clamped_free")


@functools.lru_cache(maxsize=32)
def _clamped_free_roots(n: int) -> tuple[float, ...]:
    """λ_1 … λ_n of the cantilever: numbers, the same for every link (cached per process)."""
    return tuple(_root((i - 1) * math.pi, i * math.pi, 0.0, 0.0) for i in range(1, n + 1))


def tip_loaded_modes(
    length: float,
    n: int,
    mass_per_length: float,
    EI: float,
    tip_mass: float,
    tip_inertia: float,
) -> ModeShapes:
    """Exact modes of a clamped beam with tip mass m_t (kg) and rotary inertia J_t (kg·m²).

    Tip conditions: EI φ''(L) = J_t ω² φ'(L), EI φ'''(L) = −m_t ω² φ(L), ω² = β⁴ EI/m.
    Adding tip inertia lowers every eigenvalue, so the n roots lie in (0, nπ); they are
    bracketed by a sign scan and refined by bisection.  (EI only fixes ω, which
    cancels from the dimensionless problem; it is accepted for a uniform signature.)
    n = 0: no modes (a rigid link).
    """
    if n < 0:
        raise ValueError("the number of modes must be >= 0")
    if mass_per_length <= 0 or EI <= 0 or length <= 0:
        raise ValueError("length, mass_per_length and EI must be positive")
    if tip_mass < 0 or tip_inertia < 0:
        raise ValueError("tip mass and inertia must be non-negative")
    if n == 0:
        return _build(length, np.empty(0), 0.0, 0.0, "tip_loaded")
    mu = tip_mass / (mass_per_length * length)
    j = tip_inertia / (mass_per_length * length**3)
    grid = np.unique(np.concatenate([
        np.geomspace(1e-4, 1.0, 200),
        np.arange(1.0, n * np.pi + np.pi / 64, np.pi / 64),
    ]))
    f = _frequency_function(grid, mu, j)
    sg = np.sign(f)
    idx = np.flatnonzero((sg[:-1] * sg[1:] < 0) | (sg[:-1] == 0))[:n]
    if idx.size < n:
        raise RuntimeError(f"found only {idx.size} of {n} tip-loaded eigenvalues")
    lam = np.array([
        grid[i] if f[i] == 0.0 else _root(float(grid[i]), float(grid[i + 1]), mu, j)
        for i in idx
    ])
    return _build(length, lam, mu, j, "tip_loaded")


def _determinant_roots(det: Callable[[float], float], n: int, upper: float,
                       what: str) -> np.ndarray:
    """The first n roots λ of a characteristic determinant det(λ) in (0, upper): bracketed
    by a sign scan, each bisected to adjacent floating-point numbers (its bracket's middle)."""
    grid = np.unique(np.concatenate([
        np.geomspace(1e-3, 1.0, 100),
        np.arange(1.0, upper, np.pi / 64),
    ]))
    f = np.array([det(x) for x in grid])
    idx = np.flatnonzero(np.sign(f[:-1]) * np.sign(f[1:]) < 0)[:n]
    if idx.size < n:
        raise RuntimeError(f"found only {idx.size} of {n} {what} eigenvalues")
    lam = np.empty(n)
    for i, k in enumerate(idx):
        a, b = float(grid[k]), float(grid[k + 1])
        fa = f[k]
        for _ in range(200):
            m = 0.5 * (a + b)
            if not a < m < b:
                break
            fm = det(m)
            if (fm < 0.0) == (fa < 0.0):
                a, fa = m, fm
            else:
                b = m
        lam[i] = 0.5 * (a + b)
    return lam


def _offset_tip_matrix(lam: float, mu: float, j: float, s: float) -> np.ndarray:
    """The conditions on (G, H, C, D) of y = G e^{β(x−L)} + H e^{−βx} + C cos βx + D sin βx at
    λ = βL for a cantilever carrying a rigid body at its tip with mass μ = m_b/(mL), rotary
    inertia about the tip section point j = J/(mL³) and first moment along the tip's tangent
    s = m_b c_x/(mL²): y(0) = y'(0) = 0, EI y''(L) = ω²(m_b c_x y + J y') and
    EI y‴(L) = −ω²(m_b y + m_b c_x y') (every entry bounded)."""
    e, co, si = math.exp(-lam), math.cos(lam), math.sin(lam)
    value, slope = np.array([1.0, e, co, si]), np.array([1.0, -e, -si, co])
    curvature, shear = np.array([1.0, e, -co, -si]), np.array([1.0, -e, si, -co])
    a = np.zeros((4, 4))
    a[0] = [e, 1.0, 1.0, 0.0]
    a[1] = [e, -1.0, 0.0, 1.0]
    a[2] = curvature - s * lam**2 * value - j * lam**3 * slope
    a[3] = shear + mu * lam * value + s * lam**2 * slope
    return a


def _offset_tip_determinant(lam: float, mu: float, j: float, s: float) -> float:
    return float(np.linalg.det(_offset_tip_matrix(lam, mu, j, s)))


def offset_tip_modes(length: float, n: int, mass_per_length: float, tip_mass: float,
                     tip_inertia: float, tip_moment: float) -> ModeShapes:
    """Exact modes of a clamped beam carrying a rigid body at its tip whose centre of mass is
    offset along the tip's tangent: ``tip_mass`` (kg), ``tip_inertia`` about the tip section
    point (kg·m², J_c + m c²) and ``tip_moment`` = m c_x (kg·m). The body's inertia couples the
    shear and moment conditions (`_offset_tip_matrix`); with ``tip_moment`` = 0 these are the
    `tip_loaded_modes`. Roots by a sign scan and bisection, each mode from the null vector."""
    if n < 0:
        raise ValueError("the number of modes must be >= 0")
    if mass_per_length <= 0 or length <= 0:
        raise ValueError("length and mass_per_length must be positive")
    if tip_mass < 0 or tip_inertia < 0 or tip_moment**2 > tip_mass * tip_inertia * (1 + 1e-12):
        raise ValueError("the tip body's mass matrix must be positive semi-definite")
    mu = tip_mass / (mass_per_length * length)
    j = tip_inertia / (mass_per_length * length**3)
    s = tip_moment / (mass_per_length * length**2)
    if n == 0:
        return _build(length, np.empty(0), mu, j, "tip_loaded")
    lam = _determinant_roots(lambda x: _offset_tip_determinant(x, mu, j, s), n,
                             (n + 1) * np.pi, "offset-tip")
    extra, growing = np.zeros((5, n)), np.empty(n)
    for i in range(n):
        G, H, C, D = np.linalg.svd(_offset_tip_matrix(lam[i], mu, j, s))[2][-1]
        growing[i] = G
        extra[:3, i] = [H - 0.5, C + 1.0, D]
    zero = np.zeros(n)
    raw = ModeShapes(length, n, lam, zero, growing, np.ones(n), "tip_loaded", extra)
    return ModeShapes(length, n, lam, zero, growing, _scale(raw, mu, j), "tip_loaded", extra)


def _hub_matrix(lam: float, mu: float, j: float, eta: float, rho: float) -> np.ndarray:
    """The hub–beam conditions on (G, H, C, D, ΘL) of y = G e^{β(x−L)} + H e^{−βx} + C cos βx
    + D sin βx at λ = βL (every entry bounded): the clamp to the hub, y(0) = ρ ΘL and
    y'(0) L/λ = ΘL/λ; the tip body, EI y''(L) = J_t ω² y'(L) and EI y'''(L) = −m_t ω² y(L);
    the hub, η λ⁴ ΘL + λ²(y''(0) − ρλ y'''(0)) (scaled) = 0, ρ = r/L, η = J_h/(mL³)."""
    e, co, si = math.exp(-lam), math.cos(lam), math.sin(lam)
    value, slope = np.array([1.0, e, co, si]), np.array([1.0, -e, -si, co])
    curvature, shear = np.array([1.0, e, -co, -si]), np.array([1.0, -e, si, -co])
    a = np.zeros((5, 5))
    a[0] = [e, 1.0, 1.0, 0.0, -rho]
    a[1] = [e, -1.0, 0.0, 1.0, -1.0 / lam]
    a[2, :4] = curvature - j * lam**3 * slope
    a[3, :4] = shear + mu * lam * value
    a[4] = [e - rho * lam * e, 1.0 + rho * lam, -1.0, rho * lam, eta * lam**2]
    return a


def _hub_determinant(lam: float, mu: float, j: float, eta: float, rho: float) -> float:
    return float(np.linalg.det(_hub_matrix(lam, mu, j, eta, rho)))


@functools.lru_cache(maxsize=64)
def _hub_roots(n: int, mu: float, j: float, eta: float, rho: float) -> tuple[float, ...]:
    """The first n roots of `_hub_determinant` (a run's moved scenarios, a sweep's cases
    and the equilibrium of one run ask for the same link again)."""
    return tuple(_determinant_roots(lambda x: _hub_determinant(x, mu, j, eta, rho), n,
                                    (n + 2) * np.pi, "hub-loaded"))


def hub_loaded_modes(
    length: float,
    n: int,
    mass_per_length: float,
    EI: float,
    tip_mass: float,
    tip_inertia: float,
    hub_inertia: float,
    radius: float = 0.0,
) -> ModeShapes:
    """Modes of a link on a free hub, in the link's clamped frame: for each of the first n
    natural modes y_i of the hub–beam system (the beam clamped at ``radius`` (m) to a hub of
    inertia ``hub_inertia`` (kg·m²) turning freely about its fixed centre, tip mass (kg) and
    rotary inertia (kg·m²) at its tip), φ_i = y_i − Θ_i (r + x), which has φ(0) = φ'(0) = 0.
    With the joint angle beside them these span y_1 … y_n: the first n frequencies of a
    single link on a free joint are exact, where clamped modes miss the n-th by tens of
    percent when the hub is light (docs/modes.md). Roots by a sign scan and bisection, each
    mode from the null vector of `_hub_matrix`; normalised as the other kinds."""
    if n < 0:
        raise ValueError("the number of modes must be >= 0")
    if mass_per_length <= 0 or EI <= 0 or length <= 0:
        raise ValueError("length, mass_per_length and EI must be positive")
    if min(tip_mass, tip_inertia, hub_inertia, radius) < 0:
        raise ValueError("tip body, hub inertia and radius must be non-negative")
    if n == 0:
        return _build(length, np.empty(0), 0.0, 0.0, "hub_loaded")
    args = (tip_mass / (mass_per_length * length), tip_inertia / (mass_per_length * length**3),
            hub_inertia / (mass_per_length * length**3), radius / length)
    lam = np.array(_hub_roots(n, *args))
    extra, growing = np.empty((5, n)), np.empty(n)
    for i in range(n):
        G, H, C, D, T = np.linalg.svd(_hub_matrix(lam[i], *args))[2][-1]
        # in the bracket of ModeShapes with c = 0: growing e^{β(x−L)} + ½e^{−βx} − cos βx + extra
        growing[i] = G
        extra[:, i] = [H - 0.5, C + 1.0, D, -args[3] * T, -T / lam[i]]
    zero = np.zeros(n)
    raw = ModeShapes(length, n, lam, zero, growing, np.ones(n), "hub_loaded", extra)
    return ModeShapes(length, n, lam, zero, growing, _scale(raw, args[0], args[1]),
                      "hub_loaded", extra)


def pinned_pinned_modes(length: float, n: int) -> ModeShapes:
    """Modes of a link pinned at both ends, in the frame of its chord: φ_i = √2 sin(iπx/L)
    (λ_i = iπ, ∫φ_i² dx = L, φ_i'(0) > 0), for a member whose far end a closed loop holds
    (a four-bar's coupler, a slider-crank's connecting rod) on a free joint. A tip mass at the
    held end does not move the shapes (φ(L) = 0)."""
    if n < 0:
        raise ValueError("the number of modes must be >= 0")
    lam = np.pi * np.arange(1, n + 1, dtype=float)
    extra = np.zeros((5, n))
    extra[1], extra[2] = 1.0, 2.0  # the bracket −cos − sin + cos + 2 sin = sin βx
    return ModeShapes(length, n, lam, np.ones(n), np.zeros(n), np.full(n, math.sqrt(2.0)),
                      "pinned_pinned", extra if n else None)


def _pinned_loaded_matrix(lam: float, j: float) -> np.ndarray:
    """The conditions on (G, H, C, D) of y = G e^{β(x−L)} + H e^{−βx} + C cos βx + D sin βx at
    λ = βL for a beam pinned at both ends of its chord carrying at its far end a body of
    rotary inertia j = J/(mL³) about the end: y(0) = y''(0) = 0, y(L) = 0 and
    EI y''(L) = J ω² y'(L) (every entry bounded)."""
    e, co, si = math.exp(-lam), math.cos(lam), math.sin(lam)
    slope, curvature = np.array([1.0, -e, -si, co]), np.array([1.0, e, -co, -si])
    a = np.zeros((4, 4))
    a[0] = [e, 1.0, 1.0, 0.0]
    a[1] = [e, 1.0, -1.0, 0.0]
    a[2] = [1.0, e, co, si]
    a[3] = curvature - j * lam**3 * slope
    return a


def pinned_loaded_modes(length: float, n: int, mass_per_length: float,
                        tip_inertia: float) -> ModeShapes:
    """Exact modes of a link pinned at both ends of its chord (the frame of `pinned_pinned`)
    whose far end carries a body of rotary inertia ``tip_inertia`` (kg·m², about the end):
    the end turns with the link's slope there, so its inertia bends the link, which the sines
    (no curvature at the ends) represent only slowly. A mass at the held end does not move
    (φ(L) = 0); with no inertia these are the sines. Roots by a sign scan and bisection, each
    mode from the null vector of `_pinned_loaded_matrix`."""
    if n < 0:
        raise ValueError("the number of modes must be >= 0")
    if mass_per_length <= 0 or length <= 0 or tip_inertia < 0:
        raise ValueError("length and mass_per_length must be positive, tip_inertia >= 0")
    j = tip_inertia / (mass_per_length * length**3)
    if n == 0 or j == 0.0:
        return pinned_pinned_modes(length, n)
    lam = _determinant_roots(lambda x: float(np.linalg.det(_pinned_loaded_matrix(x, j))), n,
                             (n + 1) * np.pi, "pinned-loaded")
    extra, growing = np.zeros((5, n)), np.empty(n)
    for i in range(n):
        G, H, C, D = np.linalg.svd(_pinned_loaded_matrix(lam[i], j))[2][-1]
        growing[i] = G
        extra[:3, i] = [H - 0.5, C + 1.0, D]
    zero = np.zeros(n)
    raw = ModeShapes(length, n, lam, zero, growing, np.ones(n), "pinned_loaded", extra)
    scale = _scale(raw, 0.0, j)
    # signed as the sines: φ_i'(0) > 0 (φ(L) = 0 cannot sign them)
    scale = scale * np.sign(raw.evaluate(np.array([0.0]), 1)[0] * scale)
    return ModeShapes(length, n, lam, zero, growing, scale, "pinned_loaded", extra)


def mode_shapes_for(link: Link) -> ModeShapes:
    """The link's assumed modes, chosen by ``link.mode_shapes``."""
    if link.mode_shapes == "clamped_free":
        return clamped_free_modes(link.length, link.modes)
    if link.mode_shapes == "tip_loaded":
        mass, inertia, moment = link.tip_body()
        if moment:
            return offset_tip_modes(link.length, link.modes, link.mass_per_length, mass,
                                    inertia, moment)
        return tip_loaded_modes(link.length, link.modes, link.mass_per_length, link.EI,
                                mass, inertia)
    if link.mode_shapes == "pinned_pinned":
        return pinned_pinned_modes(link.length, link.modes)
    if link.mode_shapes == "pinned_loaded":
        return pinned_loaded_modes(link.length, link.modes, link.mass_per_length,
                                   link.tip_body()[1])
    raise ValueError(f"unknown mode_shapes {link.mode_shapes!r} for link {link.name!r}")
