"""Forward dynamics (a torque-driven hub–beam) against the geometrically exact FE model
(Exudyn, tests/validation/exudyn_forward_reference.py); the FE model's hub–beam frequencies
against the exact frequency equation first (tests/validation/hub_beam.py).

Slow, and skipped where Exudyn is not installed (`pip install -e '.[test,reference]'`).
"""

from __future__ import annotations

import numpy as np
import pytest

from flexlink import simulate

pytest.importorskip("exudyn")
from tests.validation.exudyn_forward_reference import hub_beam_eigenfrequencies
from tests.validation.forward_fe_cases import (
    ARRAY,
    BEAM,
    CASES,
    error_of_peak,
    exudyn_signals,
    flexlink_scenario,
    flexlink_signals,
)
from tests.validation.hub_beam import hub_beam_frequencies

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("eta, rho", [(1.0, 0.0), (0.3, 0.2), (0.05, 0.1)])
def test_fe_hub_beam_frequencies(eta: float, rho: float) -> None:
    """The FE model linearised at rest (32 elements) has the exact hub–beam frequencies:
    measured within 1.7e-4, 3.0e-4, 1.7e-3 (modes 1–3; O(h²) convergence of the linear
    elements, 4× smaller at each mesh doubling)."""
    L, m = BEAM.length, BEAM.mass_per_length
    exact = hub_beam_frequencies(3, BEAM.EI, m, L, rho * L, eta * m * L**3)
    fe = hub_beam_eigenfrequencies(BEAM, rho * L, eta * m * L**3, 32, 3)
    np.testing.assert_allclose(fe, exact, rtol=3e-3)


def test_torque_driven_hub_beam_small_deflection() -> None:
    """Bang-bang torque on the hub (1.5 rad slew in 2 s, tip deflection 2.8% of L, 4 s):
    flexlink's first-order stiffened model (6 modes, joint 1 torque-driven with the hub as
    motor inertia) within 1% of peak of the 32-element FE model on the tip deflection and the
    hub angle (measured: see docs/validation.md, case 14b)."""
    case = CASES["hub_beam_small"]
    reference, _ = exudyn_signals(case, 32, 5e-4)
    ours = flexlink_signals(case, simulate(flexlink_scenario(case, modes=6)))
    errors = error_of_peak(ours, reference)
    assert 0.02 < np.abs(reference["tip"]).max() / BEAM.length < 0.05  # "small", as documented
    assert errors["tip"] < 0.01, errors
    assert errors["hub_angle"] < 0.01, errors


@pytest.mark.parametrize("name", ["hub_beam_large", "free_hub_large"])
def test_nonlinear_model_at_large_deflection(name: str) -> None:
    """The nonlinear model (4 modes, 2.5 ms Gauss steps) through the large slews — tip
    deflections of 30% (hub–beam) and 36% (free hub) of the length, where the first-order
    model is out of its range — within 1% of peak of the 32-element FE model on the tip
    deflection and the hub angle (measured: tip 0.55% and 0.71%, hub angle 0.03%; the hub
    rate, which carries the appendages' high modes, 0.07% and 1.1%)."""
    from dataclasses import replace

    case = CASES[name]
    reference, _ = exudyn_signals(case, 32, 5e-4)
    scenario = flexlink_scenario(case, modes=4)
    scenario = replace(scenario, settings=replace(scenario.settings, model="nonlinear",
                                                  step=2.5e-3))
    ours = flexlink_signals(case, simulate(scenario))
    errors = error_of_peak(ours, reference)
    length = BEAM.length if case.kind == "hub_beam" else ARRAY.length
    assert np.abs(reference["tip"]).max() / length > 0.3  # "large", as documented
    assert errors["tip"] < 0.01, errors
    assert errors["hub_angle"] < 0.01, errors


@pytest.mark.parametrize("name", ["cart_inverted", "cart_horizontal"])
def test_beam_standing_and_level_on_a_pushed_cart(name: str) -> None:
    """examples/cart_beam.toml's beam standing on its cart (its weight compresses it) and held
    level (released undeformed: it swings to 21% of its length under its weight), the cart
    pushed ±4 N: the nonlinear model (4 modes) within 1% of peak of the 32-element FE model
    on the tip deflection and the cart's travel (measured against 64 elements: 0.16% and
    0.17% tip); the first-order model within 3% standing (0.12%) and warning level, where it
    is 9% off."""
    from dataclasses import replace

    case = CASES[name]
    reference, _ = exudyn_signals(case, 32, 5e-4)
    scenario = flexlink_scenario(case, modes=4, rtol=1e-4)
    first = simulate(scenario)
    nonlinear = simulate(replace(scenario, settings=replace(scenario.settings,
                                                            model="nonlinear", rtol=None)))
    errors = error_of_peak(flexlink_signals(case, nonlinear), reference)
    assert max(errors.values()) < 0.01, errors
    warning = first.metadata.get("validity_warning", "")
    if case.beam_angle == 0.0:
        assert "beyond 10%" in warning, warning
    else:
        assert not warning, warning
        errors = error_of_peak(flexlink_signals(case, first), reference)
        assert max(errors.values()) < 0.03, errors


def test_gravity_loaded_arm_moved_rest_to_rest() -> None:
    """A hanging arm with a payload swung up 70° by the rigid arm's inverse-dynamics torque
    (case ``arm``): both models (4 modes, their defaults) within 1% of peak of the
    32-element FE model on the tip deflection and the hub's angle and rate (measured against
    64 elements: tip 0.15%, hub angle 0.02%, both models)."""
    from dataclasses import replace

    case = CASES["arm"]
    reference, _ = exudyn_signals(case, 32, 5e-4)
    scenario = flexlink_scenario(case, modes=4, rtol=1e-4)
    for settings in (scenario.settings, replace(scenario.settings, model="nonlinear",
                                                rtol=None)):
        run = simulate(replace(scenario, settings=settings))
        errors = error_of_peak(flexlink_signals(case, run), reference)
        assert max(errors.values()) < 0.01, (settings.model, errors)
        assert not run.metadata.get("validity_warning"), run.metadata["validity_warning"]
