"""Reference problems of the validation suite, as code.

In the spirit of Drake's ``multibody/benchmarks``: each benchmark holds its parameters (SI
units), the source it comes from, the published values transcribed once, and helpers that build
the flexlink model of it. Tests (``tests/validation/test_rotating_beam.py``,
``tests/validation/test_spinup.py``) and the figures of ``docs/validation.md``
(``scripts/validation_figures.py``) use the same objects, so the page shows what the tests check.

Contents
--------
``WRIGHT_1982``
    Natural frequencies of the uniform rotating cantilever (hub radius 0), dimensionless,
    Wright, Smith, Thresher & Wang (1982).
``KANE_RYAN_BANERJEE_1987``
    The spin-up beam of Kane, Ryan & Banerjee (1987).
``DE_LUCA_SICILIANO_1991``
    The two-link arm of De Luca & Siciliano (1991) and the published clamped-mass frequencies
    of its links.
``RotatingBeamFE``
    An independent reference solver for both: cubic Hermite finite elements of the linear
    rotating-beam equation, and a Newmark integration of its spin-up response.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import eigh

from flexlink.model import Chain, Link, PointSensor, Scenario, SimulationSettings
from flexlink.motion import Spinup

# --------------------------------------------------------------------------------------------
# Rotating uniform cantilever: natural frequencies vs. rotation speed
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class RotatingCantileverTable:
    """Published natural frequencies of a uniform Euler–Bernoulli cantilever on a hub of zero
    radius spinning at the constant rate Ω, for bending OUT of the plane of rotation (flapwise).

    Dimensionless: speed γ = Ω·√(m̄L⁴/EI), frequency ω·√(m̄L⁴/EI) (m̄ mass per length, kg/m;
    L length, m; EI bending stiffness, N·m²; Ω, ω in rad/s). With m̄ = 100 kg/m, L = 31.623 m,
    EI = 10⁸ N·m² (the blade of the BModes verification) both scales are 1, so the table reads
    in rad/s.

    flexlink's links bend IN the plane of rotation (chordwise, lead–lag). For an inextensible
    uniform beam on a hub of zero radius the in-plane equation differs from the flapwise one
    only by the centrifugal softening term −m̄Ω²w, so ω_in² = ω_flap² − Ω² (γ² in
    dimensionless form) — see ``in_plane``.
    """

    citation: str
    transcribed_from: str
    gamma: tuple[float, ...]  # dimensionless rotation speed γ
    flap: tuple[tuple[float, ...], ...]  # flap[i][k]: mode i+1 at gamma[k], dimensionless
    half_unit: float  # bound of the rounding of every printed value (dimensionless)

    def flapwise(self, mode: int) -> np.ndarray:
        """Published dimensionless flapwise frequency of ``mode`` (1-based) at every γ."""
        return np.array(self.flap[mode - 1])

    def in_plane(self, mode: int) -> np.ndarray:
        """Dimensionless in-plane frequency √(ω_flap² − γ²) of ``mode`` at every γ."""
        flap = self.flapwise(mode)
        return np.sqrt(flap**2 - np.asarray(self.gamma) ** 2)

    def in_plane_rounding(self, mode: int) -> np.ndarray:
        """Relative error bound that the table's rounding puts on ``in_plane(mode)``.

        d√(f² − γ²)/df = f/√(f² − γ²), so a rounding of ±half_unit in f becomes
        ±half_unit·f/ω_in² relative to ω_in.
        """
        flap, inplane = self.flapwise(mode), self.in_plane(mode)
        return self.half_unit * flap / inplane**2


WRIGHT_1982 = RotatingCantileverTable(
    citation=(
        "A. D. Wright, C. E. Smith, R. W. Thresher, J. L. C. Wang, 'Vibration modes of "
        "centrifugally stiffened beams', ASME J. Appl. Mech. 49(1):197-202, 1982 "
        "(Frobenius series solution, uniform cantilever, hub radius 0)"
    ),
    transcribed_from=(
        "G. S. Bir, 'Blades and towers modal analysis code (BModes): verification of blade modal "
        "analysis capability', AIAA 2009-1035 (NREL/CP-500-44749), Table 3a, analytical column; "
        "as transcribed in the pyBmodes test suite (SMI-Lab-Inha/pybmodes, "
        "tests/fem/test_rotating_uniform_blade.py)"
    ),
    gamma=(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0),
    flap=(
        (3.516, 3.682, 4.137, 4.797, 5.585, 6.450, 7.360, 8.300, 9.257, 10.226, 11.202, 12.184,
         13.170),
        (22.035, 22.181, 22.615, 23.320, 24.273, 25.446, 26.809, 28.334, 29.995, 31.771, 33.640,
         35.589, 37.603),
        (61.697, 61.842, 62.273, 62.985, 63.967, 65.205, 66.684, 68.386, 70.293, 72.387, 74.649,
         77.064, 79.615),
    ),
    # Half a unit of the third decimal, plus 5e-5: the 3-decimal table rounds Wright's 4-decimal
    # values (22.0345 printed as 22.035, while λ₂² = 22.03449), so rounding happened twice.
    half_unit=5.5e-4,
)

# Non-rotating check of the γ = 0 row: λᵢ² with λᵢ the roots of 1 + cos λ cosh λ = 0.
CANTILEVER_LAMBDA2 = (1.875104068711961**2, 4.694091132974175**2, 7.854757438237613**2)


# --------------------------------------------------------------------------------------------
# Kane, Ryan & Banerjee (1987): spin-up of a cantilever on a hub
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SpinupBeam:
    """A uniform cantilever clamped to a hub of zero radius; the hub spins up from rest to Ω in
    ``spin_time`` T with rate (Ω/T)(t − (T/2π) sin(2πt/T)) and keeps Ω afterwards (flexlink's
    ``Spinup`` is this profile). The beam bends in the plane of rotation.

    The published results are plots of the tip deflection vs. time (no tabulated values found); the
    linear ("conventional") model without geometric stiffening diverges for Ω above the first
    cantilever frequency, the model with the motion-induced stiffness stays bounded.
    """

    citation: str
    length: float = 10.0  # m
    mass_per_length: float = 1.2  # kg/m
    EI: float = 14_000.0  # N·m² (E = 7·10¹⁰ Pa, I = 2·10⁻⁷ m⁴)
    spin_time: float = 15.0  # s, T
    t_end: float = 20.0  # s, simulated time
    rates: tuple[float, ...] = (4.0, 10.0)  # rad/s, final spin rates Ω of the published cases
    dt_out: float = 0.01  # s, output interval used here (not part of the problem)

    @property
    def time_scale(self) -> float:
        """√(m̄L⁴/EI), s: converts Ω and ω to the dimensionless γ of ``RotatingCantileverTable``."""
        return math.sqrt(self.mass_per_length * self.length**4 / self.EI)

    @property
    def first_frequency(self) -> float:
        """First clamped–free frequency λ₁²/√(m̄L⁴/EI), rad/s (3.798 rad/s): the divergence
        speed of the model without geometric stiffening, whose in-plane ω₁² = λ₁⁴EI/(m̄L⁴) − Ω²."""
        return CANTILEVER_LAMBDA2[0] / self.time_scale

    def link(self, modes: int) -> Link:
        return Link("beam", self.length, self.mass_per_length, self.EI, modes=modes)

    def motion(self, rate: float) -> Spinup:
        """The spin-up to ``rate`` (rad/s) starting at t = 0."""
        return Spinup(to_rate_deg_s=math.degrees(rate), start=0.0, duration=self.spin_time)

    def scenario(self, rate: float, modes: int, stiffening: bool,
                 t_end: float | None = None) -> Scenario:
        """flexlink scenario with a ``tip`` deflection sensor (m, in the rotating clamped frame,
        positive counter-clockwise, i.e. in the direction of rotation)."""
        chain = Chain((self.link(modes),), (self.motion(rate),))
        sensors = (PointSensor("tip", "deflection", 0, self.length),)
        settings = SimulationSettings(t_end=self.t_end if t_end is None else t_end,
                                      dt_out=self.dt_out, geometric_stiffening=stiffening)
        return Scenario(chain, sensors, settings, name=f"krb_spinup_{rate:g}")

    def crossing_time(self, rate: float, omega: float) -> float:
        """Time (s) at which the spin-up to ``rate`` passes the hub rate ``omega`` (rad/s)."""
        t = np.linspace(0.0, self.spin_time, 200_001)
        hub_rate = self.motion(rate).evaluate(t)[1]
        return float(t[np.argmax(hub_rate >= omega)])


KANE_RYAN_BANERJEE_1987 = SpinupBeam(
    citation=(
        "T. R. Kane, R. R. Ryan, A. K. Banerjee, 'Dynamics of a cantilever beam attached to a "
        "moving base', J. Guidance, Control, and Dynamics 10(2):139-151, 1987"
    ),
)


# --------------------------------------------------------------------------------------------
# De Luca & Siciliano (1991): two-link arm whose first link carries the second joint's hub
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TwoLinkArm:
    """Two equal uniform links; link 1's tip carries the hub of joint 2 (mass, rotary inertia),
    link 2's tip a payload. The published frequencies are each link's clamped-mass
    eigenfrequencies: link 2 with the payload at its tip, link 1 with everything outboard
    lumped at its tip (the straight arm: ``lumped_tip_body``)."""

    citation: str
    length: float  # m, each link
    mass_per_length: float  # kg/m
    EI: float  # N·m²
    joint2_mass: float  # kg, hub of joint 2 at link 1's tip
    joint2_inertia: float  # kg·m²
    payload_mass: float  # kg, at link 2's tip
    payload_inertia: float  # kg·m²
    published_hz: tuple[tuple[float, ...], ...]  # per link, its first two, Hz (2 decimals)

    def lumped_tip_body(self) -> tuple[float, float]:
        """(kg, kg·m² about link 1's tip) of the hub, link 2 and the payload, straight arm."""
        m2 = self.mass_per_length * self.length
        mass = self.joint2_mass + m2 + self.payload_mass
        inertia = (self.joint2_inertia + m2 * self.length**2 / 3 + self.payload_inertia
                   + self.payload_mass * self.length**2)
        return mass, inertia


DE_LUCA_SICILIANO_1991 = TwoLinkArm(
    citation=(
        "A. De Luca, B. Siciliano, 'Closed-form dynamic model of planar multilink lightweight "
        "robots', IEEE Trans. Systems, Man, and Cybernetics 21(4):826-839, 1991 (two-link "
        "example: f11 = 0.48, f12 = 1.80, f21 = 2.18, f22 = 15.91 Hz)"
    ),
    length=0.5, mass_per_length=0.2, EI=1.0, joint2_mass=1.0, joint2_inertia=0.1,
    payload_mass=0.1, payload_inertia=0.0005,
    published_hz=((0.48, 1.80), (2.18, 15.91)),
)


# --------------------------------------------------------------------------------------------
# Independent reference: finite elements of the linear rotating-beam equation
# --------------------------------------------------------------------------------------------


@dataclass
class RotatingBeamFE:
    """Cubic Hermite finite elements (consistent mass) of a uniform cantilever on a hub of zero
    radius, in the frame rotating with the hub at rate Ω(t):

        m̄ ẅ + EI w'''' − (N w')' − s m̄ Ω² w = −m̄ x Ω̇,     N(x) = m̄ Ω² (L² − x²)/2,

    s = 1 for bending in the plane of rotation (centrifugal softening; flexlink's case), s = 0
    out of it (flapwise). This is the classical linear theory with centrifugal stiffening; the
    reference shares the equation with flexlink's stiffened model but none of its code or
    discretisation (no assumed modes, no Magnus integrator). Frequencies converge from above
    like h⁴; the geometric stiffness uses 4-point Gauss quadrature (exact here).
    """

    length: float  # m
    mass_per_length: float  # kg/m
    EI: float  # N·m²
    elements: int = 40
    K: np.ndarray = field(init=False, repr=False)  # bending stiffness
    G: np.ndarray = field(init=False, repr=False)  # geometric stiffness per Ω²
    M: np.ndarray = field(init=False, repr=False)  # consistent mass
    F: np.ndarray = field(init=False, repr=False)  # load vector of −m̄x per unit Ω̇

    def __post_init__(self) -> None:
        L, m, n = self.length, self.mass_per_length, self.elements
        h = L / n
        ke = self.EI / h**3 * np.array([
            [12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
            [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
        dofs = 2 * (n + 1)
        K, G, M, F = (np.zeros((dofs, dofs)), np.zeros((dofs, dofs)), np.zeros((dofs, dofs)),
                      np.zeros(dofs))
        nodes, weights = np.polynomial.legendre.leggauss(4)
        xi, wq = (nodes + 1) / 2, weights / 2
        shape = np.array([1 - 3 * xi**2 + 2 * xi**3, h * (xi - 2 * xi**2 + xi**3),
                          3 * xi**2 - 2 * xi**3, h * (xi**3 - xi**2)])
        slope = np.array([6 * xi**2 - 6 * xi, h * (1 - 4 * xi + 3 * xi**2),
                          6 * xi - 6 * xi**2, h * (3 * xi**2 - 2 * xi)]) / h
        for e in range(n):
            block = slice(2 * e, 2 * e + 4)
            x = (e + xi) * h
            axial = 0.5 * m * (L**2 - x**2)
            K[block, block] += ke
            G[block, block] += h * (slope * (wq * axial)) @ slope.T
            M[block, block] += h * m * (shape * wq) @ shape.T
            F[block] -= h * m * shape @ (wq * x)
        keep = slice(2, None)  # clamped: w(0) = w'(0) = 0
        self.K, self.G, self.M, self.F = K[keep, keep], G[keep, keep], M[keep, keep], F[keep]

    def stiffness(self, rate: float | np.ndarray, in_plane: bool = True) -> np.ndarray:
        """K + Ω²(G − s M) at hub rate Ω (rad/s)."""
        r2 = np.asarray(rate, dtype=float)[..., None, None] ** 2
        return self.K + r2 * (self.G - (self.M if in_plane else 0.0))

    def frequencies(self, rate: float, count: int, in_plane: bool = True) -> np.ndarray:
        """Lowest ``count`` natural frequencies (rad/s) relative to the frame spinning at Ω.

        Solved as the pencil (M, K_Ω) for 1/ω², so that the lowest modes keep their relative
        accuracy (eigh(K, M) loses ~eps·cond(K) on them). Past a divergence speed K_Ω is not
        positive definite; then eigh(K_Ω, M) is used and a negative ω² comes back as −√|ω²|."""
        K = self.stiffness(rate, in_plane)
        try:
            inv = eigh(self.M, K, eigvals_only=True)[::-1][:count]
        except np.linalg.LinAlgError:
            w2 = eigh(K, self.M, eigvals_only=True)[:count]
            return np.sign(w2) * np.sqrt(np.abs(w2))
        return 1.0 / np.sqrt(inv)

    def spinup_tip_deflection(self, motion: Spinup, t_end: float, dt_out: float,
                              dt: float = 2e-3) -> tuple[np.ndarray, np.ndarray]:
        """Tip deflection (m) at t = 0, dt_out, …, t_end under a prescribed hub motion, from rest.

        Newmark average acceleration (trapezoidal rule: second order, no numerical damping),
        step ``dt``; the stiffness follows Ω(t) at every step.
        """
        steps, every = round(t_end / dt), round(dt_out / dt)
        t = np.arange(steps + 1) * dt
        _, rate, acc = motion.evaluate(t)
        dofs = self.M.shape[0]
        x, v, a = np.zeros(dofs), np.zeros(dofs), np.zeros(dofs)
        out = np.zeros(steps // every + 1)
        b = 0.25 * dt * dt
        for k in range(1, steps + 1):
            predictor = x + dt * v + b * a
            K = self.stiffness(rate[k])
            a_new = np.linalg.solve(self.M + b * K, acc[k] * self.F - K @ predictor)
            x = predictor + b * a_new
            v = v + 0.5 * dt * (a + a_new)
            a = a_new
            if k % every == 0:
                out[k // every] = x[-2]
        return t[::every], out
