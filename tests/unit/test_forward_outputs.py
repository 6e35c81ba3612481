"""The compiled pass over a forward run's outputs (dynamics/forward_outputs.py) against the
numpy ForwardSystem: rates, frames at the solved rigid motion, joint torques (a driven
joint's is the applied torque its row was solved for) and momentum, to round-off."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics._forward_numba import workspace
from flexlink.dynamics.forward import momentum
from flexlink.dynamics.forward_kernel import inputs, pack
from flexlink.dynamics.forward_outputs import forward_outputs
from tests.unit.test_cart import SYSTEMS as CARTS
from tests.unit.test_forward_kernel import SYSTEMS


def _close(ours: np.ndarray, theirs: np.ndarray, what: str) -> None:
    scale = max(np.abs(theirs).max(initial=0.0), 1e-300)
    np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-10 * scale, err_msg=what)


@pytest.mark.parametrize("name", sorted(SYSTEMS))
def test_outputs_match_the_numpy_equations(name: str) -> None:
    _check(SYSTEMS[name](True))


@pytest.mark.parametrize("name", sorted(CARTS))
def test_outputs_of_a_cart_match_the_numpy_equations(name: str) -> None:
    """The cart's links hang from R_0 + s e at the cart's constant attitude (its travel s is
    no angle); its mass moves with ṡ e in the momentum."""
    _check(CARTS[name](True))


def _check(system) -> None:
    rng = np.random.default_rng(5)
    nt, nu, n, ns = 7, len(system.free), system.n, len(system.servos)
    t = np.sort(rng.uniform(0.0, 1.5, nt))
    p_free = rng.uniform(-2.0, 2.0, (nt, nu))
    pd_free = rng.normal(size=(nt, nu))
    z, zd = 1e-2 * rng.normal(size=(nt, n)), 0.3 * rng.normal(size=(nt, n))
    integral = 0.2 * rng.normal(size=(nt, ns))
    states = np.hstack([p_free, pd_free, z, zd, integral])
    data = pack(system)
    out = forward_outputs(system, data, workspace(data, ns), inputs(system, t), states)
    pdd_free, zdd, srates = system.accelerations(t, p_free, pd_free, z, zd, integral)
    _close(out.rates, np.hstack([pd_free, pdd_free, zd, zdd, srates]), "rates")
    p, pd, pdd = system.rigid_state(t, p_free, pd_free, pdd_free)
    fr = system.frames(p, pd, pdd)
    for field in ("theta", "omega", "alpha", "origin", "origin_accel"):
        _close(getattr(out.frames, field), getattr(fr, field), field)
    for field in ("T", "T_dot", "T_ddot"):
        for k in range(len(system.chain.links)):
            _close(getattr(out.frames, field)[k], getattr(fr, field)[k], f"{field}[{k}]")
    _close(out.torques, system.joint_torques(p, pd, pdd, z, zd, zdd), "torques")
    if system.base.kind == "fixed":
        assert out.momenta is None
    else:
        linear, angular = momentum(system, p, pd, z, zd)
        _close(out.momenta[0], linear, "linear momentum")
        _close(out.momenta[1], angular, "angular momentum")
