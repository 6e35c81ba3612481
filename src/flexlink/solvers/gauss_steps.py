"""Error-controlled step sizes of the Gauss collocation, shared by both nonlinear paths
(prescribed joints, `gauss.py`; rigid coordinates, `gauss_forward.py`).

Error estimate: step doubling. A checked step H is also taken as two steps H/2 from the
same state; the two H/2 steps are kept and |y_{H/2,H/2} − y_H| / 15 (fourth order) estimates
their local error. The prescribed model's loop checks every step, the forward model's the
first of each batch and every FORWARD_CHECK_EVERY-th after it (the others are their two H/2
steps alone). An embedded lower-order formula would cost less, but it multiplies the
stage accelerations by h², and the stiff high modes (ω h ≫ 1, integrated stably but not
resolved) would dominate it by (ω h)²; the doubling difference of a stiff mode stays of the
order of its (small) amplitude. The estimate is measured against atol + rtol · the largest
|y| (and |ẏ|) of its group so far — elastic coordinates, free rigid coordinates — the
norm of the uniform-step control before it (docs/nonlinear.md §4).

Control: the step controller shared with Radau IIA (`_step_control_numba`): a step is
accepted when its estimate is within the tolerance; the next step size is H · 0.9 ·
err^(−1/5), between 0.2× and 4×, not above H after a rejection, and H itself while the
factor is within [1, 1.2] (its Newton matrices kept). The compiled loop (`_gauss_numba.gauss_doubling`,
either model) takes batches of equal steps, whose inputs are evaluated in one vectorised call; a batch stops at the first rejected step, and the step size
changes between batches. Batches end exactly at every input breakpoint (the switch of a
bang-bang torque, the end of a move), so no step straddles a jump.
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import SimulationError
from .solution import STEP_DOUBLING, Accuracy

# The two-stage Gauss–Legendre tableau: nodes c, coefficients a, weights b; for positions
# a² and bᵀa (q₁ = q₀ + h v₀ + h² Σ (bᵀa)_j X_j).
_R3 = np.sqrt(3.0) / 6.0
NODES = np.array([0.5 - _R3, 0.5 + _R3])
COEFFS = np.array([[0.25, 0.25 - _R3], [0.25 + _R3, 0.25]])
COEFFS2 = COEFFS @ COEFFS
WEIGHTS = np.array([0.5, 0.5])
WEIGHTS2 = WEIGHTS @ COEFFS

Tableau = namedtuple("Tableau", ["nodes", "coeffs", "coeffs2", "weights", "weights2"])
Tableau.__doc__ = ("A collocation method for q̈ = f as the compiled loops take it: nodes c (s,), "
                   "coefficients a (s, s) and a² (s, s), weights b (s,) and bᵀa (s,).")
GAUSS2 = Tableau(NODES, COEFFS, COEFFS2, WEIGHTS, WEIGHTS2)

# Relative round-off of a stage position: a Newton correction of the accelerations below it
# times max|y| / h² cannot move any stage position (`_gauss_numba.solve_stages`, through
# NewtonSettings).
STATE_ROUND_OFF = 1e-15

# A Newton iteration whose contraction rate θ (the ratio of successive corrections) exceeds
# this has an iteration matrix too far from the stage Jacobian: its partial derivatives are
# evaluated again (`_gauss_numba.solve_stages` through NewtonSettings).
SLOW_CONTRACTION = 0.1
# … in the forward model's step-doubling loop (`gauss_forward.integrate_forward_adaptive`),
# whose partials are the first stage's for both stages, serve the matrices of H and H/2 and
# outlive changes of the step size: an evaluation costs 3n + 1 residuals, an iteration two.
# On the slider cases of benchmarks/slider_vs_fe.py 0.03 costs the least (0.1: a third more
# iterations, solves of four and five at θ ~ 0.05; 0.01: as cheap on Case 23, but 1.4–1.9×
# the evaluations at large deflection). The other loops keep each stage's partials, 0.1 and
# new partials at each step size: uniform steps because Newton then stops further below its
# tolerance, which the derivatives of their sensitivities, checked against differences of
# moved runs, need; the prescribed model's doubling loop because its steps would change
# (Newton no longer fails where its step is halved: the paper arm's strain signal at the
# default rtol would be a ninth of its model error instead of a fourteenth).
FORWARD_SLOW_CONTRACTION = 0.03

# The forward model's doubling loop checks the first step of each batch (a batch has one step
# size and ends at the inputs' breakpoints) and every FORWARD_CHECK_EVERY-th after it; the
# steps between are its two H/2 steps without the H step: 2⅓ collocation solves a step
# instead of 3. On the slider cases of benchmarks/slider_vs_fe.py (3, 4, 6 modes) the step
# sizes stay those of checking every step and so does each channel's integration error
# against the converged run, to its second digit (benchmarks/nonlinear_slider_tolerance.py);
# 4 let the large-deflection case's steps grow (its 4-mode hub rate at a seventh of its
# model error instead of an eighth). The prescribed model's loop checks every step.
FORWARD_CHECK_EVERY = 3

NewtonSettings = namedtuple("NewtonSettings", ["tol", "max_iterations", "floor",
                                               "running_peak", "state_round_off",
                                               "slow_contraction", "shared_partials"])
NewtonSettings.__doc__ = (
    "Newton's stopping test in the compiled loops (`_gauss_numba.solve_stages`): tol relative "
    "to the largest stage acceleration (of the run so far if running_peak), at most "
    "max_iterations, the absolute floor (1/s²) times max|q|, and state_round_off times "
    "max|y| / h² (STATE_ROUND_OFF); the contraction rate above which the iteration matrix's "
    "partial derivatives are evaluated again (SLOW_CONTRACTION), and whether they are the "
    "first stage's for both stages, kept across step sizes by DoublingLoop.")


def newton_settings(tol: float, max_iterations: int, floor: float, running_peak: bool,
                    slow_contraction: float = SLOW_CONTRACTION,
                    shared_partials: bool = False) -> NewtonSettings:
    """A NewtonSettings of fixed field types (one compiled signature)."""
    return NewtonSettings(float(tol), int(max_iterations), float(floor), bool(running_peak),
                          STATE_ROUND_OFF, float(slow_contraction), bool(shared_partials))


def step_control(group: np.ndarray, rtol: float, atol: float, rate_floor: float,
                 weight: np.ndarray | None = None) -> Any:
    """The step controller's record (`_step_control_numba.StepControl`) of the doubling
    test of n unknowns and their rates, [q, q̇]: ``group`` (n,) each unknown's group (−1:
    none), its rate in group G + g whose peak is at least ``rate_floor`` (1/s) times group
    g's (a run at rest in static equilibrium, whose rates are round-off); ``weight`` (2n,)
    the error weights of [q, q̇] (None: all 1)."""
    from ._step_control_numba import step_control as control

    group = np.asarray(group, dtype=np.int64)
    groups = max(int(group.max(initial=-1)) + 1, 1)
    both = np.concatenate([group, np.where(group >= 0, group + groups, -1)])
    floor_of = np.concatenate([np.full(groups, -1), np.arange(groups)])
    return control(both, weight, 2 * groups, rtol, atol, EXPONENT, GROW, floor_of,
                   rate_floor)


# Stage times of one doubled step, as fractions of H: the H step's two stages, then those of
# the first and the second H/2 step.
DOUBLING_STAGES = np.concatenate([NODES, 0.5 * NODES, 0.5 + 0.5 * NODES])
# The step controller (`_step_control_numba`): the doubling estimate is of order 4, so the
# factor goes as err^(−1/5); a step may grow 4× (the batch after a growing one is short).
EXPONENT, GROW = 0.2, 4.0
BATCH = 64  # steps per compiled call while the step size is steady
BATCH_GROWING = 4  # … while it is still growing (the controller may take the next one 4× longer)
MAX_STEPS = 2_000_000


@dataclass
class Batch:
    """What a model's compiled loop returns for one batch: status (0 all accepted, 1 a step
    rejected by its error, 2 Newton failed), the accepted steps' ends y, ẏ ((k+1, n), row 0
    the start), each step's error as a fraction of its tolerance (the rejected one included)."""

    status: int
    y: np.ndarray
    v: np.ndarray
    errors: np.ndarray
    counts: np.ndarray  # Newton's matrix rebuilds and iterations so far (the run's totals)


class DoublingLoop:
    """The compiled step-doubling loop of one run (`_gauss_numba.gauss_doubling`), for the
    model whose kernel data ``data`` is (n unknowns): Newton's settings, the step control,
    how often a batch's steps are checked (``check_every``: the first of each batch and
    every that many after it; the others are its two H/2 steps alone), and what the loop
    keeps across batches (the iteration matrices for H and H/2, Newton's counts, the run's
    largest stage acceleration)."""

    def __init__(self, data: Any, n: int, newton: NewtonSettings, control: Any,
                 check_every: int = 1) -> None:
        from ._gauss_numba import residual_model  # numba's import is slow: only when used

        if check_every < 1:
            raise ValueError(f"check_every must be at least 1, got {check_every}")
        self.data, self.n, self.newton, self.control = data, n, newton, control
        self.check_every = int(check_every)
        self.model = residual_model(data)  # borrows data's arrays: kept alive by self.data
        self.inverse = np.zeros((2, 2 * n, 2 * n))
        self.have = np.zeros(3, dtype=np.int64)  # the two matrices', then the partials'
        self.partials = np.empty((2, n, 3 * n))
        self.counts = np.zeros(2, dtype=np.int64)
        self.peak = np.zeros(1)
        self.reached = np.zeros((0, n))  # the last batch's step ends (row 0 its start)

    def batch(self, rows: Any, y0: np.ndarray, v0: np.ndarray, X: np.ndarray, h_prev: float,
              H: float, count: int, new_step: bool) -> Batch:
        """``count`` steps H from y0, v0 (a batch of `step_doubling`'s ``advance``); rows:
        a StageInputs of six stage rows per step (DOUBLING_STAGES); new_step: H differs
        from the last batch's."""
        from ._gauss_numba import gauss_doubling  # numba's import is slow: only when used

        y = np.full((count + 1, self.n), np.nan)  # NaN: rows a failed batch did not reach
        v = np.full((count + 1, self.n), np.nan)
        self.reached = y
        y[0], v[0] = y0, v0
        errors = np.zeros(count)
        if new_step:  # the matrices for the new H (shared partials: from the same ones)
            self.have[:2 if self.newton.shared_partials else 3] = 0
        status, k = gauss_doubling(self.model, rows, y, v, X, h_prev, H, GAUSS2, self.newton,
                                   self.control, errors, self.inverse, self.have,
                                   self.partials, self.counts, self.peak, self.check_every)
        return Batch(int(status), y[:k + 1], v[:k + 1], errors, self.counts)


# advance(t0, H, count, y0, v0, X, h_prev, new_step) → Batch; X (2, n) the stage
# accelerations of the last accepted step (of length h_prev), updated in place; new_step: H
# differs from the previous call's (the Newton matrices must be rebuilt).
Advance = Callable[[float, float, int, np.ndarray, np.ndarray, np.ndarray, float, bool], Batch]


@dataclass(frozen=True)
class StepRecord:
    """The step ends of an adaptive run and what its control saw."""

    t: np.ndarray  # (m+1,) s
    y: np.ndarray  # (m+1, n)
    v: np.ndarray  # (m+1, n)
    rejected: int  # steps taken again with a shorter step (error or Newton)
    largest_error: float  # largest accepted step's estimate, as a fraction of its tolerance
    newton: tuple[int, int]  # Newton's matrix rebuilds and iterations

    def stats(self) -> dict[str, float]:
        """The step statistics a Solution carries."""
        h = np.diff(self.t)
        return {"steps": int(h.size), "rejected_steps": self.rejected,
                "min_step_s": float(h.min()), "max_step_s": float(h.max()),
                "newton_matrices": self.newton[0], "newton_iterations": self.newton[1]}

    def accuracy(self, rtol: float) -> Accuracy:
        """The tolerance and the largest local error estimate of an accepted step, as a
        fraction of the peak (the norm of rtol)."""
        return Accuracy(rtol, self.largest_error * rtol, STEP_DOUBLING)


def step_doubling(advance: Advance, y0: np.ndarray, v0: np.ndarray, X: np.ndarray,
                  t_end: float, breakpoints: np.ndarray, first_step: float, control: Any,
                  on_progress: Callable[[float], None] | None = None) -> StepRecord:
    """Step ends from y0, v0 at t = 0 to t_end (s), each step accepted by its step-doubling
    estimate (``advance``: the model's compiled batch), batches ending at every breakpoint
    (s) inside (0, t_end); ``control``: the batches' StepControl (`step_control`), whose
    factor sets the next step."""
    from ._step_control_numba import SAFETY, keeps, next_factor

    inner = np.asarray(breakpoints, dtype=float)
    eps = 1e-12 * max(1.0, t_end)
    ends = np.append(np.unique(inner[(inner > eps) & (inner < t_end - eps)]), t_end)
    ts, ys, vs = [np.array([0.0])], [y0[None, :]], [v0[None, :]]
    t, y, v = 0.0, y0.copy(), v0.copy()
    H, h_prev, last_H = min(first_step, t_end), min(first_step, t_end), -1.0
    count_max, rejected, largest, window, steps = BATCH_GROWING, 0, 0.0, 0, 0
    rejected_before = False
    while t < t_end - eps:
        while ends[window] <= t + eps:
            window += 1
        remain = ends[window] - t
        count = min(count_max, max(1, int(np.ceil(remain / H - 1e-9))))
        landed = count * H >= remain - eps
        Hb = remain / count if landed else H  # the batch ends on the window's end
        batch = advance(t, Hb, count, y, v, X, h_prev, Hb != last_H)
        last_H = Hb
        k = batch.y.shape[0] - 1
        if k:
            times = t + Hb * np.arange(1, k + 1)
            if landed and k == count:
                times[-1] = ends[window]
            t = float(times[-1])
            ts.append(times)
            ys.append(batch.y[1:])
            vs.append(batch.v[1:])
            y, v = batch.y[-1].copy(), batch.v[-1].copy()
            h_prev = 0.5 * Hb
            largest = max(largest, float(batch.errors[:k].max()))
            steps += k
        if batch.status == 2:  # Newton did not converge: a shorter step
            rejected += 1
            H = 0.5 * Hb
            rejected_before = True
        else:
            err = float(batch.errors[:k + (batch.status == 1)].max(initial=0.0))
            factor = next_factor(control, err, SAFETY, rejected_before)
            rejected_before = batch.status == 1
            rejected += int(rejected_before)
            # a steady step keeps its Newton matrices: change it only when it pays
            H = Hb if keeps(factor) else Hb * factor
            count_max = BATCH_GROWING if factor > 2.0 else BATCH
        if H < 1e-12 * max(1.0, t_end) or steps > MAX_STEPS:
            raise SimulationError(
                f"the nonlinear step size collapsed to {H:.3g} s at t = {t:.4g} s: the "
                "tolerance cannot be met (loosen simulation.rtol or set simulation.step)")
        if on_progress is not None:
            on_progress(t)
    return StepRecord(np.concatenate(ts), np.concatenate(ys), np.concatenate(vs), rejected,
                      largest, (int(batch.counts[0]), int(batch.counts[1])))
