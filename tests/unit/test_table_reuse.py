"""Coefficient tables reuse what they already assembled, without changing a number: the
refinement's halves reuse their parent's samples at equal times, and a run's sensitivities
reuse the table its adaptive run settled on (solvers/coefficient_table.py,
solvers/lawson_sensitivity.py)."""

from __future__ import annotations

import itertools
import threading

import numpy as np
import pytest

import flexlink
from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.motion import Cycloidal
from flexlink.scenario.fields import ScenarioFile
from flexlink.simulation import output_times
from flexlink.simulation.prescribed import prescribed_system
from flexlink.simulation.sensitivities import prepare_fields, scenario_file, settled_run
from flexlink.solvers.coefficient_table import CoefficientTable, layout, tabulate, tabulate_on
from flexlink.solvers.lawson import _solve, _trail, integrate_lawson_discretised
from flexlink.solvers.lawson_adjoint import lawson_gradient
from flexlink.solvers.lawson_sensitivity import lawson_sensitivities, steps_on
from flexlink.solvers.magnus import state_rows
from tests.helpers import chain_of, paper_links

FIELDS = ("first", "last", "static", "pieces", "lower", "upper", "poly", "reference")


def _same(a: CoefficientTable, b: CoefficientTable) -> bool:
    return all(np.array_equal(getattr(a, f), getattr(b, f)) for f in FIELDS)


@pytest.mark.parametrize(("start2", "breaks"), [(0.7, False), (0.7043, True)])
def test_refinement_assembles_no_instant_of_the_level_before_again(start2: float,
                                                                   breaks: bool) -> None:
    system = FirstOrderSystem(chain_of(paper_links(2), [
        Cycloidal(0.0, 60.0, 0.2, 0.3), Cycloidal(20.0, -40.0, start2, 0.2)]), True)
    t = output_times(1.2, 0.002)
    calls: list[np.ndarray] = []

    def rows(times: np.ndarray) -> np.ndarray:
        calls.append(times.copy())
        return state_rows(system.matrices, times)

    table = tabulate(rows, t, system.coefficient_keys, 1e-7,
                     breaks=system.breakpoints() if breaks else None)
    assert len(calls) > 2  # refined
    for before, now in itertools.pairwise(calls):
        assert np.intersect1d(before, now).size == 0
    # the halves did share samples with their parents: fewer assembled than asked for
    assert sum(c.size for c in calls) < table.assemblies
    # and every polynomial is the one its own nodes give (one call, nothing reused)
    assert _same(table, tabulate_on(lambda times: state_rows(system.matrices, times), t,
                                    layout(table, t.size)))


def test_a_table_without_moving_references_keeps_every_other_number() -> None:
    """A table of dA/dp leaves the moving blocks' references zero (its steps read the
    static blocks' only); its polynomials and the static blocks' references are the full
    table's to the bit."""
    system = FirstOrderSystem(chain_of(paper_links(2), [
        Cycloidal(0.0, 60.0, 0.2, 0.3), Cycloidal(20.0, -40.0, 0.7, 0.2)]), True)
    t = output_times(1.2, 0.002)
    full = tabulate(lambda times: state_rows(system.matrices, times), t,
                    system.coefficient_keys, 1e-7, breaks=system.breakpoints())
    assert full.static.any() and not full.static.all()
    lean = tabulate_on(lambda times: state_rows(system.matrices, times), t,
                       layout(full, t.size), moving_references=False)
    for name in FIELDS[:-1]:
        assert np.array_equal(getattr(lean, name), getattr(full, name)), name
    assert np.array_equal(lean.reference[full.static], full.reference[full.static])
    assert not lean.reference[~full.static].any()


def test_sensitivities_take_the_settled_table_and_the_same_numbers() -> None:
    file = scenario_file(flexlink.load_paper_experiment())
    raw = dict(file.raw)
    raw["simulation"] = {**raw["simulation"], "t_end": 1.5}
    file = ScenarioFile(raw, file.base_dir, file.name, file.source)
    scenario = file.build()
    fields = prepare_fields(file, scenario, ["links[0].EI", "links[1].damping_ratio",
                                             "sensors[pzt].d31"])
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    settled = settled_run(scenario, fields, t, lambda _: None, False, keep_steps=True)
    disc = settled.discretisation
    assert disc.table is not None
    # a discretisation that others get (the optimiser's workers) does not carry the table
    _, plain = integrate_lawson_discretised(settled.nominal, t, scenario.settings.rtol,
                                            scenario.settings.atol)
    assert plain is not None and plain.table is None and plain.layout == disc.layout
    kept = steps_on(settled.nominal, t, disc, settled_system=True)
    anew = steps_on(settled.nominal, t, disc)
    assert kept[0] is disc.table and _same(kept[0], anew[0])
    for a, b in zip(kept[1:], anew[1:], strict=True):
        assert np.array_equal(a, b)
    rows = settled.derivative_rows
    with_kept = lawson_sensitivities(settled.nominal, rows, t, disc, settled_system=True)
    with_new = lawson_sensitivities(settled.nominal, rows, t, disc)
    for a, b in zip(with_kept[1:], with_new[1:], strict=True):
        assert np.array_equal(a, b)
    np.testing.assert_array_equal(with_kept[0].q, with_new[0].q)
    # and the reverse pass's gradient, from the kept table or a new one
    seeds = np.random.default_rng(3).standard_normal((3, t.size, settled.nominal.n))
    kept_gradient = lawson_gradient(settled.nominal, rows, t, disc, *seeds, settled_system=True)
    new_gradient = lawson_gradient(settled.nominal, rows, t, disc, *seeds)
    # the kept one reads the run's own steps, the same steps as the pass's forward ones but
    # summed in another order (the run's loop pairs them with its coarse steps)
    assert disc.steps is not None and kept_gradient[1] is disc.steps.states
    np.testing.assert_allclose(kept_gradient[1], new_gradient[1], rtol=0, atol=1e-15)
    np.testing.assert_allclose(kept_gradient[0], new_gradient[0], rtol=1e-11)


@pytest.mark.parametrize(("halved", "rtol"), [(False, None), (True, None), (False, 1e-9)])
def test_the_run_keeps_its_steps_for_the_reverse_pass(halved: bool, rtol: float | None,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """Asked to, the settled run keeps its states and every fine step's start on the
    moving blocks, in order, the fine steps of its accepted pass (``halved``: the first pass
    refused, its steps halved once; ``rtol`` 1e-9: ten steps per output interval, pairs
    of them started inside one); else none."""
    from flexlink.solvers import lawson

    if halved:
        monkeypatch.setattr(lawson, "agree_maxima", lambda *args: False)
    scenario = flexlink.load_paper_experiment()
    t = output_times(1.5, scenario.settings.dt_out)
    system = prescribed_system(scenario, t)
    rtol = rtol or scenario.settings.rtol
    solution, disc = integrate_lawson_discretised(system, t, rtol, scenario.settings.atol,
                                                  keep_table=True, keep_steps=True)
    assert disc is not None and disc.steps is not None and disc.table is not None
    states, starts = disc.steps.states, disc.steps.starts
    np.testing.assert_array_equal(states[:, :system.n], solution.q)
    table, k = disc.table, disc.substeps
    first = lawson.prepare(system, t, rtol, scenario.settings.atol).substeps
    assert k == (2 * first if halved else first)
    assert k > 2 or rtol > 1e-9  # the tight run's pairs start inside an interval too
    moving = np.flatnonzero(~table.static)
    intervals = np.concatenate([np.arange(table.first[b], table.last[b]) for b in moving])
    # an output interval's first step starts from the state there: not kept again
    assert starts.shape == (intervals.size * (k - 1), states.shape[1])
    # the fine pass alone (the loop without its coarse steps) takes the same steps
    alone = _trail(table, system.n, k)
    _solve(table, system.n, t, k, None, disc.propagators, alone)
    np.testing.assert_allclose(starts, alone, rtol=0, atol=1e-14 * np.abs(alone).max())
    for keep_table in (False, True):  # unless asked for
        _, plain = integrate_lawson_discretised(system, t, rtol, scenario.settings.atol,
                                                keep_table=keep_table)
        assert plain is not None and plain.steps is None


def test_state_rows_on_two_threads_are_the_same_numbers(monkeypatch: pytest.MonkeyPatch
                                                        ) -> None:
    """`split_state_rows` (the fit command's process): a large request computed in two
    halves on two threads gives the rows of one thread, bit for bit; off by default."""
    from flexlink.dynamics import prescribed_kernel
    from flexlink.dynamics.prescribed_kernel import CompiledFirstOrderSystem

    assert not prescribed_kernel._second_thread  # a library user's process: one thread
    system = CompiledFirstOrderSystem(chain_of(paper_links(2), [
        Cycloidal(0.0, 60.0, 0.2, 0.3), Cycloidal(20.0, -40.0, 0.7, 0.2)]), True)
    times = np.linspace(0.21, 0.49, 2 * prescribed_kernel._SPLIT_ROWS + 1)  # all moving
    alone = system.state_rows(times)
    monkeypatch.setattr(prescribed_kernel, "_second_thread", [])
    monkeypatch.setattr(prescribed_kernel.os, "cpu_count", lambda: 2)
    prescribed_kernel.split_state_rows()
    executor = prescribed_kernel._second_thread[0]
    calls: list[int] = []
    submit = executor.submit

    def counted(fn: object, *args: np.ndarray) -> object:
        calls.append(args[-1].shape[0])
        return submit(fn, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(executor, "submit", counted)
    split = system.state_rows(times)
    # the command ends it: a process whose other threads ended exits without teardown
    prescribed_kernel.end_split_state_rows()
    assert not prescribed_kernel._second_thread
    assert not any(t.name.startswith("flexlink-state-rows") for t in threading.enumerate())
    assert calls == [times.size - times.size // 2]
    assert np.array_equal(split, alone)
