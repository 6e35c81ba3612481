"""An objective's gradient on the forward path by the reverse pass of the Radau IIA run's
steps (simulation/forward_adjoint.py): equal to the forward tangents' gradient to
round-off, and to central differences of the objective over an exact replay of the run's
accepted steps (collocation equations solved to convergence at the moved fields, the
projection onto the known momentum after each step and at each output), on a torque-driven
hub–beam, velocity and position servos and a free base."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import flexlink
from flexlink.scenario.load import scenario_from_dict
from flexlink.simulation import driven_sensitivities as ds
from flexlink.simulation.common import output_times
from flexlink.simulation.forward_adjoint import sensor_rows, state_gradient
from flexlink.simulation.sensitivities import SensitivityError, prepare_fields, scenario_file
from flexlink.solvers.radau_sensitivity import (
    COEFFICIENTS,
    NODES,
    dense,
    output_steps,
    stage_jacobians,
    table_rows,
)

from .test_forward_sensitivities import FREE_BASE, HUB_BEAM

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
# (scenario text, overrides, metric channel, fields of different kinds)
CASES = {
    "hub_beam": (HUB_BEAM, {}, "root_strain",
                 ["links[0].EI", "links[0].mass_per_length", "joints[0].torque[0].amplitude",
                  "joints[0].motor_inertia", "sensors[0].x", "links[0].damping_ratio"]),
    "servo": ("", {("simulation", "t_end"): 0.8}, "link2_tip_deflection",
              ["links[0].E", "links[1].mass_per_length", "joints[0].P", "joints[0].D",
               "joints[1].bandwidth", "joints[0].rate_per_volt_deg_s"]),
    "free_base": (FREE_BASE, {}, "array_tip_deflection",
                  ["base.inertia", "base.rate_deg_s", "links[0].mass_per_length",
                   "links[0].EI", "base.loads[0].moment[0].amplitude"]),
}
FREE_BASE_SENSOR = """
[[sensors]]
name = "array_tip_deflection"
kind = "deflection"
link = "array"
x = 1.5
"""


def _scenario(name: str) -> flexlink.Scenario:
    text, overrides, _, _ = CASES[name]
    if name == "servo":  # examples/paper_servo.toml, shortened
        return scenario_file(flexlink.load_scenario(EXAMPLES / "paper_servo.toml")).build(
            overrides)
    if name == "free_base":
        text = text + FREE_BASE_SENSOR
    return scenario_file(scenario_from_dict(tomllib.loads(text))).build(overrides)


def _metric(name: str, scenario: flexlink.Scenario) -> flexlink.MeanSquare:
    return flexlink.MeanSquare(CASES[name][2], after=0.25 * scenario.settings.t_end)


@pytest.mark.parametrize("name", list(CASES))
def test_the_reverse_pass_equals_the_tangents(name: str) -> None:
    """The objective's gradient (method "adjoint") against Σ ∂J/∂channel · ∂channel/∂field
    of the forward tangents, and the reverse pass alone against random seeds on every
    state coordinate (rates, servo integrals, rigid coordinates included)."""
    scenario = _scenario(name)
    fields = CASES[name][3]
    metric = _metric(name, scenario)
    objective = flexlink.Objective(scenario, fields, metric)
    value, gradient = objective(objective.x0)
    assert objective.method == "adjoint"
    results = flexlink.simulate(scenario, shapes=False, sensitivities=fields)
    reference, slopes = metric(results)
    assert value == pytest.approx(reference, rel=1e-12)
    channel = CASES[name][2]
    tangents = slopes[channel] @ results.sensitivities.sel(channel=channel).values
    # the tangents' channels are central differences along the state's tangent over the
    # field's step δ: round-off ε |c| / δ, ~1e-10 of the gradient
    assert np.abs(gradient - tangents).max() <= 1e-9 * np.abs(tangents).max()

    file = scenario_file(scenario)
    prepared = prepare_fields(file, scenario, fields)
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    settled = ds.forward_settled(scenario, prepared, t, lambda *_: None, False)
    derivatives = ds.state_tangents(settled, prepared, t)
    seeds = np.random.default_rng(3).standard_normal(derivatives.shape[:2])
    seeds[: t.size // 4] = 0.0
    expected = np.einsum("ti,tik->k", seeds, derivatives)
    got = state_gradient(settled, prepared, t, seeds)
    assert np.abs(got - expected).max() <= 1e-11 * np.abs(expected).max()


def _replay(scenario: flexlink.Scenario, steps, t: np.ndarray, channel: str) -> np.ndarray:
    """The channel (nt,) of ``scenario`` on the accepted steps ``steps`` of another run:
    each step's collocation equations solved by Newton to round-off with its own rates,
    projected onto its known momentum as the compiled loop does, the outputs from the
    steps' collocation polynomials (projected too)."""
    model = ds._model(scenario, t, None)
    rates = ds._rates(model)
    m = model.y0.size
    projected = model.projection.active.size > 0
    y = model.y0.copy()
    S = steps.h.size
    y0s, zs, y1s = np.empty((S, m)), np.empty((S, 3, m)), np.empty((S, m))
    hA = np.kron(COEFFICIENTS, np.eye(m))
    for s in range(S):
        h, segment = steps.h[s], np.full(3, steps.segment[s])
        u = table_rows(model.table, segment, steps.t[s] + NODES * h)
        z = steps.z[s].copy()
        for _ in range(30):
            residual = (z - h * COEFFICIENTS @ rates(u, y + z)).ravel()
            J = stage_jacobians(rates, u, y + z)
            blocks = np.zeros((3 * m, 3 * m))
            for j in range(3):
                blocks[j * m:(j + 1) * m, j * m:(j + 1) * m] = J[j]
            step = np.linalg.solve(np.eye(3 * m) - h * hA @ blocks, -residual)
            z += step.reshape(3, m)
            if np.abs(step).max() <= 1e-15 * max(1.0, np.abs(z).max()):
                break
        y0s[s], zs[s] = y, z
        end = y + z[2]
        if projected:
            end = ds._projected(model, end[None], np.array([steps.t[s] + h]),
                                ds._Bases(steps.segment[s:s + 1],
                                          np.array([steps.t[s] + h])))[0]
        y1s[s] = y = end
    which, abscissa = output_steps(steps, t)
    states = np.vstack([model.y0, dense(y0s[which], zs[which], y1s[which], abscissa)])
    if projected:
        states[1:] = ds._projected(model, states[1:], t[1:],
                                   ds._Bases(steps.segment[which], t[1:]))
    return states @ sensor_rows(model, [channel])[channel]


@pytest.mark.parametrize("name", list(CASES))
def test_the_gradient_is_the_derivative_of_the_objective_on_the_run_s_steps(name: str) -> None:
    """Central differences of the objective over the replayed steps (fourth order, steps
    1e-4 of each field) against the reverse pass's gradient: within 1e-6 relative."""
    scenario = _scenario(name)
    fields = CASES[name][3]
    channel = CASES[name][2]
    metric = _metric(name, scenario)
    objective = flexlink.Objective(scenario, fields, metric)
    _, gradient = objective(objective.x0)
    file = scenario_file(scenario)
    prepared = prepare_fields(file, scenario, fields)
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    settled = ds.forward_settled(scenario, prepared, t, lambda *_: None, False)
    keep = t >= metric.after

    def value(path, x: float) -> float:
        c = _replay(file.build({path: x}), settled.steps, t, channel)
        return float(np.sum(c[keep] ** 2) / keep.sum())

    for k, f in enumerate(prepared):
        p = float(f.target.value)
        d = 1e-4 * (abs(p) or 1.0)
        D = (8 * (value(f.target.path, p + d) - value(f.target.path, p - d))
             - (value(f.target.path, p + 2 * d) - value(f.target.path, p - 2 * d))) / (12 * d)
        assert gradient[k] == pytest.approx(D, rel=1e-6, abs=1e-6 * np.abs(gradient).max()), \
            fields[k]


def _assert_the_gradient_is_the_tangents(scenario, fields: list[str], channel: str) -> None:
    """The objective (mean square of `channel` after 0.1 s) takes its gradient from the
    fields' tangents, and it equals the tangents' contraction with the metric's slopes."""
    metric = flexlink.MeanSquare(channel, after=0.1)
    objective = flexlink.Objective(scenario, fields, metric)
    _, gradient = objective(objective.x0)
    assert objective.method == "tangents"
    results = flexlink.simulate(scenario, shapes=False, sensitivities=fields)
    _, slopes = metric(results)
    tangents = slopes[channel] @ results.sensitivities.sel(channel=channel).values
    assert np.allclose(gradient, tangents, rtol=1e-12, atol=0)


def test_an_accelerometer_metric_takes_the_tangents() -> None:
    """A channel the reverse pass does not read linearly from the state (an accelerometer
    on the servo arm): the gradient from the fields' tangents, equal to theirs."""
    scenario = _scenario("servo")
    fields = ["links[0].E", "joints[0].P"]
    _assert_the_gradient_is_the_tangents(scenario, fields, "link1_tip_acceleration")


def test_a_metric_over_a_channel_the_run_does_not_produce_is_refused_naming_it(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """Refused before the run: the run is never started."""
    from flexlink.simulation import sensitivities

    scenario = _scenario("hub_beam")
    objective = flexlink.Objective(scenario, ["links[0].EI"], flexlink.MeanSquare("tip_strain"))

    def no_run(*args: object, **kwargs: object) -> None:
        raise AssertionError("the run started")
    monkeypatch.setattr(sensitivities, "sensitivity_run", no_run)
    with pytest.raises(SensitivityError, match="'tip_strain'.*root_strain"):
        objective(objective.x0)


def test_sampled_controllers_take_the_tangents() -> None:
    """PPF on the hub–beam, sampled: the held voltages' derivative is not in the reverse
    pass, so the objective's gradient comes from the fields' tangents, equal to theirs."""
    from .test_forward_sensitivities import PPF

    scenario = scenario_file(scenario_from_dict(tomllib.loads(PPF))).build(
        {("simulation", "t_end"): 0.3})
    fields = ["controllers[0].gain", "links[0].EI"]
    _assert_the_gradient_is_the_tangents(scenario, fields, "root_strain")


def _assert_moved_equations_are_the_full_ones(prepared, settled, parts) -> None:
    """At the run's stage states, `record_moves.moved_equations` of each field whose moves
    ``parts`` names (None: the full equations) equals the moved models' full equations,
    E to 1e-9 of its size (plus the full equations' own round-off), the servo integrals'
    rows to 1e-12."""
    from flexlink.dynamics._forward_jacobian_numba import forward_accelerations, forward_equations
    from flexlink.simulation.record_moves import applied_forces, moved_equations

    nominal = settled.nominal
    steps = settled.steps
    Y = np.ascontiguousarray((steps.y0[:, None, :] + steps.z).reshape(-1, nominal.y0.size))
    times = (steps.t[:, None] + steps.h[:, None] * NODES).ravel()
    bases = ds._Bases(np.repeat(steps.segment, 3), times)
    d = nominal.data
    q = d.free.shape[0] + d.n_x - d.n_rigid
    acc = np.empty((Y.shape[0], q))
    forward_accelerations(d, nominal.work, np.ascontiguousarray(bases.rows(nominal.table)), Y,
                          np.empty((Y.shape[0], q, q)), acc)
    ns = nominal.y0.size - 2 * q
    applied0 = applied_forces(nominal, bases.rows(nominal.table), Y)
    for k, part in enumerate(parts):
        if part is None:
            continue
        full, mine = np.zeros((Y.shape[0], q)), np.zeros((Y.shape[0], q))
        full_s, mine_s = np.zeros((Y.shape[0], ns)), np.zeros((Y.shape[0], ns))
        for w, md in zip(prepared[k].weights, settled.moved[k], strict=True):
            u = np.ascontiguousarray(bases.rows(md.table))
            E, S = np.empty((Y.shape[0], q)), np.empty((Y.shape[0], ns))
            forward_equations(md.data, md.work, u, Y, acc, E, S)
            full += w * E
            full_s += w * S
            moved_equations(md, nominal, part, applied0, u, Y, acc, E, S)
            mine += w * E
            mine_s += w * S
        scale = np.abs(full).max()
        assert scale > 0.0
        noise = 1e-14 * np.abs(applied0[0]).max()  # the full equations' own round-off
        assert np.abs(mine - full).max() <= 1e-9 * scale + noise
        if ns:  # servo integrals
            assert np.abs(mine_s - full_s).max() <= 1e-12 * max(np.abs(full_s).max(), 1.0)


def test_a_field_of_the_drives_or_the_modal_stiffness_moves_e_by_those_terms_alone() -> None:
    """Fields that move only the drives' gains and limits or the links' modal stiffness
    and damping (`record_moves.moved_arrays`) take E's change from those terms alone:
    equal to the moved models' full equations at the run's stage states; a link's mass
    or a motor's inertia is not such a field."""
    from flexlink.simulation.record_moves import moved_arrays

    scenario = _scenario("servo")
    fields = ["links[1].mass_per_length", "joints[0].motor_inertia", "joints[0].P",
              "joints[0].D", "joints[1].bandwidth", "joints[0].rate_per_volt_deg_s",
              "links[0].E", "links[1].damping_ratio"]
    prepared = prepare_fields(scenario_file(scenario), scenario, fields)
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    settled = ds.forward_settled(scenario, prepared, t, lambda *_: None, False)
    nominal = settled.nominal
    parts = [moved_arrays(nominal, group) for group in settled.moved]
    assert parts[:2] == [None, None]
    assert parts[2] == {"P"} and parts[6] == {"stiffness", "damping"} and parts[7] == {"damping"}
    assert all(part is not None for part in parts[2:])
    assert settled.nominal.y0.size > 2 * (nominal.data.free.shape[0] + nominal.data.n_x
                                          - nominal.data.n_rigid)  # servo integrals
    _assert_moved_equations_are_the_full_ones(prepared, settled, parts)


@pytest.mark.parametrize("name, fields, expected", [
    # the hub–beam's modes are those of a beam on its hub: the motor's inertia moves them
    ("hub_beam", ["links[0].mass_per_length", "joints[0].torque[0].amplitude",
                  "joints[0].motor_inertia", "links[0].EI"],
     [None, {"inputs"}, None, {"stiffness", "damping"}]),
    ("servo", ["joints[0].motor_inertia", "links[0].E"],
     [{"motor_inertia"}, {"stiffness", "damping"}]),
    ("free_base", ["links[0].mass_per_length", "base.loads[0].moment[0].amplitude"],
     [None, {"inputs"}]),
])
def test_a_motor_inertia_or_an_applied_input_moves_e_by_its_own_term(
        name: str, fields: list[str], expected: list) -> None:
    """With ``more``, a motor's inertia (ΔJ_m p̈ on its row) and a drive's torque or a base
    load (Q with the moved inputs) are moves `record_moves.moved_equations` takes from
    their own terms: equal to the moved models' full equations at the run's stage states;
    a link's mass (or a hub's inertia that moves the modes) still takes the full equations,
    and without ``more`` neither is such a move; the projection keeps their field term."""
    from flexlink.simulation.record_moves import (
        moved_arrays,
        same_projection,
    )

    scenario = _scenario(name)
    prepared = prepare_fields(scenario_file(scenario), scenario, fields)
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    settled = ds.forward_settled(scenario, prepared, t, lambda *_: None, False)
    nominal = settled.nominal
    parts = [moved_arrays(nominal, group, more=True) for group in settled.moved]
    assert parts == expected
    for k, part in enumerate(parts):
        if part is not None and not part <= {"stiffness", "damping"}:
            assert moved_arrays(nominal, settled.moved[k]) is None
            assert not same_projection(nominal, settled.moved[k])
    _assert_moved_equations_are_the_full_ones(prepared, settled, parts)
