"""Natural frequencies of a cantilever spinning at a constant rate Ω, with and without geometric
stiffening, against published values (Wright et al. 1982) and an independent finite-element
solution of the rotating-beam equation.

flexlink's link bends in the plane of rotation. For one link on a hub (T̂ = [0; E]) the first-
order equations at constant Ω reduce to M_b q̈ + (K_b − Ω²M_b + Ω²W) q = 0 with W the
centrifugal geometric stiffness (docs/derivation.md §3–4): there is no gyroscopic term (checked
below), so eig(K, M) gives ω² of the motion relative to the rotating frame. The published tables
are for flapwise bending; for this beam ω_in² = ω_flap² − Ω² (``RotatingCantileverTable``).
See docs/validation.md, case 1.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import eigh

from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.model import Chain
from flexlink.motion import Spinup
from tests.validation.benchmarks import (
    CANTILEVER_LAMBDA2,
    KANE_RYAN_BANERJEE_1987,
    WRIGHT_1982,
    RotatingBeamFE,
)

BEAM = KANE_RYAN_BANERJEE_1987  # L = 10 m, m̄ = 1.2 kg/m, EI = 14 000 N·m²; γ = 0.926 s · Ω
SCALE = BEAM.time_scale  # s
TABLE = WRIGHT_1982
MODES = 8

# Rayleigh–Ritz allowance for 8 clamped–free modes on the in-plane frequency (relative): the
# measured truncation error grows with γ and peaks at γ = 12 with 3.6e-4 (mode 1) and 8.3e-5
# (mode 2), always from above (test_converges_from_above_with_mode_count). The tolerance is
# this allowance plus the table's own rounding bound at that γ.
RITZ_ALLOWANCE = {1: 5e-4, 2: 2e-4}


def flexlink_omega2(rate: float, modes: int, stiffening: bool) -> np.ndarray:
    """ω² (rad²/s²) of the relative motion at constant hub rate (rad/s), ascending."""
    M, _, K, _ = _matrices(rate, modes, stiffening)
    return eigh(K, M, eigvals_only=True)


def _matrices(rate: float, modes: int, stiffening: bool):
    # A spin-up that is over at t = 1 s; at t = 2 s the hub turns at exactly `rate`.
    chain = Chain((BEAM.link(modes),), (Spinup(math.degrees(rate), 0.0, 1.0),))
    system = FirstOrderSystem(chain, geometric_stiffening=stiffening)
    return tuple(a[0] for a in system.matrices(np.array([2.0])))


def flexlink_in_plane(gamma: float, modes: int = MODES, stiffening: bool = True) -> np.ndarray:
    """Dimensionless in-plane frequencies ω·√(m̄L⁴/EI) at dimensionless speed γ."""
    return np.sqrt(flexlink_omega2(gamma / SCALE, modes, stiffening)) * SCALE


# -- the reference itself ---------------------------------------------------------------------

def test_table_and_fe_reference_agree() -> None:
    """Two ways to the same numbers: the transcribed table and an independent FE solution of the
    flapwise equation agree within the table's rounding (5.5e-4) plus the FE error (60 cubic
    elements: < 2e-5 on mode 3). Also the γ = 0 row against λᵢ² of 1 + cos λ cosh λ = 0."""
    fe = RotatingBeamFE(1.0, 1.0, 1.0, elements=60)  # dimensionless beam: scale 1
    for k, gamma in enumerate(TABLE.gamma):
        flap = fe.frequencies(gamma, 3, in_plane=False)
        for mode in (1, 2, 3):
            assert abs(flap[mode - 1] - TABLE.flapwise(mode)[k]) <= TABLE.half_unit + 2e-5
    np.testing.assert_allclose([TABLE.flapwise(i)[0] for i in (1, 2, 3)], CANTILEVER_LAMBDA2,
                               atol=TABLE.half_unit, rtol=0)


def test_in_plane_is_flapwise_minus_rotation_squared() -> None:
    """The in-plane equation only adds −m̄Ω²w, i.e. −Ω²M, so ω_in² = ω_flap² − Ω² holds mode by
    mode (checked on the FE reference to round-off)."""
    fe = RotatingBeamFE(1.0, 1.0, 1.0, elements=30)
    for gamma in (0.5, 3.0, 12.0):
        flap = fe.frequencies(gamma, 4, in_plane=False)
        inplane = fe.frequencies(gamma, 4, in_plane=True)
        np.testing.assert_allclose(inplane**2, flap**2 - gamma**2, rtol=1e-9)


# -- flexlink against the published values ----------------------------------------------------

@pytest.mark.parametrize("stiffening", [False, True])
def test_single_link_on_hub_has_no_gyroscopic_term(stiffening: bool) -> None:
    """C = 0 (no damping): the eigenvalues of (K, M) are the frequencies of the relative motion."""
    _, C, K, f = _matrices(5.0, MODES, stiffening)
    assert np.all(C == 0.0)
    assert np.all(f == 0.0)
    np.testing.assert_allclose(K, K.T, atol=1e-9 * np.abs(K).max())


@pytest.mark.parametrize("k", range(len(TABLE.gamma)), ids=[f"gamma={g:g}" for g in TABLE.gamma])
def test_in_plane_frequencies_match_wright_1982(k: int) -> None:
    """Modes 1 and 2, γ = 0 … 12 (Ω = 0 … 13 rad/s for the spin-up beam), 8 modes, stiffening."""
    ours = flexlink_in_plane(TABLE.gamma[k])
    for mode in (1, 2):
        published = TABLE.in_plane(mode)[k]
        tolerance = TABLE.in_plane_rounding(mode)[k] + RITZ_ALLOWANCE[mode]
        assert abs(ours[mode - 1] / published - 1) <= tolerance, (mode, ours[mode - 1], published)


@pytest.mark.parametrize("gamma", [6.0, 12.0])
def test_converges_from_above_with_mode_count(gamma: float) -> None:
    """Clamped–free modes are admissible functions, so flexlink's frequencies are Rayleigh–Ritz
    upper bounds that decrease monotonically with the mode count (against FE with 80 elements,
    itself converged to ~1e-9)."""
    reference = RotatingBeamFE(1.0, 1.0, 1.0, elements=80).frequencies(gamma, 2)
    errors = np.array([flexlink_in_plane(gamma, n)[:2] / reference - 1 for n in (2, 4, 6, 8, 12)])
    assert np.all(errors >= -1e-7)
    assert np.all(np.diff(errors, axis=0) < 0)
    assert errors[3, 0] <= 4e-4 and errors[3, 1] <= 1e-4  # 8 modes (measured 3.6e-4, 8.3e-5)


def test_stiffened_first_frequency_rises_with_speed() -> None:
    """With stiffening the first in-plane frequency grows with Ω (Southwell coefficient of the
    first mode 1.19 > 1 outweighs the softening): there is no divergence speed."""
    omegas = [flexlink_in_plane(g)[0] for g in TABLE.gamma]
    assert np.all(np.diff(omegas) > 0)
    assert omegas[0] == pytest.approx(CANTILEVER_LAMBDA2[0], rel=1e-9)


# -- the paper's model: no stiffening ---------------------------------------------------------

@pytest.mark.parametrize("rate", [0.0, 2.0, 3.79, 4.0, 10.0])
def test_without_stiffening_every_mode_softens_by_rate_squared(rate: float) -> None:
    """Without W the equations are M_b q̈ + (K_b − Ω²M_b) q = 0 with diagonal M_b, K_b: each
    clamped mode keeps its shape and ω_k² → ω_k² − Ω² exactly."""
    clamped = np.array(flexlink_omega2(0.0, MODES, False))
    np.testing.assert_allclose(flexlink_omega2(rate, MODES, False), clamped - rate**2,
                               rtol=0, atol=1e-9 * clamped.max())


def test_without_stiffening_divergence_speed_is_first_frequency() -> None:
    """The first in-plane ω² crosses zero at Ω = ω₁ = λ₁²√(EI/(m̄L⁴)) = 3.798 rad/s, below both
    spin rates of the Kane–Ryan–Banerjee beam (4 and 10 rad/s): there the paper's model has an
    exponentially growing mode, rate √(Ω² − ω₁²) = 1.26 and 9.25 s⁻¹. With stiffening the first
    frequency at the same speeds is 4.16 and 5.30 rad/s (FE reference, 40 elements)."""
    w1 = BEAM.first_frequency
    assert w1 == pytest.approx(3.7977, abs=1e-4)
    assert flexlink_omega2(w1 * (1 - 1e-6), MODES, False)[0] > 0
    assert flexlink_omega2(w1 * (1 + 1e-6), MODES, False)[0] < 0
    fe = RotatingBeamFE(BEAM.length, BEAM.mass_per_length, BEAM.EI)
    for rate in BEAM.rates:
        growth = math.sqrt(-flexlink_omega2(rate, MODES, False)[0])
        assert growth == pytest.approx(math.sqrt(rate**2 - w1**2), rel=1e-9)
        stiff = math.sqrt(flexlink_omega2(rate, MODES, True)[0])
        assert stiff == pytest.approx(fe.frequencies(rate, 1)[0], rel=5e-4)
