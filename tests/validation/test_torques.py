"""Joint torques: rigid-body limit, and zero- plus first-order parts against the exact moment
balance of the brute-force kinematics (tests/validation/brute_force.py)."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.dynamics.torques import joint_torques
from tests.helpers import CubicMotion, chain_of
from tests.validation.brute_force import exact_joint_torques
from tests.validation.test_linearisation import MOTIONS, T0, _beta_fn, _links


@pytest.mark.parametrize("count", [1, 2, 3])
@pytest.mark.parametrize("stiffening", [False, True])
def test_torques_equal_exact_moment_balance_to_first_order(count: int, stiffening: bool) -> None:
    links = _links(count)
    motions = MOTIONS[:count]
    system = FirstOrderSystem(chain_of(links, motions), stiffening)
    rng = np.random.default_rng(3)
    n = system.n
    t = np.array([T0])

    def ours(z, zd, zdd):
        return joint_torques(system, t, z[None], zd[None], zdd[None])[0]

    def exact(z, zd, zdd):
        return exact_joint_torques(links, system.modal, _beta_fn(motions), T0, z, zd, zdd,
                                   stiffening)

    zero = np.zeros(n)
    tau0 = exact(zero, zero, zero)
    np.testing.assert_allclose(ours(zero, zero, zero), tau0, rtol=1e-7, atol=1e-9)
    eps = 1e-4
    for _ in range(3):  # the first-order part along random directions of (z, ż, z̈)
        args = [rng.normal(size=n) * s for s in (1.0, 5.0, 50.0)]
        plus = exact(*(eps * a for a in args))
        minus = exact(*(-eps * a for a in args))
        slope_exact = (plus - minus) / (2 * eps)
        slope_ours = ours(*args) - ours(zero, zero, zero)
        assert np.abs(slope_ours - slope_exact).max() <= 1e-5 * np.abs(slope_exact).max() + 1e-8


def test_rigid_single_link_torque() -> None:
    """No deflection: τ = (m L²/3 + m_t L² + J_t) β̈ for a link on a hub."""
    link = _links(1)[0]
    motion = CubicMotion(0.1, 0.4, 1.5, -2.0)
    system = FirstOrderSystem(chain_of([link], [motion]))
    t = np.linspace(0, 1, 7)
    zero = np.zeros((t.size, system.n))
    tau = joint_torques(system, t, zero, zero, zero)[:, 0]
    inertia = (link.mass_per_length * link.length**3 / 3 + link.tip_mass * link.length**2
               + link.tip_inertia)
    np.testing.assert_allclose(tau, inertia * motion.evaluate(t)[2], rtol=1e-12)
