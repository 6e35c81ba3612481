"""The compiled pieces of the prescribed-joint path (dynamics/prescribed_kernel.py,
dynamics/_prescribed_numba.py) against the numpy FirstOrderSystem, the reference: the same
state rows, frames and channel inputs to round-off."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.dynamics.forward_kernel import pack
from flexlink.dynamics.prescribed_kernel import (
    forward_data,
    forward_view,
    solved_frames,
    state_rows,
)
from flexlink.dynamics.prescribed_kernel import joint_torques as compiled_torques
from flexlink.dynamics.torques import joint_torques
from flexlink.model import Body, Chain, Link
from flexlink.solvers.magnus import state_rows as numpy_state_rows
from tests.helpers import CubicMotion, paper_links


def _three_links(stiffening: bool, shapes: str = "clamped_free") -> FirstOrderSystem:
    """Three links of different mode counts (one rigid), a tip body, arbitrary motions."""
    links = (Link("a", 1.2, 0.8, 30.0, tip_mass=0.2, tip_inertia=0.01, modes=3,
                  damping_ratio=0.02, mode_shapes=shapes),
             Link("b", 0.9, 0.5, 12.0, modes=0),
             Link("c", 0.7, 0.3, 6.0, tip_mass=0.05, tip_inertia=0.002, modes=2,
                  damping_ratio=0.01))
    motions = (CubicMotion(0.3, 0.7, -0.4, 0.2), CubicMotion(1.2, -0.5, 0.8, -0.3),
               CubicMotion(-0.4, 0.2, 0.6, -0.5))
    return FirstOrderSystem(Chain(links, motions), stiffening)


def _paper(stiffening: bool) -> FirstOrderSystem:
    return FirstOrderSystem(Chain(paper_links(4), (CubicMotion(0.1, 0.9, -0.6, 0.3),
                                                   CubicMotion(1.5, -0.8, 1.1, -0.4))),
                            stiffening)


def _in_gravity(system: FirstOrderSystem) -> FirstOrderSystem:
    """The same system in a uniform field with both components (m/s², global axes)."""
    return FirstOrderSystem(system.chain, system.geometric_stiffening, gravity=(2.5, -9.81))


def _bodies(stiffening: bool) -> FirstOrderSystem:
    """Two links carrying rigid bodies: a tip body offset along and across the link, bodies
    inside the span (one across the link)."""
    links = (Link("a", 1.2, 0.8, 30.0, modes=3, mode_shapes="tip_loaded",
                  bodies=(Body(1.2, 0.3, (0.1, 0.06), 0.01), Body(0.5, 0.2, (-0.05, -0.08), 0.003))),
             Link("b", 0.9, 0.5, 12.0, tip_mass=0.05, modes=2,
                  bodies=(Body(0.4, 0.1, (0.2, 0.0), 0.0), Body(0.9, 0.0, (0.0, 0.0), 0.002),
                          Body(0.2, 0.15, (0.0, 0.1), 0.001))))
    motions = (CubicMotion(0.3, 0.7, -0.4, 0.2), CubicMotion(1.2, -0.5, 0.8, -0.3))
    return FirstOrderSystem(Chain(links, motions), stiffening, gravity=(1.5, -9.81))


SYSTEMS = {"three links": _three_links, "paper": _paper, "bodies, gravity": _bodies,
           "outboard loaded": lambda s: _three_links(s, "outboard_loaded"),
           "three links, gravity": lambda s: _in_gravity(_three_links(s)),
           "paper, gravity": lambda s: _in_gravity(_paper(s))}


@pytest.mark.parametrize("stiffening", [False, True])
@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_state_rows_match_the_numpy_equations(name: str, stiffening: bool) -> None:
    """M⁻¹[−K, −C, f] from the compiled assembly equals the numpy matrices' to round-off of
    each row's largest entry, at moving instants and with repeated (resting) ones."""
    system = SYSTEMS[name](stiffening)
    t = np.array([0.0, 0.15, 0.15, 0.6, 1.1, 1.7, 1.7, 2.3])
    expected = numpy_state_rows(system.matrices, t)
    got = state_rows(system, t)
    scale = np.abs(expected).max(axis=2, keepdims=True)
    assert got.shape == expected.shape
    worst = (np.abs(got - expected) / scale).max()
    assert worst < 1e-12, worst


@pytest.mark.parametrize("stiffening", [False, True])
@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_solved_frames_match_the_numpy_frames(name: str, stiffening: bool) -> None:
    """Angles, rates, origins, origin accelerations and ξ-heads along a random solution equal
    those of kinematics.frame_motion and the maps, and so do the joint torques read from them
    (dynamics/torques.py on either frames, and its compiled form);
    times repeat (a rest phase reuses the maps)."""
    system = SYSTEMS[name](stiffening)
    t = np.array([0.0, 0.2, 0.2, 0.2, 0.9, 1.4, 2.0, 2.0])
    rng = np.random.default_rng(3)
    z, zd, zdd = (1e-2 * rng.normal(size=(t.size, system.n)) for _ in range(3))
    ref = system.frames(t)
    got = solved_frames(system, t, z, zd, zdd)
    for a, b in ((got.theta, ref.theta), (got.omega, ref.omega), (got.alpha, ref.alpha),
                 (got.origin, ref.origin), (got.origin_accel, ref.origin_accel)):
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-13 * max(np.abs(b).max(), 1.0))
    for k in range(len(system.chain.links)):
        for a, b in zip(got.heads(k, z, zd, zdd), ref.heads(k, z, zd, zdd)):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-13 * max(np.abs(b).max(), 1e-3))
        np.testing.assert_array_equal(got.head(k, z), got.heads(k, z, zd, zdd)[0])
        # cos θ, sin θ from the kernel (once per joint state) as numpy's per time
        for a, b in zip(got.cos_sin(k), ref.cos_sin(k)):
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-15)
    expected = joint_torques(system, t, z, zd, zdd)
    np.testing.assert_allclose(joint_torques(system, t, z, zd, zdd, got), expected, rtol=0,
                               atol=1e-12 * np.abs(expected).max())
    np.testing.assert_allclose(compiled_torques(system, got), expected, rtol=0,
                               atol=1e-12 * np.abs(expected).max())


def test_solved_frames_refuse_other_coordinates() -> None:
    """The products belong to one solution: asking for another z is an error, not a wrong
    answer."""
    system = _paper(False)
    t = np.array([0.0, 0.5])
    z = np.zeros((2, system.n))
    frames = solved_frames(system, t, z, z, z)
    with pytest.raises(ValueError, match="solution"):
        frames.head(0, z.copy())
    with pytest.raises(ValueError, match="maps"):
        frames.apply(frames.T, 0, z)


def test_packed_data_are_shared_by_systems_of_one_chain_only() -> None:
    """forward_data is remembered per (chain, stiffening, modal data): a new system of the
    same chain reuses it, equal to a fresh pack; another stiffening or chain does not."""
    first, again = _paper(False), _paper(False)
    data = forward_data(first)
    assert forward_data(again) is data
    fresh = pack(forward_view(again))
    for name, value in zip(data._fields, data):
        np.testing.assert_array_equal(value, getattr(fresh, name), err_msg=name)
    assert forward_data(_paper(True)) is not data
    assert forward_data(_three_links(False)) is not data


def test_packed_data_are_shared_by_runs_of_other_motions() -> None:
    """A prescribed joint's motion is not part of the packed data (it enters the kernels as
    inputs): a system of the same links on other motions (an optimiser's trial) reuses them,
    equal to its own fresh pack, and its state rows are those of that fresh pack."""
    first = _paper(False)
    data = forward_data(first)
    other = FirstOrderSystem(Chain(first.chain.links, (CubicMotion(-0.2, 0.4, 0.9, -0.7),
                                                       CubicMotion(0.5, 0.3, -1.2, 0.6))))
    assert forward_data(other) is data
    fresh = pack(forward_view(other))
    for name, value in zip(data._fields, data):
        np.testing.assert_array_equal(value, getattr(fresh, name), err_msg=name)
    t = np.linspace(0.0, 1.0, 7)
    expected = numpy_state_rows(other.matrices, t)
    scale = np.abs(expected).max(axis=2, keepdims=True)
    assert (np.abs(state_rows(other, t) - expected) / scale).max() < 1e-12
