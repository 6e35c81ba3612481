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

Rest phases cost almost nothing: the coefficients depend on time only through the joint states,
so the caller may label instants (``coefficient_keys``; equal label ⇒ equal coefficients). Steps
with equal labels and length share one exp(Ω), and a run of identical steps is advanced by
repeated squaring of the propagator instead of a step-by-step loop.

Error control: a solution with steps h is compared with one with steps 2h at their common output
times. For a fourth-order method the finer solution's error is about their difference / 15
(Richardson); while that exceeds ``atol + rtol · peak`` the step is halved again. Peak is the
largest |z_i| over the run for displacements and the largest |ż_i| for velocities: grouping the
coordinates makes the tolerance one on the physical signals, which are sums of modal
contributions, instead of on tiny high-mode amplitudes.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import SimulationError
from .batched_expm import expm_balanced
from .solution import (
    RICHARDSON,
    Accuracy,
    LinearSystem,
    Matrices,
    Progress,
    Solution,
    StepReach,
    tip_bounds,
    unreached,
)
from .threads import single_threaded

_GAUSS = np.array([0.5 - np.sqrt(3) / 6, 0.5 + np.sqrt(3) / 6])
_CHUNK = 2048  # time samples per vectorised assembly (bounds memory for long chains)
_MAX_HALVINGS = 12
_RICHARDSON = 2**4 - 1

KeyFunction = Callable[[np.ndarray], np.ndarray]
MatrixFunction = Callable[[np.ndarray], Matrices]


def integrate_magnus(system: LinearSystem, t_out: np.ndarray, rtol: float, atol: float,
                     on_progress: Progress | None = None) -> Solution:
    """The system's q, q̇, q̈ at t_out from rest at t_out[0].

    Its max_frequency (rad/s), the highest natural frequency, sets the first step: with
    h·ω ≫ 1 the expansion is still stable but its error estimate converges slowly. Its
    coefficient_keys label instants whose coefficients are equal (module docstring).
    """
    with single_threaded():
        z, zd, substeps, estimate, reach = _integrate(
            system.matrices, system.n, t_out, rtol, atol, on_progress, system.max_frequency,
            system.coefficient_keys, tip_bounds(system))
        zdd = accelerations(system.matrices, t_out, z, zd)
    return Solution(t_out, z, zd, zdd, "magnus", {"steps_per_output_interval": substeps},
                    accuracy=Accuracy(rtol, estimate, RICHARDSON), reach=reach)


def accelerations(matrices: MatrixFunction, t: np.ndarray, z: np.ndarray,
                  zd: np.ndarray) -> np.ndarray:
    """q̈ (nt, n) from the equations of motion at times t."""
    rows = state_rows(matrices, t)
    n = z.shape[1]
    return np.einsum("tij,tj->ti", rows[:, :, : 2 * n], np.hstack([z, zd])) + rows[:, :, -1]


def _integrate(
    matrices: MatrixFunction, n: int, t_out: np.ndarray, rtol: float, atol: float,
    on_progress: Progress | None, max_frequency: float,
    keys: KeyFunction | None, bounds: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray, int, float, StepReach | None]:
    intervals = np.diff(t_out)
    first_step = initial_step(max_frequency)
    substeps = max(1, int(np.ceil(intervals.max() / first_step)))
    # The first comparison uses every other output time with the same substeps (step 2h).
    every_other = np.unique(np.append(np.arange(0, t_out.size, 2), t_out.size - 1))
    previous = _solve(matrices, n, t_out[every_other], substeps, on_progress, keys)
    common = every_other
    for _ in range(_MAX_HALVINGS):
        fine, reach = _solve_reaching(matrices, n, t_out, substeps, on_progress, keys, bounds)
        if agree(fine, fine[common], previous, n, rtol, atol):
            return (fine[:, :n], fine[:, n:], substeps,
                    richardson_error(fine[common], previous, n), reach)
        previous, common = fine, slice(None)
        substeps *= 2
    raise SimulationError(
        f"the integration did not reach rtol = {rtol:g}, atol = {atol:g} with "
        f"{substeps // 2} steps per output interval; loosen the tolerances or check the model"
    )


def initial_step(max_frequency: float) -> float:
    """First step (s) of the fourth-order integrators: 2 ms, or 3/ω_max if shorter (with
    h·ω ≫ 1 Magnus is still stable but its error estimate converges slowly)."""
    return min(2e-3, 3.0 / max_frequency) if max_frequency > 0 else 2e-3


def agree(
    fine: np.ndarray, fine_common: np.ndarray, coarse: np.ndarray, n: int, rtol: float, atol: float
) -> bool:
    """Whether the finer solution's estimated error is within atol + rtol · peak."""
    # Whole-array reductions: numpy's per-column max over (nt, 2n) is slower.
    tolerance = _tolerance(np.abs(fine[:, :n]).max(), np.abs(fine[:, n:]).max(), n, rtol, atol)
    return bool(np.all(np.abs(fine_common - coarse) <= _RICHARDSON * tolerance))


def richardson_error(fine: np.ndarray, coarse: np.ndarray, n: int) -> float:
    """The finer run's error estimate |fine − coarse| / 15 relative to the peak of the
    coordinates (the first n columns) or of their rates (the next n), the larger of the two:
    what ``agree`` holds within rtol (an Accuracy's estimate)."""
    return richardson_error_maxima(np.abs(fine[:, :2 * n]).max(axis=0),
                                   np.abs(fine[:, :2 * n] - coarse[:, :2 * n]).max(axis=0), n)


def richardson_error_maxima(peak: np.ndarray, spread: np.ndarray, n: int) -> float:
    """richardson_error from the maxima ``agree_maxima`` reads (per state component: the
    largest |fine| and |fine − coarse| over the output times)."""
    out = 0.0
    for part in (slice(0, n), slice(n, 2 * n)):
        top = float(peak[part].max(initial=0.0))
        if top > 0.0:
            out = max(out, float(spread[part].max(initial=0.0)) / _RICHARDSON / top)
    return out


def agree_maxima(peak: np.ndarray, spread: np.ndarray, n: int, rtol: float,
                 atol: float) -> bool:
    """agree from maxima over the output times instead of the whole arrays: ``peak`` the
    largest |fine state| and ``spread`` the largest |fine − coarse| of each of the 2n state
    components (the same decision: a maximum of |·| is exact)."""
    tolerance = _tolerance(peak[:n].max(initial=0.0), peak[n: 2 * n].max(initial=0.0), n,
                           rtol, atol)
    return bool(np.all(spread[: 2 * n] <= _RICHARDSON * tolerance))


def _tolerance(coordinates: float, rates: float, n: int, rtol: float,
               atol: float) -> np.ndarray:
    """The error allowed on each of the 2n state components: atol + rtol · the peak of the
    coordinates (the first n) or of their rates (the last n)."""
    tolerance = np.empty(2 * n)
    tolerance[:n] = atol + rtol * coordinates
    tolerance[n:] = atol + rtol * rates
    return tolerance


def _solve(
    matrices: MatrixFunction, n: int, t_out: np.ndarray, substeps: int,
    on_progress: Callable[[float], None] | None, keys: KeyFunction | None = None,
) -> np.ndarray:
    """States [z, ż] at t_out (nt, 2n) with `substeps` equal Magnus steps per output interval."""
    return _solve_reaching(matrices, n, t_out, substeps, on_progress, keys)[0]


def _solve_reaching(
    matrices: MatrixFunction, n: int, t_out: np.ndarray, substeps: int,
    on_progress: Callable[[float], None] | None, keys: KeyFunction | None = None,
    bounds: np.ndarray | None = None,
) -> tuple[np.ndarray, StepReach | None]:
    """`_solve`, and the steps' reach of ``bounds`` (`solution.tip_bounds`; None without)."""
    frac = np.arange(substeps) / substeps
    starts = (t_out[:-1, None] + np.diff(t_out)[:, None] * frac).ravel()
    h = np.repeat(np.diff(t_out) / substeps, substeps)
    labels = _step_labels(starts, h, keys)
    y = np.zeros(2 * n + 1)
    y[-1] = 1.0
    out = np.empty((t_out.size, 2 * n + 1))
    out[0] = y
    reach = unreached(bounds)
    for lo in range(0, starts.size, _CHUNK):
        sl = slice(lo, lo + _CHUNK)
        _, first, which = np.unique(labels[sl], return_index=True, return_inverse=True)
        props = _propagators(matrices, n, starts[sl][first], h[sl][first])
        # every step's end state (a long rest phase's only at its outputs: zero between)
        trace = np.zeros((which.size, y.size)) if bounds is not None else None
        y = _advance(props, which.ravel(), y, lo, substeps, out, trace)
        if reach is not None:
            _reach(np.abs(trace @ bounds.T), starts[sl] + h[sl], reach.peak, reach.beyond)
        if not np.all(np.isfinite(y)):
            raise SimulationError(f"the state became non-finite near t = {starts[sl][-1]:.4g} s")
        if on_progress is not None:
            on_progress(float(starts[sl][-1] + h[sl][-1]))
    return out[:, :-1], reach


def _reach(values: np.ndarray, ends: np.ndarray, far: np.ndarray, beyond: np.ndarray) -> None:
    """Keep far (r,) the largest of ``values`` (steps, r), the bounded magnitudes at the
    steps' ``ends`` (s), and beyond (r,) the first end where one exceeded 1 (in place)."""
    if not values.size:
        return
    np.maximum(far, values.max(axis=0), out=far)
    over = values > 1.0
    for j in np.flatnonzero(over.any(axis=0) & np.isinf(beyond)):
        beyond[j] = ends[int(np.argmax(over[:, j]))]


def _step_labels(starts: np.ndarray, h: np.ndarray, keys: KeyFunction | None) -> np.ndarray:
    """One integer per step; equal integers ⇒ equal Magnus propagators."""
    if keys is None:
        return np.arange(starts.size)
    at_gauss = keys((starts[:, None] + h[:, None] * _GAUSS).ravel()).reshape(-1, 2)
    # Output intervals from arange·dt differ in the last bits; that is no reason for a new exp(Ω).
    rows = np.column_stack([at_gauss, np.round(h / h.max(), 12)])
    new = np.ones(starts.size, dtype=bool)
    new[1:] = np.any(rows[1:] != rows[:-1], axis=1)
    return np.cumsum(new) - 1


def _advance(
    props: np.ndarray, which: np.ndarray, y: np.ndarray, first_step: int, substeps: int,
    out: np.ndarray, trace: np.ndarray | None = None,
) -> np.ndarray:
    """Apply props[which[i]] in turn from global step `first_step`; store outputs; return y.
    ``trace`` (steps, 2n+1): where given, each step's end state (a rest phase's taken by
    powers only at its outputs)."""
    bounds = np.flatnonzero(np.diff(which)) + 1
    for lo, hi in zip(np.concatenate([[0], bounds]), np.concatenate([bounds, [which.size]])):
        P = props[which[lo]]
        step = first_step + lo  # steps done so far
        count = int(hi - lo)
        if count >= 4 * substeps:
            # Long run of one propagator (a rest phase): to the next output, then whole output
            # intervals by powers of P^substeps, then the remainder.
            lead = (-step) % substeps
            for j in range(lead):
                y = P @ y
                if trace is not None:
                    trace[step - first_step + j] = y
            step += lead
            if lead:
                out[step // substeps] = y
            whole = (count - lead) // substeps
            Q = np.linalg.matrix_power(P, substeps)
            chunk = out[step // substeps + 1: step // substeps + 1 + whole]
            _fill_powers(Q, y, chunk)
            y = chunk[-1].copy()
            if trace is not None:
                trace[step - first_step + substeps - 1:
                      step - first_step + whole * substeps:substeps] = chunk
            step += whole * substeps
            count -= lead + whole * substeps
        for _ in range(count):
            y = P @ y
            step += 1
            if trace is not None:
                trace[step - first_step - 1] = y
            if step % substeps == 0:
                out[step // substeps] = y
    return y


def _fill_powers(Q: np.ndarray, y: np.ndarray, rows: np.ndarray) -> None:
    """rows[j] = Q^(j+1) y, by doubling: rows[m:2m] = Q^m rows[:m]."""
    rows[0] = Q @ y
    filled, Qm = 1, Q
    while filled < len(rows):
        take = min(filled, len(rows) - filled)
        rows[filled: filled + take] = rows[:take] @ Qm.T
        filled += take
        Qm = Qm @ Qm


def _propagators(matrices: MatrixFunction, n: int, t0: np.ndarray, h: np.ndarray) -> np.ndarray:
    """exp(Ω) for every step, (steps, 2n+1, 2n+1)."""
    times = (t0[:, None] + h[:, None] * _GAUSS).ravel()
    A = augmented(state_rows(matrices, times)).reshape(t0.size, 2, 2 * n + 1, 2 * n + 1)
    A1, A2 = A[:, 0], A[:, 1]
    hh = h[:, None, None]
    omega = 0.5 * hh * (A1 + A2) + (np.sqrt(3) / 12) * hh**2 * (A2 @ A1 - A1 @ A2)
    s = np.sqrt(max(np.abs(A1[:, n: 2 * n, :n]).max(), np.abs(A2[:, n: 2 * n, :n]).max(), 1.0))
    return expm_balanced(omega, n, s)


def state_rows(matrices: MatrixFunction, times: np.ndarray) -> np.ndarray:
    """M⁻¹[−K, −C, f] at every time, (nt, n, 2n+1): z̈ = this · [z; ż; 1]."""
    M, C, K, f = matrices(times)
    return np.linalg.solve(M, np.concatenate([-K, -C, f[:, :, None]], axis=2))


def augmented(rows: np.ndarray) -> np.ndarray:
    """Ã = [[0, I, 0], [rows], [0, 0, 0]] of the state [z, ż, 1] from state_rows, (…, 2n+1, 2n+1)."""
    n = rows.shape[-2]
    A = np.zeros(rows.shape[:-2] + (2 * n + 1, 2 * n + 1))
    A[..., :n, n: 2 * n] = np.eye(n)
    A[..., n: 2 * n, :] = rows
    return A
