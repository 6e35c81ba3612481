"""Properties of the assembled first-order equations."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.model import Link
from tests.helpers import CubicMotion, chain_of

LINKS = (
    Link("a", 1.0, 0.6, 120.0, tip_mass=0.2, tip_inertia=0.002, modes=3),
    Link("b", 0.8, 0.3, 30.0, tip_mass=0.05, modes=3),
    Link("c", 0.5, 0.1, 5.0, modes=2),
)

angles = st.floats(-3.0, 3.0)


@settings(max_examples=30, deadline=None)
@given(st.lists(st.tuples(angles, angles, angles), min_size=3, max_size=3), st.booleans())
def test_mass_matrix_symmetric_positive_definite(coeffs, stiffening) -> None:
    motions = [CubicMotion(a, b, c) for a, b, c in coeffs]
    system = FirstOrderSystem(chain_of(LINKS, motions), stiffening)
    M = system.matrices(np.array([0.4]))[0][0]
    np.testing.assert_allclose(M, M.T, atol=1e-12 * np.abs(M).max())
    assert np.linalg.eigvalsh(M).min() > 0


@settings(max_examples=20, deadline=None)
@given(st.lists(st.tuples(angles, angles, angles), min_size=3, max_size=3))
def test_gyroscopic_part_is_skew(coeffs) -> None:
    """C − Ṁ − D is skew-symmetric: the Coriolis forces do no work."""
    motions = [CubicMotion(a, b, c) for a, b, c in coeffs]
    system = FirstOrderSystem(chain_of(LINKS, motions))
    h = 1e-6
    M_p, M_m = (system.matrices(np.array([0.4 + s]))[0][0] for s in (h, -h))
    C = system.matrices(np.array([0.4]))[1][0]
    for body in system.bodies:
        C[body.slice, body.slice] -= body.data.damping_matrix
    G = C - (M_p - M_m) / (2 * h)
    # finite-difference noise of Ṁ is ~1e-9 of M; a wrong term would be of the order of C
    np.testing.assert_allclose(G, -G.T, atol=1e-6 * np.abs(C).max() + 1e-8 * np.abs(M_p).max())


def test_single_link_on_hub_is_paper_eq_27() -> None:
    """M_b q̈ + (K_b − β̇² M_b) q = −Φ̃ᵀ β̈ (tip mass in M_b and Φ̃, MODEL_NOTES)."""
    link = Link("a", 1.3, 0.5, 200.0, tip_mass=0.1, modes=4)
    system = FirstOrderSystem(chain_of([link], [CubicMotion(0.2, 1.5, 2.0)]))
    t = np.array([0.3])
    rate, acc = 1.5 + 4.0 * 0.3, 4.0
    M, _C, K, f = (a[0] for a in system.matrices(t))
    d = system.modal[0]
    np.testing.assert_allclose(M, d.mass_matrix, rtol=1e-13)
    np.testing.assert_allclose(K, d.stiffness_matrix - rate**2 * d.mass_matrix, rtol=1e-12)
    np.testing.assert_allclose(f, -d.phi_tilde * acc, rtol=1e-13)


def test_no_motion_no_load() -> None:
    system = FirstOrderSystem(chain_of(LINKS, [CubicMotion(0.3), CubicMotion(-1.0), CubicMotion(2.0)]))
    _M, _C, K, f = system.matrices(np.linspace(0, 1, 5))
    assert np.all(f == 0.0)
    for body in system.bodies:
        np.testing.assert_array_equal(K[:, body.slice, body.slice][0], body.data.stiffness_matrix)


def test_joint_histories_are_shared_read_only_and_equal_to_a_fresh_evaluation() -> None:
    from flexlink.dynamics import kinematics
    from flexlink.motion import Cycloidal, Hold

    joints = (Cycloidal(0.0, 90.0, 0.5, 1.0), Hold(30.0))
    t = np.linspace(0.0, 2.0, 2001)
    first = kinematics.joint_history(joints, t)
    again = kinematics.joint_history((Cycloidal(0.0, 90.0, 0.5, 1.0), Hold(30.0)), t.copy())
    assert again is first  # equal motions on equal times: one evaluation per process
    assert not first.angle.flags.writeable
    with pytest.raises(ValueError):
        first.rate[0, 0] = 1.0
    for j, joint in enumerate(joints):
        for values, expected in zip((first.angle, first.rate, first.acceleration),
                                    joint.evaluate(t)):
            np.testing.assert_array_equal(values[:, j], expected)
    other = kinematics.joint_history(joints, t + 0.1)  # other times: evaluated anew
    np.testing.assert_array_equal(other.angle[:, 0], joints[0].evaluate(t + 0.1)[0])
    unique, index = first.distinct
    np.testing.assert_array_equal(unique.angle[index], first.angle)
    assert unique.angle.shape[0] < t.size  # the rest phases collapse to one state each


def test_a_systems_first_time_grid_outlives_the_grids_asked_for_after_it(monkeypatch) -> None:
    """A run asks for its output times first and again for its channels, after its table
    sampled other grids: those first times are evaluated once (not again after three others)."""
    from flexlink.dynamics import first_order

    calls: list[int] = []
    evaluate = first_order.joint_history

    def counted(joints, t, even=None):
        calls.append(np.size(t))
        return evaluate(joints, t, even)

    monkeypatch.setattr(first_order, "joint_history", counted)
    system = FirstOrderSystem(chain_of(LINKS, [CubicMotion(0.3), CubicMotion(-1.0),
                                                CubicMotion(2.0)]))
    t = np.linspace(0.0, 1.0, 11)
    first = system.joint_history(t)
    for size in (3, 4, 5, 6):  # more grids than the recent ones kept
        system.joint_history(np.linspace(0.0, 1.0, size))
    assert system.joint_history(t.copy()) is first
    assert calls == [11, 3, 4, 5, 6]
    system.joint_history(np.linspace(0.0, 1.0, 3))  # beyond the last three: evaluated anew
    assert calls == [11, 3, 4, 5, 6, 3]


def test_distinct_joint_states_are_the_runs_of_equal_rows() -> None:
    """JointHistory.distinct: a new run wherever any angle, rate or acceleration differs
    from the previous time's (one differing entry of one joint is enough), revisits
    included; compared with the rows joined and compared whole."""
    from flexlink.dynamics.kinematics import JointHistory

    rng = np.random.default_rng(5)
    states = rng.normal(size=(6, 3, 2))
    states[4] = states[1]  # a state revisited after another one: a new run
    states[5] = states[4]
    states[5, 2, 1] += 1e-15  # one acceleration of one joint, in the last bits
    which = np.repeat(np.arange(6), [3, 1, 4, 2, 5, 2])
    angle, rate, acc = (np.ascontiguousarray(states[which, i]) for i in range(3))
    unique, index = JointHistory(angle, rate, acc).distinct
    rows = np.concatenate([angle, rate, acc], axis=1)
    new = np.concatenate([[True], np.any(rows[1:] != rows[:-1], axis=1)])
    np.testing.assert_array_equal(index, np.cumsum(new) - 1)
    np.testing.assert_array_equal(unique.angle, angle[new])
    np.testing.assert_array_equal(unique.acceleration, acc[new])
    assert unique.angle.shape[0] == 6


def test_long_joint_histories_are_not_kept_beyond_their_run(monkeypatch) -> None:
    from flexlink.dynamics import kinematics
    from flexlink.motion import Cycloidal

    monkeypatch.setattr(kinematics, "_HISTORY_BYTES_KEPT", 100_000)
    joints = (Cycloidal(0.0, 45.0, 0.1, 0.5),)
    short = kinematics.joint_history(joints, np.linspace(0.0, 1.0, 101))  # 2.4 kB
    long = kinematics.joint_history(joints, np.linspace(0.0, 1.0, 10_001))  # 240 kB
    assert kinematics.joint_history(joints, np.linspace(0.0, 1.0, 101)) is short
    assert kinematics.joint_history(joints, np.linspace(0.0, 1.0, 10_001)) is not long
    assert sum(h.angle.base.nbytes for h in kinematics._HISTORIES.values()) <= 100_000
