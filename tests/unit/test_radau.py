"""The compiled Radau IIA integrator (solvers/radau.py) on linear models with exact solutions:
global error against the tolerance, exact steps at input jumps, stiff decay in few steps, a
singular mass matrix (index-1 algebraic equation), and the input table."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from flexlink.solvers._radau_numba import LinearData
from flexlink.solvers.input_table import tabulate
from flexlink.solvers.radau import integrate_radau

OMEGA, ZETA = 2 * np.pi * 5.0, 0.01
A_OSC = np.array([[0.0, 1.0], [-OMEGA**2, -2 * ZETA * OMEGA]])
B_OSC = np.array([[0.0], [1.0]])


def _no_input(t: np.ndarray) -> np.ndarray:
    return np.zeros((t.size, 1))


@pytest.mark.parametrize("rtol", [1e-4, 1e-6, 1e-8])
def test_global_error_follows_the_tolerance(rtol: float) -> None:
    """A lightly damped oscillator over ten periods: the error at the outputs (dense output
    included) is within 2 rtol of the peak and not below a tenth of it: the tolerance means
    the global error (measured 0.76, 0.65, 0.86 rtol; radau.local_tolerances)."""
    t = np.linspace(0.0, 2.0, 201)
    y0 = np.array([1.0, 0.0])
    exact = np.array([expm(A_OSC * ti) @ y0 for ti in t])
    states, stats = integrate_radau(LinearData(A_OSC, B_OSC), (), y0, t, _no_input,
                                    np.zeros(0), rtol, 1e-14, np.array([0, 1]))
    error = (np.abs(states - exact).max(axis=0) / np.abs(exact).max(axis=0)).max()
    assert 0.1 * rtol < error < 2 * rtol
    assert stats["jacobians"] == 1  # linear: Newton converges with the first one


def test_steps_end_on_the_input_jumps() -> None:
    """A bang-bang force on the oscillator (jumps at 0.3 s and 0.71 s, neither an output):
    the solution is exact to the tolerance (measured 1.5e-7 at rtol 1e-8; without the
    breakpoints, 1.3e-5 with twice the steps)."""
    t = np.linspace(0.0, 1.0, 11)
    y0 = np.zeros(2)

    def force(tt: np.ndarray) -> np.ndarray:
        return np.where((tt >= 0.3) & (tt < 0.71), 100.0, 0.0)[:, None]

    aug = np.zeros((3, 3))  # exact: the exponential of [[A, b F], [0, 0]] piece by piece
    aug[:2, :2], aug[:2, 2] = A_OSC, B_OSC[:, 0] * 100.0
    exact = []
    for ti in t:
        y = y0.copy()
        y = expm(A_OSC * min(ti, 0.3)) @ y
        if ti > 0.3:
            y = (expm(aug * (min(ti, 0.71) - 0.3)) @ np.append(y, 1.0))[:2]
        if ti > 0.71:
            y = expm(A_OSC * (ti - 0.71)) @ y
        exact.append(y)
    exact = np.array(exact)
    states, _ = integrate_radau(LinearData(A_OSC, B_OSC), (), y0, t, force,
                                np.array([0.3, 0.71]), 1e-8, 1e-14, np.array([0, 1]))
    error = (np.abs(states - exact).max(axis=0) / np.abs(exact).max(axis=0)).max()
    assert error < 1e-6


def test_a_stiff_mode_costs_no_steps() -> None:
    """A mode at 10⁶ 1/s beside a slow one: L-stable, the step follows the slow mode (an
    explicit method would need ~10⁶ steps)."""
    A = np.diag([-1.0, -1e6])
    t = np.linspace(0.0, 5.0, 6)
    y0 = np.array([1.0, 1.0])
    states, stats = integrate_radau(LinearData(A, np.zeros((2, 1))), (), y0, t, _no_input,
                                    np.zeros(0), 1e-6, 1e-12, np.array([0, 1]))
    assert np.abs(states[:, 0] - np.exp(-t)).max() < 1e-5
    assert np.abs(states[1:, 1]).max() < 1e-12
    assert stats["steps"] < 100


def test_an_algebraic_equation_with_a_singular_mass_matrix() -> None:
    """M y' = f with M = diag(1, 0): y1' = −y1 + y2, 0 = −y2 + sin t (index 1). Exact:
    y2 = sin t, y1 = (sin t − cos t)/2 + e^{−t}/2 from y1(0) = 0."""
    A = np.array([[-1.0, 1.0], [0.0, -1.0]])
    B = np.array([[0.0], [1.0]])
    t = np.linspace(0.0, 6.0, 61)
    states, _ = integrate_radau(LinearData(A, B), (), np.zeros(2), t,
                                lambda tt: np.sin(tt)[:, None], np.zeros(0), 1e-8, 1e-12,
                                np.array([0, 1]), mass=np.diag([1.0, 0.0]))
    np.testing.assert_allclose(states[:, 1], np.sin(t), atol=1e-6)  # cubic dense output
    np.testing.assert_allclose(states[:, 0], 0.5 * (np.sin(t) - np.cos(t) + np.exp(-t)),
                               atol=1e-7)


def test_the_input_table_reproduces_the_inputs_on_each_side_of_a_jump() -> None:
    """Piecewise Chebyshev interpolation between the nodes: within 1e-10 of each column's
    peak, and at a node each segment holds its own side of the jump."""
    from flexlink.solvers._radau_numba import input_row

    def inputs(t: np.ndarray) -> np.ndarray:
        return np.stack([np.sin(7 * t), np.where(t < 1.0, 2.0, -3.0), t**3], axis=1)

    nodes = np.array([0.0, 1.0, 2.5])
    tab = tabulate(inputs, nodes)
    u = np.empty(3)
    held = np.zeros(2, dtype=np.int64)
    for seg, t in [(0, 0.0), (0, 0.37), (0, 1.0), (1, 1.0), (1, 1.9), (1, 2.5)]:
        input_row(tab, np.zeros(1), held, seg, t, u)
        side = inputs(np.array([t - 1e-12 if seg == 0 else t + 1e-12]))[0]
        assert np.abs(u - side).max() < 1e-10 * 16, (seg, t)


def test_the_inputs_integrals_follow_the_table() -> None:
    """`input_table.integrals`: ∫ u dt from the table's start, across pieces and a jump,
    equal to the exact integrals of the inputs (within the table's accuracy)."""
    from flexlink.solvers._radau_numba import input_integral
    from flexlink.solvers.input_table import integrals

    def inputs(t: np.ndarray) -> np.ndarray:
        return np.stack([np.sin(7 * t), np.where(t < 1.0, 2.0, -3.0), t**3], axis=1)

    def exact(t: float) -> np.ndarray:
        return np.array([(1 - np.cos(7 * t)) / 7, 2 * min(t, 1.0) - 3 * max(t - 1.0, 0.0),
                         t**4 / 4])

    nodes = np.array([0.0, 1.0, 2.5])
    tab = tabulate(inputs, nodes)
    assert tab[0].size > 2  # several pieces per segment
    itab = integrals(tab)
    U = np.empty(3)
    for seg, t in [(0, 0.0), (0, 0.37), (0, 1.0), (1, 1.0), (1, 1.9), (1, 2.5)]:
        input_integral(tab, itab, seg, t, U)
        np.testing.assert_allclose(U, exact(t), rtol=0, atol=1e-10)


def test_the_model_is_named_by_its_record_type() -> None:
    """The loop reaches a model's compiled rates by the class of its kernel data: data of no
    known model is refused by name before anything runs."""
    from collections import namedtuple

    from flexlink.solvers._radau_numba import model_functions

    Unknown = namedtuple("Unknown", ["A"])
    with pytest.raises(TypeError, match="Unknown"):
        model_functions(Unknown(np.eye(2)), ())
    rates, project, context = model_functions(LinearData(A_OSC, B_OSC), ())
    assert rates > 0 and context[0] > 0  # the trampoline's and the model's compiled code
    assert project == 0 and context[1] == 0  # the linear test model has no invariants


def test_rates_at_any_memory_layout() -> None:
    """rates_at evaluates f row by row whatever the layout of its arrays (the compiled loop
    takes contiguous rows): a Fortran-ordered output and transposed states give A y + B u."""
    from flexlink.solvers._radau_numba import rates_at

    states = np.asfortranarray(np.arange(10.0).reshape(5, 2))
    u = np.linspace(-1.0, 1.0, 5)[:, None]
    out = np.asfortranarray(np.zeros((5, 2)))
    rates_at(LinearData(A_OSC, B_OSC), (), u, states, out)
    assert np.allclose(out, states @ A_OSC.T + u @ B_OSC.T, rtol=1e-14, atol=0.0)


def test_recent_errors_end_the_rejections_of_a_ringing_mode() -> None:
    """Two undamped modes in one error group, the fast one (300 rad/s) a thousandth of the
    slow one's amplitude: its error estimate swings with its phase from step to step, and a
    step sized from a small error alone was rejected a step or two later (a quarter of the
    steps). Sized from the largest of the last three errors (``recent``, the closed loops'
    runs): no rejections, fewer attempts and factorisations, and a smaller error."""
    w1, w2 = 2 * np.pi * 5.0, 300.0
    A = np.zeros((4, 4))
    A[0, 2] = A[1, 3] = 1.0
    A[2, 0], A[3, 1] = -w1**2, -w2**2
    y0 = np.array([1.0, 1e-3, 0.0, 0.0])
    t = np.linspace(0.0, 1.0, 501)
    exact = np.array([expm(A * ti) @ y0 for ti in t])

    def run(recent: bool) -> tuple[float, dict[str, int]]:
        states, stats = integrate_radau(LinearData(A, np.zeros((4, 1))), (), y0, t, _no_input,
                                        np.zeros(0), 1e-4, 1e-14, np.array([0, 0, 1, 1]),
                                        recent=recent)
        return float((np.abs(states - exact).max(axis=0)
                      / np.abs(exact).max(axis=0)).max()), stats

    (plain_error, plain), (error, stats) = run(False), run(True)
    assert plain["rejected_steps"] > 0.15 * plain["steps"]  # the swing this is about
    assert stats["rejected_steps"] <= 0.02 * stats["steps"]
    assert (stats["steps"] + stats["rejected_steps"]
            < plain["steps"] + plain["rejected_steps"])
    assert stats["factorisations"] < plain["factorisations"]
    assert error <= plain_error


@pytest.mark.parametrize("c", [3.7, 2.1 + 1.3j])
def test_the_second_order_solve_is_the_whole_systems(c: complex) -> None:
    """Positions 0, 3 whose rates are the components 1, 4 (J's rows [0 I]) and one other
    component (2): the iteration matrix reduced to the velocity and other rows solves
    (c I − J) x = b as the whole system does, real and complex."""
    from flexlink.solvers._radau_numba import _lu, _reduced_matrix, _solve
    from flexlink.solvers.radau import second_order_reduction

    rng = np.random.default_rng(3)
    J = rng.standard_normal((5, 5))
    J[[0, 3]] = 0.0
    J[0, 1] = J[3, 4] = 1.0
    b = rng.standard_normal(5) + (1j * rng.standard_normal(5) if isinstance(c, complex) else 0)
    reduced = second_order_reduction(np.array([[0, 3], [1, 4]]), 5)
    assert [list(a) for a in reduced] == [[1, 4, 2], [0, 3, 2], [1, 4, -1]]
    E = np.empty((3, 3), dtype=b.dtype)
    piv = np.empty(3, dtype=np.int64)
    _reduced_matrix(J, c, reduced, E)
    assert _lu(E, piv)
    x = b.copy()
    _solve(E, piv, J, c, reduced, x, np.empty(3, dtype=b.dtype))
    np.testing.assert_allclose(x, np.linalg.solve(c * np.eye(5) - J, b), rtol=1e-12)


def test_the_second_order_run_is_the_whole_one() -> None:
    """The oscillator with its position's rate named (f[0] = y[1]): the same steps and
    states to round-off as with the whole iteration matrices; pairs that are not a
    position and a velocity each are refused."""
    t = np.linspace(0.0, 2.0, 201)
    args = (LinearData(A_OSC, B_OSC), (), np.array([1.0, 0.0]), t, _no_input, np.zeros(0),
            1e-6, 1e-14, np.array([0, 1]))
    whole, whole_stats = integrate_radau(*args)
    halved, halved_stats = integrate_radau(*args, second_order=np.array([[0], [1]]))
    assert halved_stats == whole_stats
    peak = np.abs(whole).max(axis=0)
    assert np.all(np.abs(halved - whole).max(axis=0) <= 1e-12 * peak)  # measured 3e-13
    with pytest.raises(ValueError, match="second_order"):
        integrate_radau(*args, second_order=np.array([[0], [0]]))
