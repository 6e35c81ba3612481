"""Modes of a link carrying a body inside its span (`modes.section_loaded`), the default basis
of a slider's parent whose line passes through a section inside it (`line_at`), and the arc
quadrature split at that section (docs/modes.md, "outboard_loaded")."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.linalg import eigh

from flexlink.dynamics.arc import ArcQuadrature
from flexlink.dynamics.first_order import carried_section, chain_modal_data
from flexlink.dynamics.prismatic import with_slider_masses
from flexlink.model import ZERO, Chain, Link, PrismaticJoint, TorqueDrive
from flexlink.modes import hub_loaded_modes, modal_data, tip_loaded_modes
from flexlink.modes.section_loaded import section_loaded_modes
from flexlink.motion import Cycloidal

L, M, EI = 1.0, 2.0, 400.0


def _hermite(at: float, mass: float, inertia: float, elements: int, tip_mass: float = 0.0,
             tip_inertia: float = 0.0, hub: float | None = None) -> np.ndarray:
    """Clamped-beam frequencies (rad/s) of cubic Hermite elements with a node at ``at``
    carrying the body: an independent discretisation, converging from above like h⁴. With
    ``hub`` (kg·m²) the root turns freely on a hub of that inertia (its rigid turn left out)."""
    inner = max(1, round(elements * at / L))
    nodes = np.concatenate([np.linspace(0.0, at, inner + 1),
                            np.linspace(at, L, elements - inner + 1)[1:]])
    K, Mm = (np.zeros((2 * nodes.size,) * 2) for _ in range(2))
    for e, h in enumerate(np.diff(nodes)):
        k = EI / h**3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                                  [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
        m = M * h / 420 * np.array([[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
                                    [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
        s = slice(2 * e, 2 * e + 4)
        K[s, s] += k
        Mm[s, s] += m
    Mm[2 * inner, 2 * inner] += mass
    Mm[2 * inner + 1, 2 * inner + 1] += inertia
    Mm[-2, -2] += tip_mass
    Mm[-1, -1] += tip_inertia
    if hub is not None:  # the root's slope is the hub's turn: K is singular, shift it
        Mm[1, 1] += hub
        shift = 1e3
        mu = eigh(Mm[1:, 1:], K[1:, 1:] + shift * Mm[1:, 1:], eigvals_only=True)[::-1]
        return np.sqrt(1.0 / mu[1:13] - shift)
    # the pencil (M, K): eigh(K, M) would lose eps·cond(K) on the low frequencies
    return 1.0 / np.sqrt(eigh(Mm[2:, 2:], K[2:, 2:], eigvals_only=True)[::-1][:12])


def _exact(at: float, mass: float, inertia: float, **tip: float) -> np.ndarray:
    """Richardson's extrapolation of `_hermite` on 100 and 200 elements (error ∝ h⁴)."""
    coarse, fine = (_hermite(at, mass, inertia, n, **tip) for n in (100, 200))
    return fine + (fine - coarse) / 15.0


def _ritz(shapes, at: float, mass: float, inertia: float) -> np.ndarray:
    """Frequencies (rad/s) of the clamped beam with the body at ``at`` on ``shapes``."""
    link = Link("beam", L, M, EI, modes=shapes.n)
    d = modal_data(link, shapes=shapes, quadrature_points=4000)
    x = np.array([at])
    value, slope = shapes.evaluate(x)[0], shapes.evaluate(x, 1)[0]
    mass_matrix = d.mass_matrix + mass * np.outer(value, value) + inertia * np.outer(slope, slope)
    return np.sqrt(eigh(d.stiffness_matrix, mass_matrix, eigvals_only=True))


def test_on_a_free_hub_the_frequencies_are_those_of_the_hub_beam_system() -> None:
    """A beam on a free hub (0.3 kg·m²) with a body at 0.45 m: the section-loaded modes on
    the hub give the system's first six elastic frequencies (frame elements, the hub's
    inertia on the root's rotation): within 2.8e-10 (tolerance 1e-8)."""
    shapes = section_loaded_modes(L, 6, M, 0.45, 0.7, 0.04, 0.2, 0.0, 0.3, 0.0)
    omega = shapes.beta**2 * np.sqrt(EI / M)
    coarse, fine = (_hermite(0.45, 0.7, 0.04, n, tip_mass=0.2, hub=0.3) for n in (100, 200))
    exact = (fine + (fine - coarse) / 15.0)[:6]
    assert np.abs(omega / exact - 1.0).max() < 1e-8


@pytest.mark.parametrize("at, mass, inertia, tip", [
    (0.6, 0.98, 0.1, {}), (0.3, 1.0, 0.05, {"tip_mass": 0.3, "tip_inertia": 0.01}),
    (0.6, 5.0, 1.0, {}), (0.05, 1.0, 0.1, {}), (0.97, 1.0, 0.1, {})])
def test_frequencies_are_those_of_the_loaded_beam(at, mass, inertia, tip) -> None:
    """The roots λ_i give the frequencies of an independent finite-element model of the beam
    with the body at x_a (within 1e-7 after extrapolation; measured ≤ 2.2e-8, the
    reference's own error)."""
    shapes = section_loaded_modes(L, 6, M, at, mass, inertia, **tip)
    omega = shapes.beta**2 * np.sqrt(EI / M)
    exact = _exact(at, mass, inertia, **tip)[:6]
    assert np.abs(omega / exact - 1.0).max() < 1e-7


def test_the_shapes_are_orthogonal_with_the_body_and_satisfy_its_jumps() -> None:
    """Φᵀ(M + body)Φ = mL·I and Φ''ᵀEIΦ'' = mL·diag(ω²) with the quadrature split at x_a;
    across x_a φ and φ' are continuous, EI[φ''] = −J ω² φ' and EI[φ'''] = m ω² φ."""
    at, mass, inertia = 0.55, 1.3, 0.08
    shapes = section_loaded_modes(L, 8, M, at, mass, inertia)
    d = modal_data(Link("beam", L, M, EI, modes=8), shapes=shapes)
    x = np.array([at])
    value, slope = shapes.evaluate(x)[0], shapes.evaluate(x, 1)[0]
    loaded = d.mass_matrix + mass * np.outer(value, value) + inertia * np.outer(slope, slope)
    omega2 = shapes.beta**4 * EI / M
    assert np.abs(loaded / (M * L) - np.eye(8)).max() < 1e-11
    assert np.abs(d.stiffness_matrix / (M * L) - np.diag(omega2)).max() < 1e-10 * omega2.max()
    side = np.array([at - 1e-13, at + 1e-13])
    jump = [np.diff(shapes.evaluate(side, k), axis=0)[0] for k in range(4)]
    scale = [np.abs(shapes.evaluate(np.linspace(0, L, 50), k)).max(0) for k in range(4)]
    assert np.all(np.abs(jump[0]) < 1e-9 * scale[0]) and np.all(np.abs(jump[1]) < 1e-9 * scale[1])
    assert np.allclose(EI * jump[2], -inertia * omega2 * slope, rtol=1e-8, atol=1e-8 * scale[2].max())
    assert np.allclose(EI * jump[3], mass * omega2 * value, rtol=1e-8, atol=1e-8 * scale[3].max())


def test_without_a_body_these_are_the_tip_and_hub_loaded_modes() -> None:
    x = np.linspace(0.0, L, 9)
    pairs = [(tip_loaded_modes(L, 5, M, EI, 0.3, 0.01),
              section_loaded_modes(L, 5, M, 0.6, 0.0, 0.0, 0.3, 0.01)),
             (hub_loaded_modes(L, 5, M, EI, 0.3, 0.01, 0.4, 0.1),
              section_loaded_modes(L, 5, M, 0.6, 0.0, 0.0, 0.3, 0.01, 0.4, 0.1))]
    for a, b in pairs:
        assert np.abs(a.beta_l - b.beta_l).max() < 1e-12
        for k in range(4):
            assert np.abs(a.evaluate(x, k) - b.evaluate(x, k)).max() < 1e-12 * np.abs(
                a.evaluate(x, k)).max()


def test_the_loaded_basis_converges_where_the_tip_placed_one_does_not() -> None:
    """The beam with a body (m_a = 0.98 kg, J_a = 0.1 kg·m²) at 0.6 m, 4 modes: the basis with
    the body at x_a gives its first four frequencies exactly (1.5e-8, the reference's
    error); the tip-placed basis (the body moved to the tip, `tip_loaded` modes: the default
    before) misses them by 0.12%, 7.7%, 28% and 171%, and 30 clamped–free modes still by
    0.01%, 0.69%, 2.0% and 1.4% (a jump in curvature converges only like N⁻¹)."""
    at, mass, inertia = 0.6, 0.98, 0.1
    exact = _exact(at, mass, inertia)[:4]
    new = _ritz(section_loaded_modes(L, 4, M, at, mass, inertia), at, mass, inertia)
    old = _ritz(tip_loaded_modes(L, 4, M, EI, mass, inertia + mass * (L - at) ** 2),
                at, mass, inertia)
    assert np.abs(new / exact - 1).max() < 1e-7
    assert np.abs(old / exact - 1).max() > 0.05


def _telescope(line_at: float | None, modes: int = 4) -> Chain:
    boom = Link("boom", 1.0, 2.0, 400.0, modes=modes, mode_shapes="auto")
    arm = Link("arm", 0.8, 0.6, 12.0, tip_mass=0.2, modes=modes, mode_shapes="auto")
    hold = Cycloidal(0.0, 0.0, 0.0, 1.0)
    slide = PrismaticJoint(TorqueDrive(ZERO, 0.1), 0.0, 0.0, mass=0.5, at=line_at)
    return with_slider_masses(Chain((boom, arm), (hold, slide)))


def test_a_slider_inside_the_span_loads_its_parent_at_the_section() -> None:
    """The default (`auto` → outboard_loaded) basis of a slider's parent carries the block
    and the carried link at `line_at`; at the tip (or without `line_at`) it is the
    tip-loaded basis as before."""
    from flexlink.model.basis import chosen_mode_shapes

    inside = _telescope(0.6)
    kinds = chosen_mode_shapes(inside)
    assert kinds[0] == "outboard_loaded"
    chain = Chain(tuple(dataclasses.replace(lk, mode_shapes=k)
                        for lk, k in zip(inside.links, kinds)), inside.joints)
    assert carried_section(chain, 0) == 0.6
    data = chain_modal_data(chain)[0]
    assert data.shapes.breaks == (0.6,)
    # the carried body: block, arm and its tip mass, turning about the section point
    carried = 0.5 + 0.6 * 0.8 + 0.2
    x = np.array([0.6])
    value, slope = data.shapes.evaluate(x)[0], data.shapes.evaluate(x, 1)[0]
    inertia = 0.5 * 0.1**2 + 0.6 * ((0.1 + 0.8) ** 3 - 0.1**3) / 3 + 0.2 * 0.9**2
    loaded = (data.mass_matrix + carried * np.outer(value, value)
              + inertia * np.outer(slope, slope))
    assert np.abs(loaded / 2.0 - np.eye(4)).max() < 1e-10
    for at in (None, 1.0):
        tip = _telescope(at)
        chain = Chain(tuple(dataclasses.replace(lk, mode_shapes=k) for lk, k in
                            zip(tip.links, chosen_mode_shapes(tip))), tip.joints)
        assert carried_section(chain, 0) is None
        assert not hasattr(chain_modal_data(chain)[0].shapes, "breaks")


def test_arc_quadrature_split_at_a_break() -> None:
    """With a break the cumulative rows integrate a function with a kink there exactly
    (piecewise polynomials); without one the rule is the uniform one, bit for bit."""
    plain = ArcQuadrature(1.0, 2, 12)
    split = ArcQuadrature(1.0, 2, 12, (0.37,))
    assert split.size == 36 and np.all(np.diff(split.x) > 0)
    assert np.array_equal(ArcQuadrature(1.0, 2, 12, ()).x, plain.x)

    def f(x: np.ndarray) -> np.ndarray:
        return np.abs(x - 0.37) ** 3 + x

    def F(s: np.ndarray) -> np.ndarray:
        return (np.sign(s - 0.37) * np.abs(s - 0.37) ** 4 + 0.37**4) / 4 + s**2 / 2

    s = np.linspace(0.0, 1.0, 41)
    assert np.abs(split.cumulative(s) @ f(split.x) - F(s)).max() < 1e-14
    assert np.abs(plain.cumulative(s) @ f(plain.x) - F(s)).max() > 1e-8
