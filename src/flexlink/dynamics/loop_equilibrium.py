"""Static equilibrium of a closed-loop mechanism as its initial state (``[simulation] initial
= "equilibrium"`` with ``[[closures]]``): the open tree's rule (`ForwardSystem.equilibrium_state`)
on the constrained equations. The elastic coordinates, and the angle or integral of each servo
holding an independent joint, are moved until their accelerations vanish at rest, the loops
closed at every trial (the compiled closed-loop rates project the dependent joints and carry
the constraint forces); Newton's method of `equilibrium.solve`. Torque-driven and free
independent joints keep their given state, as in the open tree; on a moving base the base's
coordinates too (equilibrium relative to the base, which may accelerate). One solver serves
both models (`closed_equilibrium`: first order; `closed_nonlinear_equilibrium`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..errors import SimulationError
from . import equilibrium


def closed_equilibrium(loops, y: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The closed state y (at rest: its rates are zeroed) moved to static equilibrium under
    the input row u (t = 0); ``loops`` a `LoopSystem` whose dependent coordinates are
    chosen. Raises SimulationError naming a servo on a dependent joint (its angle is the
    loop's, not the servo's to hold)."""
    from ._loops_numba import close

    system = loops.system
    nu, n = len(system.free), system.n
    unknowns = list(range(2 * nu, 2 * nu + n))
    rows = list(range(2 * nu + n, 2 * nu + 2 * n))  # z̈ in the rates
    for s, k in enumerate(system.servos):
        j = system.free.index(system.drive_index(k))
        _independent(k, j, loops.dep)
        rows.append(nu + j)
        unknowns.append(2 * nu + 2 * n + s if system.chain.joints[k].integrator else j)
    rest = list(range(nu, 2 * nu)) + list(range(2 * nu + n, 2 * nu + 2 * n))
    work = loops.workspace(y.size)
    columns, watched = system.unheld(_free_indices(loops.dep))
    rows += [nu + j for j in columns]

    def project(u: np.ndarray, y: np.ndarray) -> bool:
        return close(loops.data, work, u, y, 1)
    return _solve(rates_function(loops, work), project, u, y, unknowns, rows, rest, watched)


def rates_function(loops, work: Any) -> Callable[[np.ndarray, np.ndarray,
                                                                np.ndarray], None]:
    """rates(u, y, dy): the closed-loop rates dy of the state y under the input row u, y
    projected onto the loops first (y itself unchanged; ``work`` its workspace): the outputs
    pass (`_loops_numba.closed_states`) on one state, the same constrained solve as the
    integrator's rates (which Python cannot call: they have no Python wrapper)."""
    from ._loops_numba import closed_states as kernel

    lam, joint = np.empty((1, loops.n_c)), np.empty((1, len(loops.system.chain.links)))
    residual = np.empty(1)

    def rates(u: np.ndarray, y: np.ndarray, dy: np.ndarray) -> None:
        kernel(loops.data, work, np.ascontiguousarray(u, dtype=float)[None],
               np.array(y, dtype=float)[None], dy[None], lam, joint, residual)
    return rates


def closed_nonlinear_equilibrium(loops, Y: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The same on the nonlinear model: ``loops`` a `NonlinearLoopSystem`, Y = [y, ẏ] with
    y = [q, p_free, σ] (a servo's integral is σ̇, a rate)."""
    from ._nonlinear_loops_numba import project, rates

    system = loops.system
    n, nu, ny = system.n, system.nu, system.n_y
    unknowns = list(range(n))
    rows = list(range(ny, ny + n))  # q̈ in the rates
    for s, k in enumerate(system.servos):
        servo, i = system.loads.servo_of(k)
        j = system.free.index(i)
        _independent(k, j, loops.data.dep - n)
        rows.append(ny + n + j)
        unknowns.append(ny + n + nu + s if servo.integrator else n + j)
    rest = list(range(ny, ny + n + nu))
    columns, watched = system.loads.unheld(_free_indices(loops.data.dep - n))
    rows += [ny + n + j for j in columns]
    data, work = loops.data, loops.workspace()
    return _solve(lambda u, y, out: rates(data, work, u, y, out),
                  lambda u, y: project(data, work, u, y), u, Y, unknowns, rows, rest, watched)


def _free_indices(dependent: np.ndarray) -> list[int]:
    return [int(j) for j in np.asarray(dependent).ravel()]


def _independent(k: int, j: int, dependent: np.ndarray) -> None:
    """Refuses a servo (joint k + 1, free coordinate j) on a dependent joint."""
    if j in set(np.asarray(dependent).tolist()):
        raise SimulationError(
            f"simulation.initial = \"equilibrium\": joint {k + 1}'s servo drives a joint "
            "the closures determine (a dependent joint of the loop); drive an independent "
            "joint (the crank), or use initial = \"rest\"")


def _solve(rates: Callable[[np.ndarray, np.ndarray, np.ndarray], None],
           project: Callable[[np.ndarray, np.ndarray], bool], u: np.ndarray, y: np.ndarray,
           unknowns: list[int], rows: list[int], rest: list[int],
           watched: Sequence[equilibrium.Unheld] = ()) -> np.ndarray:
    """State y with its ``rest`` entries (rates) zeroed and its ``unknowns`` moved until
    the compiled closed-loop rates(u, y, out) vanish on ``rows``, then projected on the
    loops (project(u, y): in place, False when they do not close); the last
    len(``watched``) rows are the unheld joints' (`equilibrium.solve`)."""
    start = np.asarray(y, dtype=float).copy()
    start[rest] = 0.0
    out = np.empty_like(start)

    def residuals(x: np.ndarray) -> np.ndarray:
        r = np.empty((x.shape[0], len(rows)))
        for i in range(x.shape[0]):
            trial = start.copy()
            trial[unknowns] = x[i]
            rates(u, trial, out)
            r[i] = out[rows]
        return r

    closed = start.copy()
    closed[unknowns] = equilibrium.solve(residuals, start[unknowns], watched)
    if not project(u, closed):
        raise SimulationError("simulation.initial = \"equilibrium\": the deflected mechanism "
                              "does not close (a singular configuration at t = 0)")
    return closed
