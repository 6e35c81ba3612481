"""Natural frequencies of the clamped link from its modal matrices vs. exact/published values."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh

from flexlink.model import Link
from flexlink.modes import modal_data, tip_loaded_modes

L, M_PER_L, EI = 1.3, 2.7, 45.0  # m, kg/m, N·m² (deliberately not unity)

# Roots of 1 + cos λ cosh λ = 0 (Blevins, "Formulas for natural frequency and mode shape").
TABULATED_BETA_L = [1.875104068711961, 4.694091132974175, 7.854757438237613, 10.99554073487547]

# Cantilever with tip mass m_t = mL, no rotary inertia: λ_i² (Math. Probl. Eng. 2017,
# art. 1568019, Table 1, column J = 0, from the frequency equation of Laura et al. 1974).
TIP_MASS_RATIO_ONE_LAMBDA2 = [1.557298, 16.25009, 50.89584, 105.1983, 179.2320]


def reference_beta_l(i: int) -> float:
    """λ_i: tabulated for i ≤ 4, else (2i−1)π/2 + (−1)^{i+1} sech((2i−1)π/2).

    The bare asymptote (2i−1)π/2 is off by ~sech λ (5e-8 relative at i = 5, 4e-9 at i = 6);
    the first correction, from cos λ = −sech λ, leaves an error below 2e-13 for i ≥ 5.
    """
    if i <= len(TABULATED_BETA_L):
        return TABULATED_BETA_L[i - 1]
    lam0 = (2 * i - 1) * np.pi / 2
    return lam0 + (-1) ** (i + 1) / np.cosh(lam0)


def omega_exact(beta_l: np.ndarray) -> np.ndarray:
    return np.asarray(beta_l) ** 2 * np.sqrt(EI / (M_PER_L * L**4))


def modal_omegas(link: Link) -> np.ndarray:
    data = modal_data(link)
    w2 = eigh(data.stiffness_matrix, data.clamped_mass_matrix, eigvals_only=True)
    return np.sqrt(w2)


def fe_omegas(m_t: float, J_t: float, elements: int, count: int) -> np.ndarray:
    """Cubic Hermite finite elements with consistent mass; converge from above as h⁴.

    Solved as the pencil (M, K) so the largest 1/ω² — the lowest modes — are accurate
    relative to themselves (eigh(K, M) loses ~eps·cond(K) on the fundamental).
    """
    h = L / elements
    ke = EI / h**3 * np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                               [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]])
    me = M_PER_L * h / 420 * np.array(
        [[156, 22 * h, 54, -13 * h], [22 * h, 4 * h * h, 13 * h, -3 * h * h],
         [54, 13 * h, 156, -22 * h], [-13 * h, -3 * h * h, -22 * h, 4 * h * h]])
    dofs = 2 * (elements + 1)
    K, M = np.zeros((dofs, dofs)), np.zeros((dofs, dofs))
    for e in range(elements):
        block = slice(2 * e, 2 * e + 4)
        K[block, block] += ke
        M[block, block] += me
    M[-2, -2] += m_t
    M[-1, -1] += J_t
    inv_w2 = eigh(M[2:, 2:], K[2:, 2:], eigvals_only=True)[::-1][:count]
    return 1.0 / np.sqrt(inv_w2)


@pytest.mark.parametrize("n", [4, 12])
def test_clamped_free_frequencies_exact(n: int) -> None:
    link = Link("beam", L, M_PER_L, EI, modes=n)
    expected = omega_exact([reference_beta_l(i) for i in range(1, n + 1)])
    np.testing.assert_allclose(modal_omegas(link), expected, rtol=1e-9, atol=0)
    hz = modal_data(link).natural_frequencies_hz
    np.testing.assert_allclose(2 * np.pi * hz, expected, rtol=1e-9, atol=0)


def test_tip_mass_ratio_one_matches_published() -> None:
    shapes = tip_loaded_modes(L, 5, M_PER_L, EI, tip_mass=M_PER_L * L, tip_inertia=0.0)
    assert shapes.beta_l[0] == pytest.approx(1.2479, abs=5e-5)
    np.testing.assert_allclose(shapes.beta_l**2, TIP_MASS_RATIO_ONE_LAMBDA2, rtol=2e-6)


@pytest.mark.parametrize(("m_t", "J_t"), [(M_PER_L * L, 0.0), (M_PER_L * L, 0.3), (0.0, 0.3)])
def test_tip_loaded_eigenvalues_vs_finite_elements(m_t: float, J_t: float) -> None:
    exact = omega_exact(tip_loaded_modes(L, 4, M_PER_L, EI, m_t, J_t).beta_l)
    coarse, fine = fe_omegas(m_t, J_t, 25, 4), fe_omegas(m_t, J_t, 50, 4)
    assert np.all(coarse >= fine) and np.all(fine >= exact * (1 - 1e-10))  # from above
    np.testing.assert_allclose(fine, exact, rtol=3e-6)
    # Richardson extrapolation with the h⁴ rate removes most of the discretisation error.
    np.testing.assert_allclose((16 * fine - coarse) / 15, exact, rtol=1e-7)


def test_tip_mass_vs_rayleigh_ritz_with_clamped_free_modes() -> None:
    """30 clamped–free modes + tip mass: Rayleigh–Ritz upper bounds, O(N⁻³) convergence."""
    m_t = M_PER_L * L
    exact = omega_exact(tip_loaded_modes(L, 3, M_PER_L, EI, m_t, 0.0).beta_l)
    ritz = modal_omegas(Link("beam", L, M_PER_L, EI, tip_mass=m_t, modes=30))[:3]
    assert np.all(ritz >= exact * (1 - 1e-12))
    np.testing.assert_array_less(ritz / exact - 1, [1e-6, 1e-5, 5e-5])  # measured 5e-7, 6e-6, 2e-5


def test_tip_inertia_vs_rayleigh_ritz_converges_slowly_from_above() -> None:
    """Clamped–free modes have φ''(L) = 0 but the exact modes have EI φ''(L) = J_t ω² φ'(L),
    so with tip inertia the Ritz error only decays like 1/N."""
    m_t, J_t = M_PER_L * L, 0.3
    exact = omega_exact(tip_loaded_modes(L, 3, M_PER_L, EI, m_t, J_t).beta_l)
    errors = []
    for n in (10, 20):
        ritz = modal_omegas(Link("beam", L, M_PER_L, EI, m_t, J_t, modes=n))[:3]
        assert np.all(ritz >= exact * (1 - 1e-12))
        errors.append(ritz / exact - 1)
    assert np.all(errors[1] < 0.6 * errors[0])


@pytest.mark.parametrize(("m_t", "J_t", "n"), [(3.5, 0.0, 6), (3.5, 0.4, 6), (0.0, 0.4, 10),
                                               (500.0, 80.0, 8)])
def test_tip_loaded_basis_reproduces_exact_frequencies(m_t: float, J_t: float, n: int) -> None:
    link = Link("beam", L, M_PER_L, EI, m_t, J_t, modes=n, mode_shapes="tip_loaded")
    data = modal_data(link)
    expected = omega_exact(data.shapes.beta_l)
    np.testing.assert_allclose(modal_omegas(link), expected, rtol=1e-9, atol=0)
    np.testing.assert_allclose(2 * np.pi * data.natural_frequencies_hz, expected, rtol=1e-9)
