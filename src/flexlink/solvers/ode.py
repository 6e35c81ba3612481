"""scipy's ``solve_ivp`` behind flexlink's contract: the prescribed-joint equations for
comparison (``method = "DOP853"``, "RK45", "Radau", "LSODA"), and any first-order system
y' = rhs(t, y) (forward runs), with a guard against a collapsing step.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import SimulationError
from .magnus import accelerations
from .solution import SCIPY, Accuracy, LinearSystem, Progress, Solution
from .threads import single_threaded

# A run whose right-hand side is called STALL_CALLS times while time advances by less than
# STALL_FRACTION of the span is stopped: solve_ivp would otherwise grind on at steps of
# 1e-12 s towards a blow-up.
STALL_CALLS = 5000
STALL_FRACTION = 1e-6


class Stalled(SimulationError):
    """The time step collapsed (the model blew up); ``t`` is where (s)."""

    def __init__(self, t: float) -> None:
        self.t = t
        super().__init__(f"the run stalled at t = {t:.6g} s (the time step collapsed)")


def integrate_scipy(system: LinearSystem, t_out: np.ndarray, rtol: float, atol: float,
                    on_progress: Progress | None = None, method: str = "DOP853") -> Solution:
    """The system's q, q̇, q̈ at t_out from rest, by an error-controlled scipy method."""
    n = system.n

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        M, C, K, f = system.matrices(np.array([t]))
        zdd = np.linalg.solve(M[0], f[0] - C[0] @ y[n:] - K[0] @ y[:n])
        if on_progress is not None:
            on_progress(t)
        return np.concatenate([y[n:], zdd])

    y, evaluations = integrate_ivp(rhs, np.zeros(2 * n), t_out, rtol, atol, method)
    z, zd = y[:, :n], y[:, n:]
    with single_threaded():
        zdd = accelerations(system.matrices, t_out, z, zd)
    return Solution(t_out, z, zd, zdd, method, {"rhs_evaluations": evaluations},
                    accuracy=Accuracy(rtol, None, SCIPY))


def integrate_ivp(rhs: Callable[[float, np.ndarray], np.ndarray], y0: np.ndarray,
                  t_out: np.ndarray, rtol: float, atol: float, method: str,
                  max_step: float = np.inf) -> tuple[np.ndarray, int]:
    """States (nt, len(y0)) at t_out and the number of right-hand side evaluations; raises
    `Stalled` when the step collapses, SimulationError when the integration fails."""
    from scipy.integrate import solve_ivp  # a comparison method: keep it out of start-up

    span = float(t_out[-1] - t_out[0])
    watch = {"calls": 0, "t": float(t_out[0])}

    def guarded(t: float, y: np.ndarray) -> np.ndarray:
        watch["calls"] += 1
        if watch["calls"] % STALL_CALLS == 0:
            if t - watch["t"] < STALL_FRACTION * span:
                raise Stalled(t)
            watch["t"] = t
        return rhs(t, y)

    with single_threaded():  # tiny matrices: threads only cost
        sol = solve_ivp(guarded, (float(t_out[0]), float(t_out[-1])), y0, method=method,
                        t_eval=t_out, rtol=rtol, atol=atol, max_step=max_step)
    if sol.status != 0:
        raise SimulationError(f"time integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
    if not np.all(np.isfinite(sol.y)):
        raise SimulationError("time integration produced non-finite values")
    return sol.y.T, int(sol.nfev)
