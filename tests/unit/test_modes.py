"""Mode shapes and modal integrals of one link (flexlink.modes)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.linalg import eigh

from flexlink.model import Link
from flexlink.modes import (
    ModalData,
    ModeShapes,
    clamped_free_modes,
    modal_data,
    mode_shapes_for,
    tip_loaded_modes,
)

L, M_PER_L, EI = 1.3, 2.7, 45.0


def test_evaluate_shape_and_bad_derivative() -> None:
    shapes = clamped_free_modes(L, 5)
    assert isinstance(shapes, ModeShapes) and shapes.length == L and shapes.n == 5
    assert shapes.evaluate(np.linspace(0, L, 7), 2).shape == (7, 5)
    with pytest.raises(ValueError):
        shapes.evaluate(np.array([0.0]), 4)


def test_mode_shapes_are_immutable() -> None:
    shapes = clamped_free_modes(L, 3)
    with pytest.raises(dataclasses.FrozenInstanceError):
        shapes.n = 4  # type: ignore[misc]
    with pytest.raises(ValueError):
        shapes.beta_l[0] = 1.0
    data = modal_data(Link("b", L, M_PER_L, EI, modes=3))
    with pytest.raises(ValueError):
        data.mass_matrix[0, 0] = 1.0


def test_clamped_free_boundary_values_and_normalisation() -> None:
    shapes = clamped_free_modes(L, 6)
    ends = np.array([0.0, L])
    np.testing.assert_allclose(shapes.evaluate(ends, 0)[0], 0, atol=1e-14)
    np.testing.assert_allclose(shapes.evaluate(ends, 1)[0], 0, atol=1e-12)
    np.testing.assert_allclose(shapes.evaluate(ends, 0)[1], 2.0, rtol=1e-13)  # tip value +2
    scale = shapes.beta**2
    np.testing.assert_allclose(shapes.evaluate(ends, 2)[1] / scale, 0, atol=1e-12)
    np.testing.assert_allclose(shapes.evaluate(ends, 3)[1] / (scale * shapes.beta), 0, atol=1e-12)


def test_derivatives_are_consistent_and_solve_the_beam_equation() -> None:
    shapes = clamped_free_modes(L, 5)
    x, h = np.linspace(0.05, L - 0.05, 9), 1e-5
    for k in range(1, 4):
        fd = (shapes.evaluate(x + h, k - 1) - shapes.evaluate(x - h, k - 1)) / (2 * h)
        np.testing.assert_allclose(fd / shapes.beta**k, shapes.evaluate(x, k) / shapes.beta**k,
                                   atol=1e-6)
    fourth = (shapes.evaluate(x + h, 3) - shapes.evaluate(x - h, 3)) / (2 * h)
    np.testing.assert_allclose(fourth / shapes.beta**4, shapes.evaluate(x), atol=1e-6)


def test_bare_beam_orthogonality() -> None:
    data = modal_data(Link("b", L, M_PER_L, EI, modes=8))
    mL = M_PER_L * L
    np.testing.assert_allclose(data.mass_matrix, mL * np.eye(8), atol=1e-10 * mL)
    k = data.stiffness_matrix
    np.testing.assert_allclose(k - np.diag(np.diag(k)), 0, atol=1e-10 * np.abs(k).max())
    np.testing.assert_allclose(np.diag(k), EI * data.shapes.beta**4 * L, rtol=1e-10)


def test_twenty_modes_are_stable() -> None:
    shapes = clamped_free_modes(L, 20)
    x = np.linspace(0, L, 401)
    for k in range(4):
        assert np.all(np.isfinite(shapes.evaluate(x, k)))
    assert np.abs(shapes.evaluate(x)).max() < 2.1  # bounded by ~|tip value|
    data = modal_data(Link("b", L, M_PER_L, EI, modes=20))
    np.testing.assert_allclose(data.mass_matrix / (M_PER_L * L), np.eye(20), atol=1e-8)
    assert np.all(np.isfinite(data.foreshortening_moment))


@pytest.mark.parametrize("kind", ["clamped_free", "tip_loaded"])
def test_integrals_against_adaptive_quadrature(kind: str) -> None:
    m_t, J_t = 1.7, 0.05
    link = Link("b", L, M_PER_L, EI, m_t, J_t, modes=3, mode_shapes=kind)
    data = modal_data(link)
    shapes = data.shapes

    def f(k: int, i: int):
        return lambda x: shapes.evaluate(np.array([x]), k)[0, i]

    def integral(g, a: float = 0.0, b: float = L) -> float:
        return quad(g, a, b, epsabs=1e-11, epsrel=1e-12, limit=200)[0]

    def S(x: float, i: int, j: int) -> float:
        return integral(lambda s: f(1, i)(s) * f(1, j)(s), 0.0, x)

    tip = shapes.evaluate(np.array([L]))[0]
    assert data.mass == pytest.approx(M_PER_L * L + m_t, rel=1e-14)
    assert data.first_moment == pytest.approx(M_PER_L * L**2 / 2 + m_t * L, rel=1e-14)
    assert data.second_moment == pytest.approx(M_PER_L * L**3 / 3 + m_t * L**2, rel=1e-14)
    checks = [
        (data.phi_bar[1], M_PER_L * integral(f(0, 1)) + m_t * tip[1]),
        (data.phi_tilde[2], M_PER_L * integral(lambda x: x * f(0, 2)(x)) + m_t * L * tip[2]),
        (data.mass_matrix[0, 2],
         M_PER_L * integral(lambda x: f(0, 0)(x) * f(0, 2)(x)) + m_t * tip[0] * tip[2]),
        (data.stiffness_matrix[2, 2], EI * integral(lambda x: f(2, 2)(x) ** 2)),
        (data.foreshortening_tip[0, 1], S(L, 0, 1)),
        # Definitions ∫S dm and ∫xS dm as nested integrals (not the outboard-mass form).
        (data.foreshortening_mass[1, 2],
         M_PER_L * integral(lambda x: S(x, 1, 2)) + m_t * S(L, 1, 2)),
        (data.foreshortening_moment[0, 2],
         M_PER_L * integral(lambda x: x * S(x, 0, 2)) + m_t * L * S(L, 0, 2)),
    ]
    for got, want in checks:
        assert got == pytest.approx(want, rel=1e-11, abs=1e-12)
    slope = shapes.evaluate(np.array([L]), 1)[0]
    np.testing.assert_allclose(data.tip_value, tip, rtol=1e-15)
    np.testing.assert_allclose(data.clamped_mass_matrix,
                               data.mass_matrix + J_t * np.outer(slope, slope), rtol=1e-14)


def test_quadrature_override_agrees() -> None:
    link = Link("b", L, M_PER_L, EI, 0.8, 0.02, modes=6)
    auto, manual = modal_data(link), modal_data(link, quadrature_points=400)
    for name in ("phi_bar", "mass_matrix", "stiffness_matrix", "foreshortening_moment"):
        a, b = getattr(auto, name), getattr(manual, name)
        np.testing.assert_allclose(a, b, atol=1e-12 * np.abs(b).max())


@pytest.mark.parametrize(("m_t", "J_t"), [(3.5, 0.0), (0.0, 0.4), (3.5, 0.4), (500.0, 80.0)])
def test_tip_loaded_modes_satisfy_dynamic_boundary_conditions(m_t: float, J_t: float) -> None:
    shapes = tip_loaded_modes(L, 8, M_PER_L, EI, m_t, J_t)
    omega2 = shapes.beta**4 * EI / M_PER_L
    at = lambda x, k: shapes.evaluate(np.array([x]), k)[0]
    np.testing.assert_allclose(at(0.0, 0), 0, atol=1e-13)
    np.testing.assert_allclose(at(0.0, 1) / shapes.beta, 0, atol=1e-13)
    # Residuals relative to the terms' natural scales (|φ| ~ 1, |φ'| ~ β, |φ''| ~ β², …):
    # with a heavy tip φ(L), φ'(L) are small differences of O(1) parts, so their absolute
    # round-off, amplified by m_t ω² and J_t ω², sets the attainable accuracy.
    moment, inertia_moment = EI * at(L, 2), J_t * omega2 * at(L, 1)
    shear, inertia_force = EI * at(L, 3), -m_t * omega2 * at(L, 0)
    size_m = EI * shapes.beta**2 + J_t * omega2 * shapes.beta
    size_s = EI * shapes.beta**3 + m_t * omega2
    np.testing.assert_allclose((moment - inertia_moment) / size_m, 0, atol=1e-12)
    np.testing.assert_allclose((shear - inertia_force) / size_s, 0, atol=1e-12)
    assert np.all(at(L, 0) > 0)
    # Orthogonal in the clamped link's full mass matrix, normalised to the beam mass.
    data = modal_data(Link("b", L, M_PER_L, EI, m_t, J_t, modes=8, mode_shapes="tip_loaded"))
    mL = M_PER_L * L
    np.testing.assert_allclose(data.clamped_mass_matrix, mL * np.eye(8), atol=1e-10 * mL)
    np.testing.assert_allclose(np.diag(data.stiffness_matrix), mL * omega2, rtol=1e-10)


def test_tip_loaded_without_tip_body_equals_clamped_free() -> None:
    loaded = tip_loaded_modes(L, 10, M_PER_L, EI, 0.0, 0.0)
    free = clamped_free_modes(L, 10)
    np.testing.assert_allclose(loaded.beta_l, free.beta_l, rtol=1e-14)
    x = np.linspace(0, L, 31)
    for k in range(4):
        np.testing.assert_allclose(loaded.evaluate(x, k) / free.beta**k,
                                   free.evaluate(x, k) / free.beta**k, atol=1e-11)


def test_mode_shapes_for_dispatches_on_link() -> None:
    link = Link("b", L, M_PER_L, EI, tip_mass=2.0, modes=3, mode_shapes="tip_loaded")
    assert mode_shapes_for(link).kind == "tip_loaded"
    np.testing.assert_allclose(mode_shapes_for(link).beta_l,
                               tip_loaded_modes(L, 3, M_PER_L, EI, 2.0, 0.0).beta_l)
    bare = dataclasses.replace(link, mode_shapes="clamped_free")
    assert mode_shapes_for(bare).kind == "clamped_free"
    with pytest.raises(ValueError):
        mode_shapes_for(dataclasses.replace(link, mode_shapes="bogus"))  # type: ignore[arg-type]


def test_modal_damping_matrix() -> None:
    zeta = 0.03
    link = Link("b", L, M_PER_L, EI, 1.2, 0.05, damping_ratio=zeta, modes=5)
    data = modal_data(link)
    assert isinstance(data, ModalData)
    omega2, vectors = eigh(data.stiffness_matrix, data.clamped_mass_matrix)
    omega = np.sqrt(omega2)
    np.testing.assert_allclose(vectors.T @ data.damping_matrix @ vectors,
                               np.diag(2 * zeta * omega), atol=1e-10 * 2 * zeta * omega.max())
    np.testing.assert_allclose(2 * np.pi * data.natural_frequencies_hz, omega, rtol=1e-12)
    undamped = modal_data(dataclasses.replace(link, damping_ratio=0.0))
    assert np.all(undamped.damping_matrix == 0.0)


def test_a_sensor_point_s_shape_row_is_remembered_as_evaluated() -> None:
    """channels.modal.shape_row: Φ or a derivative at one point, as evaluate gives it, kept
    read-only per mode shapes (every run of a link reads the same rows)."""
    from flexlink.channels.modal import shape_row

    shapes = clamped_free_modes(0.9, 4)
    for derivative in range(3):
        row = shape_row(shapes, 0.37, derivative)
        np.testing.assert_array_equal(row, shapes.evaluate(np.array([0.37]), derivative)[0])
        assert shape_row(shapes, 0.37, derivative) is row and not row.flags.writeable


def test_the_gauss_rule_is_numpys_computed_once_and_read_only() -> None:
    """The modes and modal integrals take their Gauss–Legendre rules from one cache: the
    same nodes and weights as numpy's leggauss, bit for bit, which no caller can change."""
    from flexlink.modes.shapes import gauss_rule

    for points in (3, 20, 40):
        nodes, weights = gauss_rule(points)
        expected = np.polynomial.legendre.leggauss(points)
        assert np.array_equal(nodes, expected[0]) and np.array_equal(weights, expected[1])
        assert gauss_rule(points)[0] is nodes
        assert not nodes.flags.writeable and not weights.flags.writeable
