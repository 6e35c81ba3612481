"""Energy balance: the work of the joint torques equals the change of the arm's energy.

The energy and the torques are those of the exact (nonlinear) kinematics evaluated on the
simulated first-order trajectory (tests/validation/brute_force.py). Along a trajectory that
satisfies the equations of motion to first order, the balance is violated only at third order
in the deflection, i.e. by a fraction ~ w/L of the elastic energy; a missing or wrong coupling
in the equations leaves an error of the order of the elastic energy itself (the mutation test
below shows this for the load of the outer link on the inner one).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson

from flexlink.dynamics import first_order
from flexlink.model import Link
from flexlink.motion import Cycloidal
from flexlink.solvers import GivenMatrices, integrate_magnus
from tests.helpers import chain_of
from tests.validation.brute_force import exact_energy, exact_joint_torques

LINKS = (Link("inner", 1.0, 0.6, 150.0, tip_mass=0.2, modes=3),
         Link("outer", 0.7, 0.2, 6.0, tip_mass=0.05, tip_inertia=1e-4, modes=3))
MOTIONS = (Cycloidal(0.0, 40.0, 0.05, 0.5), Cycloidal(30.0, -20.0, 0.1, 0.4))


def _balance_error(stiffening: bool) -> float:
    system = first_order.FirstOrderSystem(chain_of(LINKS, MOTIONS), stiffening)
    t = np.linspace(0.0, 0.8, 321)
    solution = integrate_magnus(GivenMatrices(system.matrices, system.n), t, 1e-9, 1e-14)
    z, zd = solution.q, solution.q_dot
    zdd = system.accelerations(t, z, zd)
    beta_fn = lambda s: np.array([m.evaluate(np.array(s))[0] for m in MOTIONS])
    rates = np.stack([m.evaluate(t)[1] for m in MOTIONS], -1)
    power = np.empty(t.size)
    energy = np.empty(t.size)
    strain = np.empty(t.size)
    for i, ti in enumerate(t):
        tau = exact_joint_torques(LINKS, system.modal, beta_fn, ti, z[i], zd[i], zdd[i], stiffening)
        power[i] = tau @ rates[i]
        energy[i], strain[i] = exact_energy(LINKS, system.modal, beta_fn, ti, z[i], zd[i],
                                            stiffening)
    work = cumulative_simpson(power, x=t, initial=0.0)
    return float(np.abs(work - (energy - energy[0])).max() / strain.max())


@pytest.mark.parametrize("stiffening", [False, True])
def test_work_of_joint_torques_equals_energy_change(stiffening: bool) -> None:
    assert _balance_error(stiffening) < 0.02


def test_energy_balance_detects_a_missing_coupling(monkeypatch: pytest.MonkeyPatch) -> None:
    """Drop the outer link's inertia load on the inner link (MODEL_NOTES, eq. 35 item 1)."""
    original = first_order.FirstOrderSystem._rigid_load

    def without_outboard_rigid_rows(self, body, fr, k):
        load = original(self, body, fr, k)
        if k > 0:
            load[:, :3] = 0.0
        return load

    monkeypatch.setattr(first_order.FirstOrderSystem, "_rigid_load", without_outboard_rigid_rows)
    assert _balance_error(True) > 0.1
