"""Frozen-time eigenvalues of the linearised plant against exact and independent frequencies.

* clamped–free beam (a prescribed joint at rest): roots of 1 + cos λ cosh λ = 0;
* clamped beam with a tip mass m_t = mL (published λ², cantilever test) — the clamped-free
  basis converges with the mode count, which the test follows;
* pinned–free beam (a torque-driven joint with no torque, no hub inertia): tan μ = tanh μ;
* hub–beam (free hub with inertia J_h, beam clamped at radius r: a pinned base) and a
  torque-driven joint with a motor inertia: the characteristic equation of
  tests/validation/hub_beam.py;
* (slow, Exudyn) the paper's arm with locked joints at β₂ = 0°, 45°, 90° against a
  geometrically exact FE model (exudyn_modal_reference.py), mesh converged by Richardson.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexlink.control import frozen_modes, linearize
from flexlink.model import Base, Chain, Link, Scenario, TorqueDrive
from flexlink.model.histories import ZERO
from tests.helpers import SmoothStep, paper_links
from tests.validation.hub_beam import hub_beam_frequencies
from tests.validation.test_cantilever_frequencies import (
    TIP_MASS_RATIO_ONE_LAMBDA2,
    reference_beta_l,
)

L, M_PER_L, EI = 1.3, 2.7, 45.0
HOLD = SmoothStep(0.0, 0.0, 0.0, 1.0)


def _omega(mu: np.ndarray | list[float]) -> np.ndarray:
    return np.asarray(mu) ** 2 * np.sqrt(EI / (M_PER_L * L**4))


def _frequencies(scenario: Scenario, count: int) -> np.ndarray:
    return 2 * np.pi * linearize(scenario, at=[0.0] * len(scenario.chain.joints)).modes()[0][
        :count]


def test_clamped_free_beam() -> None:
    link = Link("beam", L, M_PER_L, EI, modes=6)
    got = _frequencies(Scenario(Chain((link,), (HOLD,))), 6)
    np.testing.assert_allclose(got, _omega([reference_beta_l(i) for i in range(1, 7)]),
                               rtol=1e-9)


def test_clamped_beam_with_tip_mass_converges_with_the_mode_count() -> None:
    exact = np.asarray(TIP_MASS_RATIO_ONE_LAMBDA2[:3]) * np.sqrt(EI / (M_PER_L * L**4))
    errors = []
    for modes in (4, 8, 16):
        link = Link("beam", L, M_PER_L, EI, tip_mass=M_PER_L * L, modes=modes)
        got = _frequencies(Scenario(Chain((link,), (HOLD,))), 3)
        errors.append(np.abs(got / exact - 1).max())
    assert errors[0] > errors[1] > errors[2]
    assert errors[1] < 5e-3 and errors[2] < 1e-3, errors  # measured 7.4e-4, 1.0e-4


def test_pinned_free_beam() -> None:
    """tan μ = tanh μ: μ ≈ (4i + 1)π/4."""
    from scipy.optimize import brentq

    mu = [brentq(lambda m: np.tan(m) - np.tanh(m), (4 * i + 1) * np.pi / 4 - 0.1,
                 (4 * i + 1) * np.pi / 4 + 0.1) for i in range(1, 5)]
    errors = []
    for modes in (8, 12, 16):  # the clamped-free basis converges on the pinned modes
        link = Link("beam", L, M_PER_L, EI, modes=modes)
        got = _frequencies(Scenario(Chain((link,), (TorqueDrive(ZERO),))), 4)
        errors.append(np.abs(got / _omega(mu) - 1).max())
    assert errors[0] > errors[1] > errors[2]
    assert errors[0] < 5e-4 and errors[2] < 5e-6, errors  # measured 1.6e-4, 9e-6, 1.3e-6


@pytest.mark.parametrize("radius, hub", [(0.0, 0.4), (0.25, 1.5)])
def test_hub_beam_pinned_base(radius: float, hub: float) -> None:
    exact = hub_beam_frequencies(4, EI, M_PER_L, L, radius, hub)
    link = Link("beam", L, M_PER_L, EI, modes=8)
    base = Base("pinned", inertia=hub, attachments=((0, (radius, 0.0)),))
    got = _frequencies(Scenario(Chain((link,), (HOLD,)), base=base), 4)
    np.testing.assert_allclose(got, exact, rtol=1e-6)  # measured ≤ 3.8e-7


def test_hub_beam_torque_driven_joint_with_motor_inertia() -> None:
    exact = hub_beam_frequencies(4, EI, M_PER_L, L, 0.0, 0.4)
    for modes, tol in ((4, 5e-6), (8, 5e-8), (16, 5e-10)):  # measured 2.1e-6, 1.4e-8, 1.2e-10
        link = Link("beam", L, M_PER_L, EI, modes=modes)
        joint = TorqueDrive(ZERO, motor_inertia=0.4)
        got = _frequencies(Scenario(Chain((link,), (joint,))), 4)
        np.testing.assert_allclose(got, exact, rtol=tol)


@pytest.mark.slow
def test_paper_arm_locked_against_geometrically_exact_fe() -> None:
    pytest.importorskip("exudyn")
    from tests.validation.exudyn_modal_reference import locked_chain_frequencies

    links = paper_links(modes=10, damping=False)
    count = 6
    grid = frozen_modes(Scenario(Chain(links, (HOLD, HOLD))),
                        angles={"joint2": [0.0, 45.0, 90.0]}, count=count)
    coarse_links = paper_links(modes=8, damping=False)
    coarse = frozen_modes(Scenario(Chain(coarse_links, (HOLD, HOLD))),
                          angles={"joint2": [0.0, 45.0, 90.0]}, count=count)
    # the assumed modes have converged: 8 → 10 modes per link changes < 0.05 %
    assert np.abs(coarse.frequency_hz / grid.frequency_hz - 1).max() < 5e-4
    for i, beta2 in enumerate((0.0, 45.0, 90.0)):
        angles = [0.0, math.radians(beta2)]
        f75 = locked_chain_frequencies(links, angles, 75, count)
        f150 = locked_chain_frequencies(links, angles, 150, count)
        fe = f150 + (f150 - f75) / 3  # O(h²) elements: Richardson
        assert np.abs((f150 - f75) / 3 / fe).max() < 1e-3  # the mesh error left in f150
        error = np.abs(grid.frequency_hz[i] / fe - 1)
        assert error.max() < 5e-3, (beta2, grid.frequency_hz[i], fe)
        assert error.max() < 1e-3, (beta2, error)  # measured ≤ 6e-4
