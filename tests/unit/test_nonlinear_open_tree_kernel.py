"""The closed loops' kernel with no closures (`dynamics.nonlinear_loops.NonlinearLoopSystem`
on an open tree: what sampled controllers on the nonlinear forward path integrate) against
the nonlinear forward model's own accelerations (`NonlinearForwardSystem.accelerations`),
with sliders inside the chain (their mass-matrix columns from the residual) on fixed and
moving bases."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics.forward_kernel import inputs
from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
from flexlink.dynamics.nonlinear_loops import NonlinearLoopSystem
from flexlink.model import Base, Cart, Step, TorqueDrive
from tests.unit._slider_cases import telescope
from tests.unit.test_nonlinear_prismatic import _random_states

BASES = {
    "fixed": Base(),
    "free": Base("free", mass=3.0, inertia=0.2),
    "pinned": Base("pinned", inertia=0.2),
    "cart": Base("cart", mass=2.0, attitude=0.2, cart=Cart(TorqueDrive(Step(1.0)), 0.3)),
}


def _kernel_rates(loops: NonlinearLoopSystem, t: np.ndarray, y: np.ndarray, v: np.ndarray
                  ) -> np.ndarray:
    from flexlink.solvers._radau_numba import rates_function

    s = loops.system
    u = inputs(s.loads, t)
    rates = rates_function(loops.data, loops.workspace())
    out = np.empty_like(y)
    for i in range(t.size):
        Y = np.concatenate([y[i], v[i]])
        dY = np.empty_like(Y)
        rates(u[i], Y, dY)
        np.testing.assert_array_equal(dY[:s.n_y], v[i])
        out[i] = dY[s.n_y:]
    return out


@pytest.mark.parametrize("base", list(BASES))
@pytest.mark.parametrize("drive", ["force", "prescribed", "servo"])
def test_the_open_tree_on_the_loop_kernel_has_the_forward_models_accelerations(
        drive: str, base: str) -> None:
    """Random states, gravity on: ÿ of the loop kernel with no closures equals the forward
    model's to 1e-9 of its size (two solves' round-off)."""
    system = NonlinearForwardSystem(telescope(drive), BASES[base], gravity=(1.0, -9.81))
    loops = NonlinearLoopSystem(system, ())
    assert loops.n_c == 0 and loops.first_order is None
    t, y, v, _ = _random_states(system, seed=3)
    expected = system.accelerations(t, y, v)
    got = _kernel_rates(loops, t, y, v)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


def test_the_open_tree_starts_from_the_trees_own_state() -> None:
    system = NonlinearForwardSystem(telescope("force"), BASES["free"])
    y, v = system.initial_state()
    np.testing.assert_array_equal(NonlinearLoopSystem(system, ()).y0, np.concatenate([y, v]))
