"""Newton of the nonlinear forward model's error-controlled Gauss loop and the accelerations at
its step ends (solvers/gauss_forward.py, docs/nonlinear.md §7): the first stage's partial
derivatives shared by both stages and kept across step sizes converge to the same steps as
each stage's own partials evaluated at every step size, and the step-end accelerations
iterated with an earlier state's mass matrix equal the direct solve."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
from flexlink.model import Base, Chain, Link, PrismaticJoint, Step, TorqueDrive
from flexlink.solvers import gauss_forward
from flexlink.solvers.gauss_steps import FORWARD_SLOW_CONTRACTION, SLOW_CONTRACTION


def _slider() -> NonlinearForwardSystem:
    """A rigid link turned by a bang-bang torque, a block pushed along its axis, on the block
    a flexible beam with a tip mass (the shape of validation Case 23, smaller)."""
    links = (Link("hub", 0.3, 2.0, 1e4, modes=0),
             Link("beam", 0.8, 0.6, 12.0, tip_mass=0.1, modes=3))
    joints = (TorqueDrive(Step(0.6, -0.6, 0.4)),
              PrismaticJoint(TorqueDrive(Step(1.5, -1.5, 0.5)), 0.0, 0.0, mass=0.3))
    return NonlinearForwardSystem(Chain(links, joints), Base())


def _run(system: NonlinearForwardSystem, shared: bool, slow: float, monkeypatch):
    real = gauss_forward.newton_settings

    def settings(*args, **kwargs):
        kwargs.update(slow_contraction=slow, shared_partials=shared)
        return real(*args[:4], **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(gauss_forward, "newton_settings", settings)
        return gauss_forward.integrate_forward_adaptive(system, 1.0, 1e-5)


def test_shared_partials_take_the_same_steps(monkeypatch: pytest.MonkeyPatch) -> None:
    """The forward loop's Newton (shared, kept partials) and the prescribed loop's (each
    stage's, new at every step size): the same step ends, states within Newton's tolerance."""
    system = _slider()
    shared = _run(system, True, FORWARD_SLOW_CONTRACTION, monkeypatch)
    own = _run(system, False, SLOW_CONTRACTION, monkeypatch)
    assert shared.newton[0] < own.newton[0]  # fewer evaluations of the partials
    np.testing.assert_array_equal(shared.t, own.t)
    np.testing.assert_allclose(shared.y, own.y, rtol=0, atol=1e-8 * np.abs(own.y).max())
    np.testing.assert_allclose(shared.v, own.v, rtol=0, atol=1e-8 * np.abs(own.v).max())


@pytest.mark.parametrize("stride", [1, 7])
def test_step_end_accelerations_equal_the_direct_solve(stride: int) -> None:
    """Along a run's step ends (every one, and every seventh: a mass matrix further from the
    last one built) the compiled accelerations, which iterate with an earlier state's mass
    matrix, equal the numpy model's direct solve to 1e-11 of their size."""
    system = _slider()
    record = gauss_forward.integrate_forward_adaptive(system, 1.0, 1e-5)
    t, y, v = record.t[::stride], record.y[::stride], record.v[::stride]
    got = system.accelerations(t, y, v)
    expected = system.accelerations(t, y, v, compiled=False)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-11 * np.abs(expected).max())
