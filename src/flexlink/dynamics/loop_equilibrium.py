"""Static equilibrium of a closed-loop mechanism as its initial state (``[simulation] initial
= "equilibrium"`` with ``[[closures]]``): the open tree's rule (`ForwardSystem.equilibrium_state`)
on the constrained equations. The elastic coordinates, and the angle or integral of each servo
holding an independent joint, are moved until their accelerations vanish at rest, the loops
closed at every trial (the compiled closed-loop rates project the dependent joints and carry
the constraint forces); Newton's method of `equilibrium.solve`. Torque-driven and free
independent joints keep their given state, as in the open tree.
"""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from . import equilibrium


def closed_equilibrium(loops, y: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The closed state y (at rest: its rates are zeroed) moved to static equilibrium under
    the input row u (t = 0); ``loops`` a `LoopSystem` whose dependent coordinates are
    chosen. Raises SimulationError naming a servo on a dependent joint (its angle is the
    loop's, not the servo's to hold)."""
    from ._loops_numba import project, rates

    system = loops.system
    nu, n = len(system.free), system.n
    dependent = set(loops.dep.tolist())
    unknowns = list(range(2 * nu, 2 * nu + n))
    rows = list(range(2 * nu + n, 2 * nu + 2 * n))  # z̈ in the rates
    for s, k in enumerate(system.servos):
        j = system.free.index(system.drive_index(k))
        if j in dependent:
            raise SimulationError(
                f"simulation.initial = \"equilibrium\": joint {k + 1}'s servo drives a joint "
                "the closures determine (a dependent joint of the loop); drive an independent "
                "joint (the crank), or use initial = \"rest\"")
        rows.append(nu + j)
        unknowns.append(2 * nu + 2 * n + s if system.chain.joints[k].integrator else j)
    start = np.asarray(y, dtype=float).copy()
    start[nu:2 * nu] = 0.0
    start[2 * nu + n:2 * nu + 2 * n] = 0.0
    work = loops.workspace(start.size)
    out = np.empty_like(start)

    def residuals(x: np.ndarray) -> np.ndarray:
        r = np.empty((x.shape[0], len(rows)))
        for i in range(x.shape[0]):
            trial = start.copy()
            trial[unknowns] = x[i]
            rates(loops.data, work, u, trial, out)
            r[i] = out[rows]
        return r

    closed = start.copy()
    closed[unknowns] = equilibrium.solve(residuals, start[unknowns])
    if not project(loops.data, work, u, closed):
        raise SimulationError("simulation.initial = \"equilibrium\": the deflected mechanism "
                              "does not close (a singular configuration at t = 0)")
    return closed
