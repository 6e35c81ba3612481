"""The reverse pass of the Lawson steps (solvers/lawson_adjoint.py) and Objective's gradient
by it (simulation/adjoint.py): the same derivative as the fields' tangents to round-off, and
as central differences of the objective on the run's own discretisation."""

from __future__ import annotations

import numpy as np
import pytest

import flexlink
from flexlink.scenario.fields import ScenarioFile
from flexlink.simulation.channel_subset import State
from flexlink.simulation.common import output_times
from flexlink.simulation.sensitivities import prepare_fields, scenario_file, settled_run
from flexlink.solvers.lawson_adjoint import lawson_gradient
from flexlink.solvers.lawson_sensitivity import lawson_sensitivities

FIELDS = ["links[0].EI", "links[1].mass_per_length", "links[0].tip_mass",
          "links[1].damping_ratio", "links[0].damping_ratio", "sensors[pzt].capacitance",
          "sensors[pzt].d31", "joints[1].motion[0].to_deg", "joints[0].motion[0].from_deg",
          "links[1].thickness"]


def _paper(t_end: float = 2.0, **settings: object) -> ScenarioFile:
    file = scenario_file(flexlink.load_paper_experiment())
    raw = dict(file.raw)
    raw["simulation"] = {**raw["simulation"], "t_end": t_end, **settings}
    return ScenarioFile(raw, file.base_dir, file.name, file.source)


@pytest.mark.parametrize(("t_end", "settings"), [
    (2.0, {}), (2.0, {"initial": "equilibrium", "gravity": [0.0, -9.81]}),
    (0.02, {"initial": "equilibrium", "gravity": [0.0, -9.81]})])
def test_the_reverse_pass_is_the_transpose_of_the_tangents(t_end: float, settings: dict
                                                           ) -> None:
    """Random seeds on q, q̇, q̈ at every output time: the reverse pass's gradient equals
    the seeds paired with the tangents, to round-off (moving and static blocks: the paper
    manoeuvre rests before and after; a run that is one static block)."""
    file = _paper(t_end, **settings)
    scenario = file.build()
    fields = prepare_fields(file, scenario, FIELDS[:5] + FIELDS[7:])
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    settled = settled_run(scenario, fields, t, lambda _: None, False)
    layout = settled.discretisation.layout
    assert layout.static and (layout.moving or t_end < 0.1)
    _, dq, dqd, dqdd = lawson_sensitivities(settled.nominal, settled.derivative_rows, t,
                                            settled.discretisation)
    rng = np.random.default_rng(7)
    a, b, c = rng.standard_normal((3, t.size, settled.nominal.n))
    tangents = (np.einsum("ti,kti->k", a, dq) + np.einsum("ti,kti->k", b, dqd)
                + np.einsum("ti,kti->k", c, dqdd))
    gradient, states = lawson_gradient(settled.nominal, settled.derivative_rows, t,
                                       settled.discretisation, a, b, c)
    np.testing.assert_allclose(gradient, tangents, rtol=1e-11, atol=0.0)
    n = settled.nominal.n
    shift = 0.0 if settled.nominal.z_start is None else settled.nominal.z_start
    np.testing.assert_allclose(states[:, :n] + shift, settled.run.solution.q, rtol=0.0,
                               atol=1e-9 * np.abs(settled.run.solution.q).max())


@pytest.mark.parametrize("channel", ["link2_tip_deflection", "pzt", "link2_root_strain"])
def test_objective_gradient_by_the_reverse_pass(channel: str) -> None:
    """Ten fields of different kinds: the reverse pass's gradient equals the tangents'
    (Results.sensitivities paired with the metric's slopes) to 1e-8 and fourth-order
    central differences of the objective on the run's discretisation to 1e-6."""
    from flexlink.simulation.prescribed import run_prescribed
    from flexlink.solvers.lawson import integrate_lawson_discretised, integrate_lawson_on

    file = _paper()
    scenario = file.build()
    metric = flexlink.MeanSquare(channel, after=0.5)
    objective = flexlink.Objective(scenario, FIELDS, metric)
    value, gradient = objective(objective.x0)
    assert objective.method == "adjoint"
    results = flexlink.simulate(scenario, sensitivities=FIELDS, shapes=False)
    _, slopes = metric(results)
    tangents = slopes[channel] @ results.sensitivities.sel(channel=channel).values
    scale = np.abs(tangents).max()
    np.testing.assert_allclose(gradient, tangents, rtol=1e-8, atol=1e-12 * scale)
    # central differences of the objective on the run's discretisation
    t = results.time
    settled = []

    def adaptive(system, times, rtol, atol, progress):
        solution, disc = integrate_lawson_discretised(system, times, rtol, atol, progress)
        settled.append(disc)
        return solution

    run_prescribed(scenario, t, lambda _: None, False, adaptive)

    def on(system, times, rtol, atol, progress):
        return integrate_lawson_on(system, times, settled[0])

    keep = t >= 0.5
    for k, field in enumerate(FIELDS):
        target = file.locate(field)
        x = float(target.value)
        h = 1e-4 * abs(x) if x else 1e-4
        f = {j: np.mean(run_prescribed(file.build({target.path: x + j * h}), t,
                                       lambda _: None, False, on).values[channel][keep] ** 2)
             for j in (-2, -1, 1, 2)}
        fd = (8 * (f[1] - f[-1]) - (f[2] - f[-2])) / (12 * h)
        assert gradient[k] == pytest.approx(fd, rel=1e-6, abs=1e-9 * abs(value) / abs(x or 1)), \
            field


def test_a_metric_on_channels_that_need_the_frames_takes_the_tangents() -> None:
    file = _paper(t_end=0.6)
    fields = ["links[0].EI", "joints[1].motion[0].to_deg"]
    metric = flexlink.MeanSquare("link1_tip_acceleration")
    objective = flexlink.Objective(file.build(), fields, metric)
    _, gradient = objective(objective.x0)
    assert objective.method == "tangents"
    results = flexlink.simulate(file.build(), sensitivities=fields, shapes=False)
    _, slopes = metric(results)
    expected = slopes["link1_tip_acceleration"] @ results.sensitivities.sel(
        channel="link1_tip_acceleration").values
    np.testing.assert_allclose(gradient, expected, rtol=1e-12)


def test_a_field_the_equations_do_not_read_assembles_nothing() -> None:
    """A sensor's gain moves the channel map only: its stencil reuses the run's system and
    its dA/dp is zero (not a difference of two assemblies); a link field builds its own."""
    file = _paper(t_end=0.3)
    scenario = file.build()
    fields = prepare_fields(file, scenario, ["sensors[pzt].d31", "links[0].EI"])
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    settled = settled_run(scenario, fields, t, lambda _: None, False)
    assert all(s is settled.nominal for s in settled.systems[0])
    assert all(s is not settled.nominal for s in settled.systems[1])
    rows = settled.derivative_rows(t[:5])
    assert not rows[:, 0].any() and rows[:, 1].any()


def test_a_state_part_the_sensors_read_is_differenced() -> None:
    """The seeds skip a part of the state (q̇, q̈) only where the metric leaves it unread:
    a reading of the rates is seen (NaN carried), and the probed copy gets its values
    back."""
    from flexlink.simulation.adjoint import _unread

    t = np.linspace(0.0, 1.0, 5)
    q, qd, qdd = np.ones((5, 2)), np.full((5, 2), 2.0), np.full((5, 2), 3.0)

    def reads_q(scenario: object, system: object, state: State) -> np.ndarray:
        return state.q[:, 0] ** 2

    def reads_rates(scenario: object, system: object, state: State) -> np.ndarray:
        return state.q[:, 0] + 0.0 * state.q_dot[:, 1]

    for part, values in ((1, qd), (2, qdd)):
        arrays = [q, qd, qdd]
        arrays[part] = values.copy()
        assert _unread(reads_q, None, None, t, arrays, part, values)
        assert np.array_equal(arrays[part], values)
    arrays = [q, qd.copy(), qdd]
    assert not _unread(reads_rates, None, None, t, arrays, 1, qd)
    assert np.array_equal(arrays[1], qd)


def test_objective_gradient_from_an_equilibrium_start() -> None:
    """The start z₀(p) moves with the fields: its derivative enters the reverse pass's
    gradient as it enters the tangents."""
    file = _paper(t_end=1.0, initial="equilibrium", gravity=[0.0, -9.81])
    fields = ["links[0].EI", "links[0].tip_mass", "simulation.gravity[1]",
              "links[1].damping_ratio"]
    metric = flexlink.MeanSquare("link2_root_strain")
    objective = flexlink.Objective(file.build(), fields, metric)
    _, gradient = objective(objective.x0)
    assert objective.method == "adjoint"
    results = flexlink.simulate(file.build(), sensitivities=fields, shapes=False)
    _, slopes = metric(results)
    expected = slopes["link2_root_strain"] @ results.sensitivities.sel(
        channel="link2_root_strain").values
    np.testing.assert_allclose(gradient, expected, rtol=1e-8)
