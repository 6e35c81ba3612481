"""The assembled first-order equations equal a brute-force linearisation of the exact kinematics.

This is the "two ways to one quantity" check of the kinematical synthesis (MODEL_NOTES: a direct
Lagrangian linearisation of the whole arm is the reference for a general N-link implementation).
"""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.model import Link
from tests.helpers import CubicMotion, chain_of
from tests.validation.brute_force import linearise

T0 = 0.3


def _links(count: int) -> list[Link]:
    base = [
        Link("a", 1.2, 0.8, 300.0, tip_mass=0.3, tip_inertia=0.004, modes=3),
        Link("b", 0.7, 0.2, 15.0, tip_mass=0.05, tip_inertia=0.001, modes=2),
        Link("c", 0.5, 0.1, 4.0, tip_mass=0.02, modes=2),
    ]
    return base[:count]


MOTIONS = [CubicMotion(0.3, 1.1, -2.0, 3.0), CubicMotion(1.2, -0.8, 1.5, -4.0),
           CubicMotion(-0.6, 0.5, 2.5, 1.0)]


def _beta_fn(motions):
    return lambda t: np.array([float(m.evaluate(np.array(t))[0]) for m in motions])


@pytest.mark.parametrize("count", [1, 2, 3])
@pytest.mark.parametrize("stiffening", [False, True])
def test_matrices_equal_brute_force_linearisation(count: int, stiffening: bool) -> None:
    links = _links(count)
    motions = MOTIONS[:count]
    system = FirstOrderSystem(chain_of(links, motions), geometric_stiffening=stiffening)
    M, C, K, f = (a[0] for a in system.matrices(np.array([T0])))
    for body in system.bodies:  # the reference has inertia only
        K[body.slice, body.slice] -= body.data.stiffness_matrix
        C[body.slice, body.slice] -= body.data.damping_matrix

    M_ref, C_ref, K_ref, f_ref = linearise(links, system.modal, _beta_fn(motions), T0, stiffening)

    # Finite differences leave noise of ~1e-8 of the mass matrix where an entry is exactly zero.
    floor = 1e-6 * np.abs(M_ref).max()
    for name, ours, ref in (("M", M, M_ref), ("C", C, C_ref), ("K", K, K_ref), ("f", f, f_ref)):
        scale = np.abs(ref).max()
        assert np.abs(ours - ref).max() <= 2e-5 * scale + floor, name


def test_stiffening_changes_only_stiffness() -> None:
    links = _links(2)
    chain = chain_of(links, MOTIONS[:2])
    plain = FirstOrderSystem(chain, False).matrices(np.array([T0]))
    stiff = FirstOrderSystem(chain, True).matrices(np.array([T0]))
    for i in (0, 1, 3):
        np.testing.assert_array_equal(plain[i], stiff[i])
    inertial = plain[2][0].copy()
    for body in FirstOrderSystem(chain, False).bodies:
        inertial[body.slice, body.slice] -= body.data.stiffness_matrix
    assert np.abs(plain[2] - stiff[2]).max() > 0.1 * np.abs(inertial).max()
