"""The step controller shared by Radau IIA and the Gauss collocation
(solvers/_step_control_numba.py) and the per-mode error weights (solvers/error_weights.py):
the weighted norm, its groups, peaks and floors, the factor's limits and rejection rules; the
weights' rule; and their effect on a run whose channels read only displacements."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from flexlink.solvers._step_control_numba import (
    SAFETY,
    SHRINK,
    error_norm,
    keeps,
    next_factor,
    predictive_factor,
    step_control,
    step_factor,
    tolerances,
    update_peaks,
)


def _control(weight=None, floor_of=None, floor_ratio=0.0):
    group = np.array([0, 0, 1, -1])
    return step_control(group, weight, 2, 1e-3, 1e-9, 0.25, 8.0, floor_of, floor_ratio)


def test_the_norm_weighs_each_error_against_its_groups_peak() -> None:
    """Tolerance atol + rtol · max(|y_i|, peak of i's group); error max w_i |e_i| / tol_i;
    a component of group −1 sets no step; a zero error counts zero."""
    c = _control(weight=np.array([1.0, 0.5, 1.0, 1.0]))
    update_peaks(c, np.array([2.0, -3.0, 0.1, 50.0]))
    assert np.allclose(c.peak, [3.0, 0.1])
    y = np.array([0.0, 1.0, 0.5, 0.0])
    scal = np.empty(4)
    tolerances(c, y, scal)
    assert np.allclose(scal, 1e-9 + 1e-3 * np.array([3.0, 3.0, 0.5, 0.0]))
    e = np.array([1e-3, 6e-3, 0.0, 1.0])
    assert math.isclose(error_norm(c, e, scal), max(1e-3 / scal[0], 0.5 * 6e-3 / scal[1]))


def test_a_group_floored_by_another() -> None:
    """Group 1's peak is raised to floor_ratio times group 0's (rates of a state at rest get
    their tolerance from the coordinates)."""
    c = _control(floor_of=np.array([-1, 0]), floor_ratio=10.0)
    update_peaks(c, np.array([2.0, 0.0, 1e-6, 0.0]))
    scal = np.empty(4)
    tolerances(c, np.zeros(4), scal)
    assert math.isclose(scal[2], 1e-9 + 1e-3 * 20.0)


def test_the_factor_limits_and_rejections() -> None:
    """safety · err^−k within [SHRINK, grow]; a rejected step shrinks by SAFETY at least; the
    first step after a rejection does not grow; the keep band; Gustafsson's factor never
    exceeds the plain one."""
    c = _control()
    assert math.isclose(step_factor(c, 0.01, SAFETY), min(8.0, SAFETY * 0.01 ** -0.25))
    assert step_factor(c, 0.0, SAFETY) == 8.0
    assert step_factor(c, 1e9, SAFETY) == SHRINK
    assert next_factor(c, 1.001, SAFETY, False) <= SAFETY
    assert next_factor(c, 1e-6, SAFETY, True) == 1.0
    assert next_factor(c, 1e-6, SAFETY, False) > 1.0
    assert keeps(1.1) and not keeps(0.99) and not keeps(1.5)
    plain = step_factor(c, 0.5, SAFETY)
    assert predictive_factor(c, plain, 0.5, 1e-3, 1e-3, 0.1) <= plain
    assert predictive_factor(c, plain, 0.5, 1e-3, 1e-3, 0.1) >= SHRINK


def test_weights_of_the_wrong_size_are_refused() -> None:
    with pytest.raises(ValueError, match="error weights"):
        step_control(np.zeros(3), np.ones(2), 1, 1e-3, 0.0, 0.25, 8.0)


def test_displacement_weights_follow_the_modal_frequencies() -> None:
    """ω₁/ω_j of each link's clamped modes: 1 for its first, decreasing."""
    from flexlink.model import Link
    from flexlink.modes import modal_data
    from flexlink.solvers.error_weights import displacement_rate_weights, mode_frequencies

    links = [Link("a", 1.0, 2.0, 400.0, modes=3), Link("b", 0.8, 0.6, 12.0, tip_mass=0.2,
                                                       modes=4)]
    modal = [modal_data(link) for link in links]
    w = displacement_rate_weights(modal)
    assert w.shape == (7,)
    assert w[0] == 1.0 and w[3] == 1.0
    assert np.all(np.diff(w[:3]) < 0) and np.all(np.diff(w[3:]) < 0)
    omega = mode_frequencies(modal)[1]
    assert np.allclose(w[3:], omega[0] / omega)
    # the clamped beam with its tip mass: its fourth mode ~50× its first
    assert 40 < omega[3] / omega[0] < 60


def _slider_case():
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    from tests.validation.test_prismatic import slider_fe_case

    return slider_fe_case(4)[0]


def test_the_rule_of_the_weights() -> None:
    """Weights below 1 only where every channel reads displacements: not with a strain
    sensor, nor with a prescribed joint (its torque reads the link's root moment)."""
    from flexlink.model import PointSensor
    from flexlink.modes import modal_data
    from flexlink.solvers.error_weights import elastic_rate_weights

    scenario = _slider_case()
    chain = scenario.chain
    modal = [modal_data(link) for link in chain.links]
    w = elastic_rate_weights(modal, chain.joints, None, scenario.sensors, ())
    assert w.min() < 0.5
    strain = (*scenario.sensors, PointSensor("gauge", "strain", 1, 0.05))
    assert np.all(elastic_rate_weights(modal, chain.joints, None, strain, ()) == 1.0)
    from flexlink.motion import Hold

    held = (Hold(0.0), *chain.joints[1:])  # the hub's angle prescribed
    assert np.all(elastic_rate_weights(modal, held, None, scenario.sensors, ()) == 1.0)


def test_the_weights_free_the_step_from_the_top_mode() -> None:
    """The slider case (torque drives, a deflection sensor; the bang-bang inputs ring the
    beam's undamped top mode), integrated with the weights of its channels: fewer than 60%
    of the unweighted run's steps, and its hub angle, travel and tip deflection within 4e-4
    of their peaks of the unweighted run at rtol 1e-9 (a tenth of the model's own error
    against the FE model, docs/validation.md Case 23). One run's error is one draw of its
    step sequence (the hub angle at rtol 1e-4 is 0.3 of that bound, at 1.04e-4 1.4 times
    it): over 15 tolerances about the default (0.7e-4 … 1.4e-4), the medians must meet
    both, and no run be off by half the model's error."""
    from flexlink.modes import modal_data
    from flexlink.simulation.forward import forward_system
    from flexlink.solvers.error_weights import elastic_rate_weights
    from flexlink.solvers.forward import integrate_forward

    scenario = _slider_case()
    system = forward_system(scenario)
    t = np.linspace(0.0, scenario.settings.t_end, 1001)
    weights = elastic_rate_weights(system.modal, system.chain.joints, None, scenario.sensors,
                                   ())
    assert weights.min() < 0.1

    def run(rtol: float, rate_weights: np.ndarray | None):
        return integrate_forward(system, t, rtol, 1e-12, "radau5", rate_weights=rate_weights)

    tip = modal_data(scenario.chain.links[1]).tip_value

    def signals(solution):  # hub angle, travel, the beam's tip deflection
        return solution.q[:, 0], solution.q[:, 1], solution.q[:, 2:] @ tip

    reference = signals(run(1e-9, None))
    steps, errors = [], []
    for rtol in np.geomspace(0.7e-4, 1.4e-4, 15):
        plain, weighted = run(rtol, None), run(rtol, weights)
        steps.append(weighted.stats["steps"] / plain.stats["steps"])
        errors.append([np.abs(ours - ref).max() / np.abs(ref).max()
                       for ours, ref in zip(signals(weighted), reference)])
    assert np.median(steps) < 0.6, steps
    assert np.all(np.median(errors, axis=0) < 4e-4), errors
    assert np.max(errors) < 2e-3, errors


def test_displacement_weights_make_an_amplitude_error_count_alike_at_every_phase() -> None:
    """Each elastic coordinate weighs ω_j/ω₁ times its rate's weight (1 by default); the
    forward state's weights put them on z, the rate weights on ż, 1 on the rigid parts."""
    from flexlink.simulation.forward import forward_system
    from flexlink.solvers.error_weights import displacement_weights, mode_frequencies
    from flexlink.solvers.forward import state_weights

    scenario = _slider_case()
    system = forward_system(scenario)
    omega = np.concatenate(mode_frequencies(system.modal))
    assert np.allclose(displacement_weights(system.modal), omega / omega[0])
    rates = omega[0] / omega
    assert np.allclose(displacement_weights(system.modal, rates), 1.0)
    nu, n = len(system.free), system.n
    size = system.initial_state().size
    w = state_weights(system, size, None)
    assert np.all(w[:2 * nu] == 1.0) and np.all(w[2 * nu + 2 * n:] == 1.0)
    assert np.allclose(w[2 * nu:2 * nu + n], omega / omega[0])
    assert np.all(w[2 * nu + n:2 * nu + 2 * n] == 1.0)


def test_a_ringing_top_mode_no_longer_lets_the_hub_drift() -> None:
    """The slider case at the forward default rtol 1e-4: its beam's undamped top mode (ω₄ ≈
    50 ω₁) rings after the bang-bang switches. Counted plainly, that mode's error passed
    whenever it sat in its displacement (tolerance ω₄/ω₁ times looser in amplitude than its
    rate's): a third of the steps were rejected and the hub angle drifted to 1.1e-3 of its
    peak from the rtol-1e-9 run, twice the model's own error against the FE model (5.4e-4,
    docs/performance.md). With the displacement weights: few rejections, and the angle,
    travel and tip within about a tenth of that."""
    from flexlink.modes import modal_data
    from flexlink.simulation.forward import forward_system
    from flexlink.solvers.forward import integrate_forward

    scenario = _slider_case()
    system = forward_system(scenario)
    t = np.linspace(0.0, scenario.settings.t_end, 1001)
    reference = integrate_forward(system, t, 1e-9, 1e-12, "radau5")
    run = integrate_forward(system, t, 1e-4, 1e-12, "radau5")
    assert run.stats["rejected_steps"] < 0.05 * run.stats["steps"]
    tip = modal_data(scenario.chain.links[1]).tip_value
    for ours, ref in ((run.q[:, 0], reference.q[:, 0]), (run.q[:, 1], reference.q[:, 1]),
                      (run.q[:, 2:] @ tip, reference.q[:, 2:] @ tip)):
        assert np.abs(ours - ref).max() < 7e-5 * np.abs(ref).max()
