"""Fourth-order Magnus integrator for the linear time-varying equations of motion.

The first-order model is linear in the state y = [z, ż] with coefficients that depend on time
only (prescribed joints), ẏ = A(t) y + b(t). On a step of length h the augmented system
d/dt [y; 1] = Ã(t) [y; 1], Ã = [[A, b], [0, 0]], is advanced by exp(Ω) with the two-point Gauss
Magnus expansion (Iserles & Nørsett 1999; Blanes et al., Phys. Rep. 470, 2009):

    Ω = h/2 (Ã₁ + Ã₂) + (√3 h²/12) [Ã₂, Ã₁],   Ã_i = Ã(t + (1/2 ∓ √3/6) h).

Every Ã_i is known in advance, so all of them — and all step propagators exp(Ω) — are computed
in a few vectorised calls; only the product y_{n+1} = exp(Ω_n) y_n is sequential. The method
is exact for frozen coefficients, so its step is set by how fast the coefficients change (the
manoeuvre), not by the highest modal frequency.

Error control: the run is repeated with halved steps until two successive solutions agree to
``atol + rtol · peak`` where peak is the largest |z_i| over the run for displacements and the
largest |ż_i| for velocities (the difference over-estimates the error of the finer solution by
~15×, since the method is fourth order). Grouping the coordinates makes the tolerance one on the
physical signals, which are sums of modal contributions, instead of on tiny high-mode amplitudes.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.linalg import expm
from threadpoolctl import threadpool_limits

from .ode import MatrixFunction, SimulationError

_GAUSS = np.array([0.5 - np.sqrt(3) / 6, 0.5 + np.sqrt(3) / 6])
_CHUNK = 2048  # time samples per vectorised assembly (bounds memory for long chains)
_MAX_HALVINGS = 12


def integrate_magnus(
    matrices: MatrixFunction,
    n: int,
    t_out: np.ndarray,
    rtol: float,
    atol: float,
    on_progress: Callable[[float], None] | None = None,
    max_frequency: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """z and ż at t_out (each (nt, n)) from rest at t_out[0].

    max_frequency (rad/s), the highest natural frequency of the model, sets the first step:
    with h·ω ≫ 1 the expansion is still stable but its error estimate converges slowly.
    """
    # The matrices are tiny (2n+1 ≤ a few dozen): BLAS threads only add contention, and under
    # load they slowed a paper run twelvefold. Batch runs parallelise over cases instead.
    with threadpool_limits(limits=1):
        return _integrate(matrices, n, t_out, rtol, atol, on_progress, max_frequency)


def _integrate(
    matrices: MatrixFunction, n: int, t_out: np.ndarray, rtol: float, atol: float,
    on_progress: Callable[[float], None] | None, max_frequency: float,
) -> tuple[np.ndarray, np.ndarray]:
    intervals = np.diff(t_out)
    first_step = min(2e-3, 3.0 / max_frequency) if max_frequency > 0 else 2e-3
    substeps = max(1, int(np.ceil(intervals.max() / first_step)))
    coarse = _solve(matrices, n, t_out, substeps, on_progress)
    for _ in range(_MAX_HALVINGS):
        substeps *= 2
        fine = _solve(matrices, n, t_out, substeps, on_progress)
        peak = np.abs(fine).max(axis=0)
        scale = atol + rtol * np.concatenate([np.full(n, peak[:n].max()), np.full(n, peak[n:].max())])
        if np.all(np.abs(fine - coarse) <= scale):
            return fine[:, :n], fine[:, n:]
        coarse = fine
    raise SimulationError(
        f"the integration did not reach rtol = {rtol:g}, atol = {atol:g} with "
        f"{substeps} steps per output interval; loosen the tolerances or check the model"
    )


def _solve(
    matrices: MatrixFunction, n: int, t_out: np.ndarray, substeps: int,
    on_progress: Callable[[float], None] | None,
) -> np.ndarray:
    """States at t_out with `substeps` equal Magnus steps inside every output interval."""
    frac = np.arange(substeps) / substeps
    starts = (t_out[:-1, None] + np.diff(t_out)[:, None] * frac).ravel()
    h = np.repeat(np.diff(t_out) / substeps, substeps)
    y = np.zeros(2 * n + 1)
    y[-1] = 1.0
    out = np.empty((t_out.size, 2 * n))
    out[0] = 0.0
    for lo in range(0, starts.size, _CHUNK):
        sl = slice(lo, lo + _CHUNK)
        props = _propagators(matrices, n, starts[sl], h[sl])
        for i, P in enumerate(props):
            y = P @ y
            step = lo + i + 1
            if step % substeps == 0:
                out[step // substeps] = y[:-1]
        if not np.all(np.isfinite(y)):
            raise SimulationError(f"the state became non-finite near t = {starts[sl][-1]:.4g} s")
        if on_progress is not None:
            on_progress(float(starts[sl][-1] + h[sl][-1]))
    return out


def _propagators(matrices: MatrixFunction, n: int, t0: np.ndarray, h: np.ndarray) -> np.ndarray:
    """exp(Ω) for every step, (steps, 2n+1, 2n+1)."""
    times = (t0[:, None] + h[:, None] * _GAUSS).ravel()
    A = _augmented(matrices, n, times).reshape(t0.size, 2, 2 * n + 1, 2 * n + 1)
    A1, A2 = A[:, 0], A[:, 1]
    hh = h[:, None, None]
    omega = 0.5 * hh * (A1 + A2) + (np.sqrt(3) / 12) * hh**2 * (A2 @ A1 - A1 @ A2)
    return expm(omega)


def _augmented(matrices: MatrixFunction, n: int, times: np.ndarray) -> np.ndarray:
    """Ã = [[0, I, 0], [−M⁻¹K, −M⁻¹C, M⁻¹f], [0, 0, 0]] at every time."""
    M, C, K, f = matrices(times)
    rhs = np.concatenate([-K, -C, f[:, :, None]], axis=2)
    solved = np.linalg.solve(M, rhs)
    A = np.zeros((times.size, 2 * n + 1, 2 * n + 1))
    A[:, :n, n: 2 * n] = np.eye(n)
    A[:, n: 2 * n, :] = solved
    return A
