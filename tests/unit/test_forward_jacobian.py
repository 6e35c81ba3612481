"""The forward rates' linearization (dynamics/_forward_jacobian_numba.py, through
driven_sensitivities._linearization) against central differences of the compiled rates at
the stage states of runs: ∂f/∂y (exact along the elastic coordinates, differences of the
equations at fixed accelerations elsewhere) and ∂f/∂p of several kinds of fields. Systems:
two links behind servos, an elastic joint behind a servo, a free base, a cart, a slider."""

from __future__ import annotations

import numpy as np
import pytest

import flexlink
from flexlink.simulation.driven_sensitivities import _linearization, _model, _rates
from flexlink.simulation.forward import run_forward
from flexlink.simulation.sensitivities import prepare_fields, scenario_file
from flexlink.solvers.radau_sensitivity import (
    NODES,
    stage_jacobians,
    step_sequence,
    table_rows,
)


@pytest.mark.parametrize("example, t_end, fields", [
    ("examples/paper_servo.toml", 1.2, ["links[0].E", "joints[0].P", "joints[1].bandwidth",
                                        "joints[0].motor_inertia"]),
    ("examples/flexible_joint_arm.toml", 0.5, ["joints[0].spring_stiffness",
                                               "links[0].mass_per_length"]),
    ("examples/satellite_slew.toml", 2.0, ["base.inertia",
                                           "base.loads[0].moment[0].amplitude"]),
    ("examples/cart_beam.toml", 0.5, ["links[0].EI"]),
    ("examples/telescoping_arm.toml", 0.5, ["links[0].EI"])])
def test_linearization_matches_central_differences(example: str, t_end: float,
                                                   fields: list[str]) -> None:
    file = scenario_file(flexlink.load_scenario(example))
    scenario = file.build({("simulation", "t_end"): t_end})
    t = np.linspace(0.0, t_end, 11)
    records: list = []
    run_forward(scenario, t, None, False, steps=records)
    steps = step_sequence(records)
    model = _model(scenario, t, None)
    prepared = prepare_fields(file, scenario, fields)
    moved = [[model if j == 0 else _model(sc, t, None) for j, sc in
              zip(f.offsets, f.scenarios, strict=True)] for f in prepared]
    jacobians, forcing = _linearization(model, moved, prepared, [True] * len(fields))
    times = (steps.t[:, None] + steps.h[:, None] * NODES).ravel()
    segment = np.repeat(steps.segment, 3)
    Y = (steps.y0[:, None, :] + steps.z).reshape(-1, model.y0.size)
    pick = np.linspace(0, Y.shape[0] - 1, 40).astype(int)
    Y, times, segment = Y[pick], times[pick], segment[pick]
    u = table_rows(model.table, segment, times)
    J = jacobians(u, Y)
    central = stage_jacobians(_rates(model), u, Y)
    scale = np.abs(central).max(axis=1, keepdims=True)  # per state, per column
    # a column the rates do not depend on (a free base's position): round-off of the rest
    floor = 1e-6 * np.abs(central).max(axis=(1, 2), keepdims=True)
    assert np.all(np.abs(J - central) <= 1e-6 * np.maximum(scale, floor))
    # the rates are affine in the elastic rates ż (the equations' matrix reads the
    # configuration alone): a unit step of the compiled rates is their column to round-off
    # (1e-14 of the column: a kernel that put its unit steps back by subtraction, z + 1 − 1,
    # left the stiffness times that round-off in the later columns, up to 1e-10 of them)
    nu, n = len(model.system.free), model.system.n
    rates = _rates(model)
    f0 = rates(u, Y)
    for c in range(2 * nu + n, 2 * nu + 2 * n):
        step = Y.copy()
        step[:, c] += 1.0
        unit = rates(u, step) - f0
        bound = 1e-12 * np.maximum(scale[:, :, c], floor[:, :, 0])
        assert np.all(np.abs(J[:, :, c] - unit) <= bound)
    Fp = forcing(times, segment, Y)
    for k, f in enumerate(prepared):
        rates = [_rates(md) for md in moved[k]]
        reference = sum(w * r(table_rows(md.table, segment, times), Y) for w, r, md in
                        zip(f.weights, rates, moved[k], strict=True)) / f.step
        assert np.abs(Fp[:, :, k] - reference).max() <= 1e-6 * np.abs(reference).max(), \
            f.target.text


def test_outputs_with_given_accelerations() -> None:
    """The outputs pass with accelerations given equals the one that solves for them (to
    the bit, given those it solved for), and a moved model's accelerations from one Newton
    step off the nominal ones (`_moved_accelerations`) match its solved ones to second
    order in the move."""
    from flexlink.dynamics.forward_kernel import inputs
    from flexlink.dynamics.forward_outputs import forward_outputs
    from flexlink.simulation.driven_sensitivities import _accelerations, _moved_accelerations

    file = scenario_file(flexlink.load_scenario("examples/paper_servo.toml"))
    scenario = file.build({("simulation", "t_end"): 1.2})
    t = np.linspace(0.0, 1.2, 61)
    records: list = []
    run_forward(scenario, t, None, False, steps=records)
    steps = step_sequence(records)
    model = _model(scenario, t, None)
    states = np.vstack([model.y0, steps.y1[np.linspace(0, steps.h.size - 1, 60).astype(int)]])
    u = inputs(model.system, t)
    solved = forward_outputs(model.system, model.data, model.work, u, states)
    nu, n = len(model.system.free), model.system.n
    acc = np.hstack([solved.rates[:, nu:2 * nu], solved.rates[:, 2 * nu + n:2 * nu + 2 * n]])
    given = forward_outputs(model.system, model.data, model.work, u, states,
                            accelerations=acc)
    assert np.array_equal(given.rates, solved.rates)
    assert np.array_equal(given.torques, solved.torques)
    assert np.array_equal(given.frames.alpha, solved.frames.alpha)
    A, a0 = _accelerations(model, t, states)
    assert np.array_equal(a0, acc)
    direction = np.random.default_rng(0).standard_normal(states.shape) * 1e-3
    for rel in (1e-3, 1e-4):
        moved = _model(file.build({("simulation", "t_end"): 1.2,
                                   ("links", 0, "E"): 30e9 * (1 + rel)}), t, None)
        y = states + rel * direction
        exact = forward_outputs(moved.system, moved.data, moved.work,
                                inputs(moved.system, t), y).rates
        exact = np.hstack([exact[:, nu:2 * nu], exact[:, 2 * nu + n:2 * nu + 2 * n]])
        step = _moved_accelerations(moved, t, y, A, a0)
        error = np.abs(step - exact).max() / np.abs(exact - a0).max()
        assert error < 0.3 * rel, (rel, error)  # second order: relative error ∝ the move


@pytest.mark.parametrize("example", ["examples/satellite_slew.toml",
                                     "examples/cart_beam.toml"])
def test_projection_is_affine_in_the_rates(example: str) -> None:
    """The momentum projection of a state (free base, cart) is affine in the rates at a fixed
    configuration (the momentum is linear in them, and so is the correction that restores
    it): what lets the sensitivities take its Jacobian's rate columns from one unit step.
    Checked at run states: a unit step and a double one, and central differences."""
    from flexlink.simulation.driven_sensitivities import _Bases, _projected

    scenario = scenario_file(flexlink.load_scenario(example)).build(
        {("simulation", "t_end"): 0.5})
    t = np.linspace(0.0, 0.5, 6)
    records: list = []
    run_forward(scenario, t, None, False, steps=records)
    steps = step_sequence(records)
    model = _model(scenario, t, None)
    assert model.projection.active.size > 0
    nu, n = model.data.free.shape[0], model.data.n_x - model.data.n_rigid
    Y = steps.y0[::max(1, steps.h.size // 8)]
    times = steps.t[::max(1, steps.h.size // 8)]
    segment = steps.segment[::max(1, steps.h.size // 8)]
    bases = _Bases(segment, times)
    base = _projected(model, Y, times, bases)
    corrected = 0.0
    for j in [*range(nu, 2 * nu), 2 * nu + n, 2 * nu + 2 * n - 1]:  # rigid and elastic rates
        moved = [Y.copy() for _ in range(4)]
        for s, y in zip([1.0, 2.0, 1e-5, -1e-5], moved, strict=True):
            y[:, j] += s
        one, two, up, down = (_projected(model, y, times, bases) for y in moved)
        unit = one - base  # a column of the Jacobian (per unit of the rate)
        unit[:, j] -= 1.0  # what the projection corrects
        corrected = max(corrected, np.abs(unit).max())
        unit[:, j] += 1.0
        assert np.abs((two - base) - 2.0 * unit).max() <= 1e-12
        assert np.abs((up - down) / 2e-5 - unit).max() <= 1e-7
    assert corrected > 1e-3  # the rates moved the momentum, and the projection restored it
