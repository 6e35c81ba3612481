"""Integrate M(t) z̈ + C(t) ż + K(t) z = f(t) with an error-controlled Runge–Kutta method.

The user sets rtol/atol; scipy's ``solve_ivp`` keeps the local error below them. Results come
at the requested output times from the method's dense output.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .threads import single_threaded

MatrixFunction = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]]


class SimulationError(RuntimeError):
    """The integration failed or produced a non-physical (non-finite or exploding) state."""


def integrate_second_order(
    matrices: MatrixFunction,
    n: int,
    t_out: np.ndarray,
    rtol: float,
    atol: float,
    method: str = "DOP853",
    on_progress: Callable[[float], None] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """z and ż at t_out (each (nt, n)), starting from rest (z = ż = 0) at t_out[0]."""
    from scipy.integrate import solve_ivp  # a comparison method: keep it out of start-up


    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        M, C, K, f = matrices(np.array([t]))
        z, zd = y[:n], y[n:]
        zdd = np.linalg.solve(M[0], f[0] - C[0] @ zd - K[0] @ z)
        if on_progress is not None:
            on_progress(t)
        return np.concatenate([zd, zdd])

    with single_threaded():
        sol = solve_ivp(
            rhs, (float(t_out[0]), float(t_out[-1])), np.zeros(2 * n), method=method,
            t_eval=t_out, rtol=rtol, atol=atol,
        )
    if sol.status != 0:
        raise SimulationError(f"time integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
    y = sol.y.T
    if not np.all(np.isfinite(y)):
        raise SimulationError("time integration produced non-finite values")
    return y[:, :n], y[:, n:]
