"""What the reverse pass reads of ∂A/∂p: the samples' weights of a table's monomial weights
(`coefficient_table.sample_weights`, the transpose of `tabulate_on`), their pairing with
∂A/∂p (`SettledRun.derivative_pairing`), and ∂A/∂p of a field that moves the links'
stiffness and damping matrices alone, −M⁻¹[∂K, ∂D, 0] (`prescribed_kernel.mass_inverse`,
`stiffness_alone`)."""

from __future__ import annotations

import numpy as np
import pytest

import flexlink
from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.dynamics.prescribed_kernel import mass_inverse, state_rows, stiffness_alone
from flexlink.scenario.fields import ScenarioFile
from flexlink.simulation.common import output_times
from flexlink.simulation.sensitivities import prepare_fields, scenario_file, settled_run
from flexlink.solvers.coefficient_table import sample_weights, tabulate_on

FIELDS = ["links[0].EI", "links[1].mass_per_length", "links[1].damping_ratio",
          "sensors[pzt].d31", "joints[1].motion[0].to_deg", "links[0].damping_ratio"]
STIFFNESS_ALONE = [True, False, True, False, False, True]


def _paper(t_end: float = 2.0, **settings: object) -> ScenarioFile:
    file = scenario_file(flexlink.load_paper_experiment())
    raw = dict(file.raw)
    raw["simulation"] = {**raw["simulation"], "t_end": t_end, **settings}
    return ScenarioFile(raw, file.base_dir, file.name, file.source)


def _settled(file: ScenarioFile, fields: list[str]):  # type: ignore[no-untyped-def]
    scenario = file.build()
    prepared = prepare_fields(file, scenario, fields)
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    return settled_run(scenario, prepared, t, lambda _: None, False), prepared, t


def _stencil_rows(settled, prepared, times: np.ndarray) -> np.ndarray:  # type: ignore[no-untyped-def]
    """∂A/∂p by the fields' stencils of assembled rows (what every field had)."""
    out = np.zeros((times.size, len(prepared), settled.nominal.n, 2 * settled.nominal.n + 1))
    for k, (f, moved) in enumerate(zip(prepared, settled.systems, strict=True)):
        for w, s in zip(f.weights, moved, strict=True):
            out[:, k] += (w / f.step) * s.state_rows(times)
    return out


def test_the_samples_weights_pair_as_the_tables_monomials() -> None:
    """For any samples S at the instants `tabulate_on` reads on a run's layout (moving
    pieces and static blocks), Σ ⟨poly, weights⟩ of the table it builds = Σ ⟨S_i, W_i⟩."""
    settled, _, t = _settled(_paper(), FIELDS[:1])
    table = settled.discretisation.table
    assert table.static.any() and not table.static.all()
    rng = np.random.default_rng(3)
    weights = rng.standard_normal(table.poly.shape)
    values: dict[float, np.ndarray] = {}

    def rows(times: np.ndarray) -> np.ndarray:
        out = rng.standard_normal((times.size, 2, 3))
        for i, time in enumerate(times):  # one sample per instant, however often asked
            out[i] = values.setdefault(float(time), out[i])
        return out

    made = tabulate_on(rows, t, settled.discretisation.layout, moving_references=False)
    times, paired = sample_weights(table, t, weights[..., :2, :3])
    assert np.all(np.diff(times) > 0)  # each instant once
    assert set(times.tolist()) == set(values)
    expected = np.einsum("pdij,pdij->", made.poly, weights[..., :2, :3])
    got = sum(np.vdot(values[float(time)], w) for time, w in zip(times, paired, strict=True))
    assert got == pytest.approx(expected, rel=1e-12)


def test_the_run_keeps_the_rows_its_table_sampled() -> None:
    """The nominal system keeps the rows its run's table sampled: at the instants the
    pairing reads (the table's samples) they are there, equal to the rows computed anew;
    an instant never computed is not, and a caller changing rows it was given changes
    nothing kept."""
    settled, _, t = _settled(_paper(), FIELDS[:1])
    nominal, table = settled.nominal, settled.discretisation.table
    times, _ = sample_weights(table, t, np.zeros(table.poly.shape))
    kept = nominal.kept_rows(times)
    assert kept is not None
    np.testing.assert_array_equal(kept, nominal.state_rows(times))
    assert nominal.kept_rows(np.append(times, times[1] + 1e-7)) is None
    kept[:] = np.nan
    np.testing.assert_array_equal(nominal.kept_rows(times), nominal.state_rows(times))


def test_the_mass_matrix_inverse_from_the_rows() -> None:
    """mass_inverse equals the inverse of the numpy model's M (gravity, stiffening on)."""
    scenario = _paper(gravity=[0.0, -9.81], geometric_stiffening=True).build()
    system = FirstOrderSystem(scenario.chain, True, (), scenario.settings.gravity)
    times = np.linspace(0.0, 1.2, 7)
    M = system.matrices(times)[0]
    inverse = mass_inverse(system, times, state_rows(system, times))
    np.testing.assert_allclose(inverse, np.linalg.inv(M), rtol=0,
                               atol=1e-12 * np.abs(np.linalg.inv(M)).max())


def test_stiffness_fields_take_minus_inverse_mass_times_their_matrices() -> None:
    """EI and damping ratios (and only they) move the links' stiffness and damping
    matrices alone; their ∂A/∂p = −M⁻¹[∂K, ∂D, 0] equals their stencil's assembled rows to
    the stencil's round-off, the other fields' rows are the stencil's; the pairing is the
    rows' pairing."""
    settled, prepared, _ = _settled(_paper(), FIELDS)
    nominal = settled.nominal
    alone = [all(s is nominal or stiffness_alone(nominal, s) for s in moved)
             and any(s is not nominal for s in moved) for moved in settled.systems]
    assert alone == STIFFNESS_ALONE
    times = np.linspace(0.0, 2.0, 23)
    got, expected = settled.derivative_rows(times), _stencil_rows(settled, prepared, times)
    for k, field in enumerate(FIELDS):
        scale = np.abs(expected[:, k]).max()
        np.testing.assert_allclose(got[:, k], expected[:, k], rtol=0,
                                   atol=1e-9 * scale if STIFFNESS_ALONE[k] else 0.0,
                                   err_msg=field)
    weights = np.random.default_rng(5).standard_normal(got[:, 0].shape)
    np.testing.assert_allclose(settled.derivative_pairing(times, weights),
                               np.einsum("tkij,tij->k", got, weights), rtol=1e-12)


def test_a_start_offset_takes_the_stencils_rows() -> None:
    """From equilibrium under gravity (a start offset z_start, which the rows carry and
    which moves with EI) no field takes the M⁻¹ shortcut."""
    settled, prepared, _ = _settled(_paper(0.5, initial="equilibrium",
                                           gravity=[0.0, -9.81]), FIELDS[:1])
    assert not stiffness_alone(settled.nominal, settled.systems[0][0])
    times = np.linspace(0.0, 0.5, 5)
    np.testing.assert_array_equal(settled.derivative_rows(times),
                                  _stencil_rows(settled, prepared, times))


def test_the_seeds_skip_a_link_no_sensor_reads_and_a_part_read_as_a_nan_view() -> None:
    """`_unread` of some columns: NaN in those columns, given back after; of a whole part:
    a NaN view, the arrays untouched."""
    from flexlink.simulation.adjoint import _unread
    from flexlink.simulation.channel_subset import State

    t = np.linspace(0.0, 1.0, 5)
    q, qd, qdd = np.arange(15.0).reshape(5, 3), np.ones((5, 3)), np.ones((5, 3))

    def reads_first(scenario: object, system: object, state: State) -> np.ndarray:
        return state.q[:, 0] ** 2 + state.q_dot[:, 0]

    arrays = [q.copy(), qd, qdd]
    assert _unread(reads_first, None, None, t, arrays, 0, q, slice(1, 3))
    assert not _unread(reads_first, None, None, t, arrays, 0, q, slice(0, 1))
    assert np.array_equal(arrays[0], q)
    assert not _unread(reads_first, None, None, t, arrays, 1, qd)
    assert _unread(reads_first, None, None, t, arrays, 2, qdd)
    assert np.array_equal(arrays[1], qd) and np.array_equal(arrays[2], qdd)


def test_the_direct_term_is_left_out_only_where_the_readings_stay_the_nominal_ones() -> None:
    """The readings of the metric's sensors stay the nominal ones, bit for bit, under a
    joint's motion, a link's EI or damping ratio (the same mode shapes) and another
    sensor's gain: their direct term, zero, is not evaluated; a link's mass or the
    sensor's own gain moves them."""
    from flexlink.simulation.adjoint import _same_readings
    from flexlink.simulation.channel_subset import State, channel_values

    settled, prepared, t = _settled(_paper(0.5), FIELDS)
    rng = np.random.default_rng(7)
    n = settled.nominal.n
    state = State(t, *(rng.standard_normal((t.size, n)) for _ in range(3)))
    for names, moving in ((["link2_tip_deflection"], ("links[1].mass_per_length",)),
                          (["pzt"], ("links[1].mass_per_length", "sensors[pzt].d31"))):
        nominal = channel_values(settled.scenario, settled.nominal, state, names)[0]
        for f, moved, field in zip(prepared, settled.systems, FIELDS, strict=True):
            same = [_same_readings(sc, system, settled.scenario, settled.nominal, names)
                    for sc, system in zip(f.scenarios, moved, strict=True)]
            assert all(same) == (field not in moving), (names, field)
            for sc, system, kept in zip(f.scenarios, moved, same, strict=True):
                if kept:
                    values = channel_values(sc, system, state, names)[0]
                    for name in names:
                        np.testing.assert_array_equal(values[name], nominal[name])


def test_the_seeds_are_the_sensors_rows_where_those_give_the_readings() -> None:
    """Sensors on the modes read fixed rows of the state: the seeds from those rows equal
    central differences of the weighted readings along the state's coordinates (zero on
    the rates); readings the rows do not give (an offset) leave the seeds to the
    differences."""
    from flexlink.simulation.adjoint import _seeds_by_rows
    from flexlink.simulation.channel_subset import State, channel_values

    settled, _, t = _settled(_paper(0.5), FIELDS[:1])
    solution = settled.run.solution
    arrays = [solution.q, solution.q_dot, solution.q_ddot]
    names = ["link2_tip_deflection", "pzt", "link2_root_strain"]
    readings = channel_values(settled.scenario, settled.nominal, solution, names)[0]
    rng = np.random.default_rng(11)
    weights = {name: rng.standard_normal(t.size) for name in names}
    seeds = _seeds_by_rows(settled.scenario, settled.nominal, t, arrays, readings, weights)
    assert seeds is not None

    def weighted(state: State) -> np.ndarray:
        values = channel_values(settled.scenario, settled.nominal, state, names)[0]
        return sum(weights[name] * values[name] for name in names)  # type: ignore[return-value]

    for part, j in [(0, 0), (0, 5), (0, 7), (1, 6), (2, 7)]:
        moved = []
        for sign in (1.0, -1.0):
            shifted = [a.copy() for a in arrays]
            shifted[part][:, j] += sign
            moved.append(weighted(State(t, *shifted)))
        expected = (moved[0] - moved[1]) / 2.0
        np.testing.assert_allclose(seeds[part][:, j], expected, rtol=0,
                                   atol=1e-12 * max(np.abs(expected).max(), 1e-300))
    assert not np.any(seeds[1]) and not np.any(seeds[2])
    offset = {name: values + 1e-3 for name, values in readings.items()}
    assert _seeds_by_rows(settled.scenario, settled.nominal, t, arrays, offset, weights) is None


def test_the_stencils_share_the_joints_their_field_leaves_alone() -> None:
    """Built with the scenario in one reusing_tables, a link field's moved scenarios hold
    the scenario's joints (their motions' breaks need no second look); a joint's motion
    field's do not, and a field moving a motion's start is still refused."""
    from flexlink.scenario.load import reusing_tables
    from flexlink.simulation.sensitivities import SensitivityError, _same_motions

    file = _paper()
    with reusing_tables():
        scenario = file.build()
        link, joint = prepare_fields(file, scenario, ["links[0].EI", "joints[1].motion[0].to_deg"])
        assert all(_same_motions(s, scenario) for s in link.scenarios)
        assert not any(_same_motions(s, scenario) for s in joint.scenarios)
        with pytest.raises(SensitivityError, match="acceleration jumps"):
            prepare_fields(file, scenario, ["joints[0].motion[0].start"])
