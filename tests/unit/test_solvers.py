"""The Magnus solver's shortcuts against the plain computation they replace."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.motion import Cycloidal
from flexlink.simulation import output_times
from flexlink.solvers.batched_expm import expm_stack
from flexlink.solvers.magnus import _solve
from tests.helpers import chain_of, paper_links


@pytest.mark.parametrize("norm", [1e-3, 0.2, 0.9, 2.0, 5.0, 40.0])
def test_expm_stack_equals_scipy(norm: float) -> None:
    rng = np.random.default_rng(1)
    A = rng.normal(size=(20, 9, 9))
    A *= norm / np.abs(A).sum(axis=1).max(axis=1)[:, None, None]
    reference = np.array([scipy.linalg.expm(a) for a in A])
    assert np.abs(expm_stack(A) - reference).max() <= 1e-13 * np.abs(reference).max()


def test_expm_stack_mixed_norms_square_each_matrix_as_needed() -> None:
    A = np.stack([np.diag([0.01, -0.02]), np.array([[0.0, 30.0], [-30.0, 0.0]])])
    expected = np.array([scipy.linalg.expm(a) for a in A])
    assert np.allclose(expm_stack(A), expected, rtol=0, atol=1e-12)


def _system() -> FirstOrderSystem:
    # Rest, move, rest, second move, rest: long runs of identical steps and a changing h.
    motions = [Cycloidal(0.0, 60.0, 0.2, 0.3), Cycloidal(20.0, -40.0, 0.7, 0.2)]
    return FirstOrderSystem(chain_of(paper_links(2), motions), True)


def test_coefficient_keys_label_equal_coefficients_only() -> None:
    system = _system()
    t = np.linspace(0.0, 1.2, 241)
    keys = system.coefficient_keys(t)
    M, C, K, f = system.matrices(t)
    for key in np.unique(keys):
        same = keys == key
        for a in (M, C, K, f):
            assert np.all(a[same] == a[same][0])
    assert np.unique(keys).size < t.size / 2  # the rest phases were recognised
    moving = (t > 0.2) & (t < 0.5)
    assert np.unique(keys[moving]).size == moving.sum()


@pytest.mark.parametrize("substeps", [1, 3])
def test_shared_propagators_and_powers_equal_the_step_by_step_product(substeps: int) -> None:
    system = _system()
    t = np.append(output_times(1.2, 0.01), 1.2037)  # a last, shorter interval
    plain = _solve(system.matrices, system.n, t, substeps, None)
    shared = _solve(system.matrices, system.n, t, substeps, None, system.coefficient_keys)
    assert np.abs(shared - plain).max() <= 1e-11 * np.abs(plain).max()
