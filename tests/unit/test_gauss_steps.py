"""Error-controlled steps of the Gauss collocation (solvers/gauss_steps.py) and the accuracy
every integrator reports (solvers/solution.py Accuracy)."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink import simulate
from flexlink.dynamics.nonlinear import NonlinearSystem
from flexlink.model import (
    BangBang,
    Chain,
    Link,
    PointSensor,
    Scenario,
    SimulationSettings,
    TorqueDrive,
)
from flexlink.model.settings import DEFAULT_RTOL, FORWARD_RTOL, default_rtol
from flexlink.motion import Cycloidal
from flexlink.solvers.gauss import (
    NEWTON_MAX,
    NEWTON_TOL,
    NODES,
    ROUND_OFF,
    integrate_adaptive,
    solve_nonlinear,
)
from flexlink.solvers.gauss_steps import DOUBLING_STAGES

BEAM = Link("beam", 1.0, 0.5, 8.0, modes=3, damping_ratio=0.0, thickness=0.005)


def _swing(duration: float = 0.3, start: float = 0.1) -> Chain:
    """A light beam swung 90° (large deflection): breakpoints at start and start + duration."""
    return Chain((BEAM,), (Cycloidal(0.0, 90.0, start, duration),))


def test_the_doubling_kernel_keeps_the_two_half_steps() -> None:
    """One doubled step H from a state ends where two plain steps of H/2 end (the uniform
    loop, the same Newton tolerance): the half steps are the solution, the H step only
    the estimate."""
    from flexlink.solvers._gauss_numba import gauss_doubling, gauss_loop, residual_model
    from flexlink.solvers.gauss_steps import GAUSS2, newton_settings, step_control

    system = NonlinearSystem(_swing())
    n, H, t0 = system.n, 0.02, 0.15
    q0, v0 = np.linspace(0.01, -0.02, n), np.linspace(-0.3, 0.2, n)
    data = system.kernel_data()
    model = residual_model(data)
    newton = newton_settings(NEWTON_TOL, NEWTON_MAX, ROUND_OFF * system.max_frequency**2, False)
    X0 = np.repeat(system.accelerations(np.array([t0]), q0[None], v0[None]), 2, axis=0)

    def rows(times: np.ndarray):
        return system.node_inputs(times).stage_inputs()

    q, v = np.array([q0, q0]), np.array([v0, v0])
    errors = np.zeros(1)
    status, accepted = gauss_doubling(
        model, rows(t0 + H * DOUBLING_STAGES), q, v, X0.copy(), H, H, GAUSS2, newton,
        step_control(np.zeros(n), 1.0, 1.0, 0.0), errors, np.zeros((2, 2 * n, 2 * n)),
        np.zeros(3, np.int64), np.empty((2, n, 3 * n)), np.zeros(2, np.int64), np.zeros(1))
    assert (status, accepted) == (0, 1)
    qh, vh = np.array([q0, q0, q0]), np.array([v0, v0, v0])
    half = t0 + 0.5 * H * (np.arange(2)[:, None] + NODES[None, :]).ravel()
    failed, _, _ = gauss_loop(model, rows(half), qh, vh, X0.copy(), 0.5 * H, GAUSS2, newton,
                              False, np.zeros(1))
    assert failed == -1
    scale = np.abs(qh).max()
    assert np.abs(q[1] - qh[2]).max() <= 1e-8 * scale  # within Newton's tolerance
    assert np.abs(v[1] - vh[2]).max() <= 1e-8 * np.abs(vh).max()
    assert 0.0 < errors[0] < 1.0


def test_adaptive_steps_end_on_the_breakpoints_and_grow_at_rest() -> None:
    system = NonlinearSystem(_swing(0.3, 0.1))
    record = integrate_adaptive(system, 1.0, 1e-5)
    for b in (0.1, 0.4, 1.0):
        assert np.min(np.abs(record.t - b)) == 0.0
    h = np.diff(record.t)
    assert np.all(h > 0)
    # before the move the beam rests: nothing to resolve, the steps grow to the limit 4× per batch
    assert h[record.t[:-1] < 0.1].size <= 8
    assert record.largest_error <= 1.0


def test_the_error_follows_the_tolerance() -> None:
    """Against a run at rtol 1e-10, the tip path's error shrinks with rtol and stays within
    a small multiple of it (the control bounds each step's error; measured ×1–30 on the
    validation cases' deflections, docs/nonlinear.md §4); the estimate reported is within rtol."""
    system = NonlinearSystem(_swing())
    t = np.linspace(0.0, 1.0, 501)
    exact = solve_nonlinear(system, t, 1e-10)
    peak = np.abs(exact.q).max()
    errors = {}
    for rtol in (1e-4, 1e-6):
        run = solve_nonlinear(system, t, rtol)
        errors[rtol] = np.abs(run.q - exact.q).max() / peak
        assert run.accuracy is not None and run.accuracy.rtol == rtol
        assert 0.0 < run.accuracy.estimate <= rtol
        assert errors[rtol] <= 20 * rtol
    assert errors[1e-6] < errors[1e-4] / 10


def test_forward_steps_end_on_the_bang_bang_switches() -> None:
    """A torque-driven hub–beam (nonlinear forward model): adaptive steps land on the
    torque's switch times, and the run says what it reached."""
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
    from flexlink.solvers.gauss_forward import integrate_forward_adaptive

    chain = Chain((BEAM,), (TorqueDrive(BangBang(1.0, 0.2, 0.5), motor_inertia=0.5),))
    record = integrate_forward_adaptive(NonlinearForwardSystem(chain), 1.0, 1e-5)
    for b in (0.2, 0.45, 0.7, 1.0):
        assert np.min(np.abs(record.t - b)) == 0.0
    assert record.largest_error <= 1.0


def test_each_model_has_its_default_tolerance() -> None:
    assert _scenario("first_order").settings.rtol == DEFAULT_RTOL["first_order"] == 1e-6
    assert _scenario("nonlinear").settings.rtol == DEFAULT_RTOL["nonlinear"]
    assert _scenario("nonlinear", driven=True).settings.rtol == DEFAULT_RTOL["nonlinear"]
    assert _scenario("first_order", driven=True).settings.rtol == FORWARD_RTOL
    assert _scenario("nonlinear", rtol=1e-7).settings.rtol == 1e-7


def _scenario(model: str, driven: bool = False, **settings: object) -> Scenario:
    joint = (TorqueDrive(BangBang(0.5, 0.0, 0.4), motor_inertia=0.5) if driven
             else Cycloidal(0.0, 30.0, 0.0, 0.4))
    return Scenario(Chain((BEAM,), (joint,)), (PointSensor("tip", "deflection", 0, 1.0),),
                    SimulationSettings(0.6, 0.01, model=model, **settings))  # type: ignore


@pytest.mark.parametrize(("model", "driven", "measure"), [
    ("first_order", False, "Richardson"), ("first_order", True, "none reported: Radau IIA"),
    ("nonlinear", False, "step doubling"), ("nonlinear", True, "step doubling")])
def test_every_path_says_what_accuracy_it_reached(model: str, driven: bool,
                                                  measure: str) -> None:
    results = simulate(_scenario(model, driven))
    meta = results.metadata
    assert meta["rtol"] == default_rtol(model, driven)
    if measure.startswith("none"):  # local error control: no global estimate to report
        assert "error_estimate" not in meta
    else:
        assert 0.0 < meta["error_estimate"] <= meta["rtol"]
    assert meta["error_estimate_measure"].startswith(measure)


def test_a_fixed_step_or_scipy_makes_no_estimate() -> None:
    for scenario in (_scenario("nonlinear", step=0.01), _scenario("first_order", method="RK45")):
        meta = simulate(scenario).metadata
        assert "error_estimate" not in meta and meta["error_estimate_measure"].startswith("none")



def test_the_cli_summary_says_what_was_asked_for_and_reached(tmp_path) -> None:
    from flexlink.cli import summary

    text = summary(simulate(_scenario("nonlinear")), tmp_path, "beam")
    line = next(x for x in text.splitlines() if x.startswith("accuracy:"))
    assert "rtol 1e-05 asked for" in line and "(step doubling)" in line
    fixed = summary(simulate(_scenario("nonlinear", step=0.01)), tmp_path, "beam")
    assert "rtol 1e-05 asked for, no error estimate" in fixed


def test_both_nonlinear_models_reach_one_compiled_loop() -> None:
    """The compiled Gauss loops take a model of the same type for both nonlinear records
    (each record's residual behind a pointer), so numba compiles each loop once for both;
    a record without a compiled residual is refused by name."""
    from numba import typeof

    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
    from flexlink.solvers._gauss_numba import residual_model

    prescribed = NonlinearSystem(_swing()).kernel_data()
    driven = NonlinearForwardSystem(Chain((BEAM,), (TorqueDrive(BangBang(1.0, 0.2, 0.5),
                                                                motor_inertia=0.5),))
                                    ).kernel_data()
    assert type(prescribed) is not type(driven)
    models = residual_model(prescribed), residual_model(driven)
    assert typeof(models[0]) == typeof(models[1])
    assert models[0][0] != models[1][0] and models[0][2] == prescribed.n
    with pytest.raises(TypeError, match="no compiled residual for kernel data tuple"):
        residual_model((1.0, 2.0))


def test_unchecked_doubling_steps_are_two_half_steps() -> None:
    """With every = 3, steps 0 and 3 of a batch are checked (H and two H/2 steps), steps 1
    and 2 are their two H/2 steps alone: the batch ends where uniform steps of H/2 end
    (within Newton's tolerance), with errors only for the checked steps and fewer Newton
    iterations than checking every step."""
    from flexlink.solvers._gauss_numba import gauss_doubling, gauss_loop, residual_model
    from flexlink.solvers.gauss_steps import GAUSS2, newton_settings, step_control

    system = NonlinearSystem(_swing())
    n, H, t0, count = system.n, 0.01, 0.15, 4
    q0, v0 = np.linspace(0.01, -0.02, n), np.linspace(-0.3, 0.2, n)
    model = residual_model(system.kernel_data())
    newton = newton_settings(NEWTON_TOL, NEWTON_MAX, ROUND_OFF * system.max_frequency**2, False)
    X0 = np.repeat(system.accelerations(np.array([t0]), q0[None], v0[None]), 2, axis=0)
    stages = (t0 + H * (np.arange(count)[:, None] + DOUBLING_STAGES[None, :])).ravel()
    rows = system.node_inputs(stages).stage_inputs()

    def doubled(every: int):
        q, v = np.repeat(q0[None], count + 1, axis=0), np.repeat(v0[None], count + 1, axis=0)
        errors, counts = np.zeros(count), np.zeros(2, np.int64)
        status, accepted = gauss_doubling(
            model, rows, q, v, X0.copy(), H, H, GAUSS2, newton,
            step_control(np.zeros(n), 1.0, 1.0, 0.0), errors, np.zeros((2, 2 * n, 2 * n)),
            np.zeros(3, np.int64), np.empty((2, n, 3 * n)), counts, np.zeros(1), every)
        assert (status, accepted) == (0, count)
        return q, v, errors, counts[1]

    q, v, errors, iterations = doubled(3)
    _, _, every_step, all_iterations = doubled(1)
    assert np.all(errors[[0, 3]] > 0.0) and np.all(errors[[1, 2]] == 0.0)
    np.testing.assert_array_equal(errors[[0, 3]] > 0.0, every_step[[0, 3]] > 0.0)
    assert iterations < all_iterations
    half = t0 + 0.5 * H * (np.arange(2 * count)[:, None] + NODES[None, :]).ravel()
    qh = np.repeat(q0[None], 2 * count + 1, axis=0)
    vh = np.repeat(v0[None], 2 * count + 1, axis=0)
    failed, _, _ = gauss_loop(model, system.node_inputs(half).stage_inputs(), qh, vh,
                              X0.copy(), 0.5 * H, GAUSS2, newton, False, np.zeros(1))
    assert failed == -1
    np.testing.assert_allclose(q, qh[::2], rtol=0, atol=1e-8 * np.abs(qh).max())
    np.testing.assert_allclose(v, vh[::2], rtol=0, atol=1e-8 * np.abs(vh).max())
