"""The Lawson integrator and its coefficient table against the plain computations they replace."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.motion import Cycloidal, MeasuredMotion, Sequence
from flexlink.simulation import output_times
from flexlink.solvers import GivenMatrices, Solution, integrate_lawson, integrate_magnus
from flexlink.solvers.coefficient_table import tabulate
from flexlink.solvers.lawson import _run, _solve
from flexlink.solvers.magnus import agree, agree_maxima, state_rows
from tests.helpers import chain_of, paper_links


def _system(start2: float = 0.7) -> FirstOrderSystem:
    # Rest, move, rest, second move, rest.
    motions = [Cycloidal(0.0, 60.0, 0.2, 0.3), Cycloidal(20.0, -40.0, start2, 0.2)]
    return FirstOrderSystem(chain_of(paper_links(2), motions), True)


def _table(system: FirstOrderSystem, t: np.ndarray, tolerance: float = 1e-7,
           breaks: bool = False):
    return tabulate(lambda times: state_rows(system.matrices, times), t,
                    system.coefficient_keys, tolerance,
                    breaks=system.breakpoints() if breaks else None)


def _without_breaks(system: FirstOrderSystem) -> GivenMatrices:
    """The same equations with no breakpoints: the table must find the kinks itself."""
    return GivenMatrices(system.matrices, system.n, system.max_frequency,
                         coefficient_keys=system.coefficient_keys)


def _states(solution: Solution) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return solution.q, solution.q_dot, solution.q_ddot


def test_table_is_static_exactly_where_the_joints_rest() -> None:
    system = _system()
    t = output_times(1.2, 0.002)
    table = _table(system, t)
    moves = [(0.2, 0.5), (0.7, 0.9)]
    for a, b, static in zip(table.first, table.last, table.static):
        # Output times are multiples of 0.01 up to rounding: leave them that margin.
        rests = all(t[b] < lo - 1e-9 or t[a] > hi + 1e-9 for lo, hi in moves)
        moving = any(t[a] < hi - 1e-9 and t[b] > lo + 1e-9 for lo, hi in moves)
        assert (static and not moving) or (not static and not rests), (t[a], t[b])
    assert table.static.sum() == 3  # each rest phase is one block
    assert np.all(table.last[:-1] == table.first[1:]) and table.last[-1] == t.size - 1


@pytest.mark.parametrize("breaks", [False, True])
@pytest.mark.parametrize("start2", [0.7, 0.7043])  # a kink on an output time, and between two
def test_table_reproduces_the_assembled_coefficients(start2: float, breaks: bool) -> None:
    system = _system(start2)
    t = output_times(1.2, 0.01)
    tolerance = 1e-7
    table = _table(system, t, tolerance, breaks)
    probe = np.random.default_rng(0).uniform(0.0, 1.2, 400)
    exact = state_rows(system.matrices, probe)
    b = np.searchsorted(t[table.last], probe)  # block of each probe time
    tau = (probe - t[table.first[b]]) / (t[table.last[b]] - t[table.first[b]])
    interpolated = table.evaluate(b, tau)
    spread = exact.max(axis=0) - exact.min(axis=0)
    error = np.abs(interpolated - exact) / (spread + 1e-9 * np.abs(exact).max(axis=0) + 1e-300)
    assert error.max() < 20 * tolerance
    split = np.diff(table.pieces) > 1  # blocks of one output interval cut in pieces
    assert split.any() == (start2 == 0.7043)
    if breaks and start2 == 0.7043:  # cut exactly at the kinks: two pieces, no refinement
        assert np.diff(table.pieces).max() == 2
        b = np.flatnonzero(split)
        cuts = t[table.first[b]] + table.upper[table.pieces[b]] * (t[table.last[b]]
                                                                   - t[table.first[b]])
        assert np.allclose(cuts, [0.7043, 0.9043])


def test_breaks_save_the_refinement_around_kinks() -> None:
    system = _system(0.7043)
    t = output_times(1.2, 0.001)
    assert _table(system, t, 1e-7, breaks=True).assemblies < 0.8 * _table(system, t, 1e-7).assemblies


@pytest.mark.parametrize("breaks", [False, True])
def test_lawson_agrees_with_magnus(breaks: bool) -> None:
    system = _system(0.7043)
    t = np.append(output_times(1.2, 0.005), 1.2037)  # a last, shorter interval
    solved = system if breaks else _without_breaks(system)
    z, zd, zdd = _states(integrate_lawson(solved, t, 1e-8, 1e-14))
    zm, zdm, _ = _states(integrate_magnus(system, t, 1e-10, 1e-14))
    assert np.abs(z - zm).max() < 1e-7 * np.abs(zm).max()
    assert np.abs(zd - zdm).max() < 1e-7 * np.abs(zdm).max()
    # z̈ from the table equals z̈ from the assembled equations at the same state.
    assert np.abs(zdd - system.accelerations(t, z, zd)).max() < 1e-5 * np.abs(zdd).max()


def test_lawson_is_fourth_order() -> None:
    system = FirstOrderSystem(chain_of(paper_links(2), [Cycloidal(0.0, 90.0, 0.1, 1.0),
                                                        Cycloidal(90.0, 170.0, 0.1, 1.0)]), True)
    t = output_times(1.5, 0.02)
    table = _table(system, t, 1e-10)
    runs = [_solve(table, system.n, t, substeps, None)[0] for substeps in (4, 8, 16, 32)]
    changes = [np.abs(fine - coarse).max() for coarse, fine in itertools.pairwise(runs)]
    orders = np.log2(np.array(changes[:-1]) / np.array(changes[1:]))
    assert np.all((orders > 3.5) & (orders < 4.5)), orders


@pytest.mark.parametrize("start2", [0.7, 0.7043])  # with pieces (a kink between outputs)
def test_the_coarse_pass_alongside_is_a_run_of_its_own(start2: float) -> None:
    # The compiled loop advances the Richardson pass with half the steps next to the fine
    # one, reading the fine pass's ΔÃ: both equal separate runs to round-off, an odd number
    # of steps per output interval (the single-step remainder) included.
    system = _system(start2)
    t = np.append(output_times(1.2, 0.005), 1.2037)
    table = _table(system, t, 1e-8)
    for substeps in (2, 6):
        fine, acc, coarse, *_ = _run(table, system.n, t, substeps, None, None, coarse=True)
        alone, alone_acc = _solve(table, system.n, t, substeps, None)
        half, _ = _solve(table, system.n, t, substeps // 2, None)
        scale = np.abs(alone).max(axis=0)
        assert np.all(np.abs(fine - alone) <= 1e-12 * scale)
        assert np.all(np.abs(acc - alone_acc) <= 1e-12 * np.abs(alone_acc).max(axis=0))
        assert np.all(np.abs(coarse - half) <= 1e-12 * scale)
        assert np.abs(coarse - fine).max() > 0.0  # a run of its own, not a copy
    with pytest.raises(ValueError, match="even number of steps, got 3"):
        _run(table, system.n, t, 3, None, None, coarse=True)


def test_the_loops_running_maxima_are_those_of_the_whole_arrays() -> None:
    # The Richardson check reads maxima the compiled loop keeps per state component instead
    # of comparing the whole arrays (magnus.agree): the same numbers, bit for bit, and so
    # the same decision.
    system = _system(0.7043)
    t = np.append(output_times(1.2, 0.005), 1.2037)
    table = _table(system, t, 1e-8)
    states, _, coarse, peak, spread = _run(table, system.n, t, 2, None, None, coarse=True)
    kept, _, none, peak2, spread2 = _run(table, system.n, t, 2, None, None, coarse=True,
                                         keep_coarse=False)
    assert none.shape[0] == 0 and np.array_equal(kept, states)
    assert np.array_equal(peak, np.abs(states).max(axis=0))
    assert np.array_equal(spread, np.abs(states - coarse).max(axis=0))
    assert np.array_equal(peak2, peak) and np.array_equal(spread2, spread)
    n = system.n
    for rtol in (1e-4, 1e-6, 1e-8, 1e-10):
        assert agree_maxima(peak, spread, n, rtol, 1e-12) == agree(
            states[:, :-1], states[:, :-1], coarse[:, :-1], n, rtol, 1e-12)


def test_rough_coefficients_are_integrated_by_magnus() -> None:
    # Measured angles with noise, sampled at 1.7 ms: a spline knot every sample, between the
    # output times; tabulating A(t) would cost more than assembling it where Magnus needs it.
    t_data = np.arange(0.0, 0.6, 0.0017)
    noise = np.random.default_rng(3).normal(0.0, 0.05, t_data.size)
    angle = 30.0 * np.sin(2 * np.pi * t_data / 0.6) ** 2 + noise
    motions = [MeasuredMotion.from_arrays(t_data, angle), Cycloidal(0.0, 0.0, 0.0, 1.0)]
    system = FirstOrderSystem(chain_of(paper_links(2), motions), True)
    t = output_times(0.5, 0.001)
    solution = integrate_lawson(_without_breaks(system), t, 1e-6, 1e-12)
    z, zd, zdd = _states(solution)
    assert solution.method == "magnus"
    zm, zdm, _ = _states(integrate_magnus(system, t, 1e-6, 1e-12))
    assert np.array_equal(z, zm) and np.array_equal(zd, zdm)
    assert np.allclose(zdd, system.accelerations(t, z, zd), rtol=1e-9, atol=1e-9 * np.abs(zdd).max())


@pytest.mark.parametrize("motion", [
    Cycloidal(0.0, 1.0, 0.5123, 0.03),  # a whole move inside one output interval
    Sequence((Cycloidal(0.0, 1.0, 0.5, 0.02), Cycloidal(1.0, 0.0, 0.52, 0.02))),  # and back
])
def test_a_move_inside_one_output_interval_is_integrated(motion) -> None:
    # Regressions: the move there and back left equal joint states at both ends and in the
    # middle of its interval, which was taken for rest (the move was skipped: 100% error); and
    # a block of one interval had no error estimate in the first comparison (6e-4 of peak).
    system = FirstOrderSystem(chain_of(paper_links(2), [motion, Cycloidal(90.0, 90.0, 0.0, 1.0)]),
                              True)
    t = output_times(1.0, 0.1)
    solution = integrate_lawson(system, t, 1e-6, 1e-14)
    z, zd, _ = _states(solution)
    zm, zdm, _ = _states(integrate_magnus(system, t, 1e-8, 1e-14))
    assert solution.method == "lawson" and np.abs(zm).max() > 0
    assert np.abs(z - zm).max() < 2e-5 * np.abs(zm).max()
    assert np.abs(zd - zdm).max() < 2e-5 * np.abs(zdm).max()


def test_a_run_on_a_given_discretisation_repeats_the_adaptive_one_and_varies_smoothly() -> None:
    """integrate_lawson_on with the discretisation of an adaptive run of the same system gives
    that run's states exactly; for a perturbed motion, differences on it are those of one
    smooth map (the same at steps 1e-4 … 1e-6), and converge to the derivative that adaptive
    runs at a tight tolerance give."""
    from flexlink.solvers.coefficient_table import layout as table_layout
    from flexlink.solvers.coefficient_table import tabulate_on
    from flexlink.solvers.lawson import integrate_lawson_discretised, integrate_lawson_on

    def system(delta: float) -> FirstOrderSystem:
        motions = [Cycloidal(0.0, 60.0 + delta, 0.2, 0.3), Cycloidal(20.0, -40.0, 0.7, 0.2)]
        return FirstOrderSystem(chain_of(paper_links(2), motions), True)

    t = output_times(1.0, 0.005)
    adaptive, settled = integrate_lawson_discretised(system(0.0), t, 1e-5, 1e-14)
    assert settled is not None and adaptive.method == "lawson"
    again = integrate_lawson_on(system(0.0), t, settled)
    assert np.array_equal(again.q, adaptive.q) and np.array_equal(again.q_dot, adaptive.q_dot)
    assert again.stats["steps_per_output_interval"] == settled.substeps

    def end(delta: float) -> np.ndarray:
        return integrate_lawson_on(system(delta), t, settled).q[-1]

    def end_tight(delta: float) -> np.ndarray:
        return integrate_lawson(system(delta), t, 1e-10, 1e-16).q[-1]

    slopes = [(end(h) - end(-h)) / (2 * h) for h in (1e-4, 1e-5, 1e-6)]
    scale = np.abs(slopes[0]).max()
    for s in slopes[1:]:
        assert np.abs(s - slopes[0]).max() < 1e-5 * scale  # round-off / h at h = 1e-6
    reference = (end_tight(1e-3) - end_tight(-1e-3)) / 2e-3
    assert np.abs(slopes[0] - reference).max() < 1e-3 * np.abs(reference).max()
    # the layout belongs to its output times
    with pytest.raises(ValueError, match="output times"):
        tabulate_on(lambda times: state_rows(system(0.0).matrices, times), t[:-1],
                    settled.layout)
    # and a table's layout sampled again is that table
    table = _table(system(0.0), t, 1e-5, breaks=True)
    same = tabulate_on(lambda times: state_rows(system(0.0).matrices, times), t,
                       table_layout(table, t.size))
    for name in ("first", "last", "static", "pieces", "lower", "upper", "poly", "reference"):
        assert np.array_equal(getattr(same, name), getattr(table, name)), name
