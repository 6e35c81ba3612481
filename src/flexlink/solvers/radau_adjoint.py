"""The reverse pass of a compiled Radau IIA run's accepted steps: the gradient of a scalar
J of the run's outputs, the transpose of the forward tangent (`radau_sensitivity`) on the
same steps, with the same stage Jacobians and dense output.

J's seeds are ∂J/∂y at the output times (the states the outputs hold, projected if the run
projects). Each output after the first is the collocation polynomial of one step,
linear in the step's start y0, stage increments z and end y1 (`radau_sensitivity.dense`),
so its seed goes to those with the polynomial's weights at its abscissa. The compiled
pass (`_radau_adjoint_numba.radau_reverse`) then gives, per step, the stage weights w_j
with which ∂f/∂p at stage j enters dJ/dp (Σ_s Σ_j w_sjᵀ ∂f/∂p(Y_sj)), the adjoint of each
step's projected end (the projection's own ∂/∂p enters through it) and that of the
initial state.
"""

from __future__ import annotations

import numpy as np

from .radau_sensitivity import COEFFICIENTS, StepSequence, dense, output_steps


def dense_weights(s: np.ndarray) -> np.ndarray:
    """The weights (n, 5) of y0, z_1, z_2, z_3, y1 in the collocation polynomial at
    abscissae s (n,) (`radau_sensitivity.dense` is linear in them)."""
    n = s.size
    out = np.empty((n, 5))
    for k in range(5):
        unit = np.zeros((5, n, 1))
        unit[k] = 1.0
        out[:, k] = dense(unit[0], np.stack([unit[1], unit[2], unit[3]], axis=1), unit[4],
                          s)[:, 0]
    return out


def output_seeds(steps: StepSequence, t: np.ndarray, seeds: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """∂J/∂(step start) (S, m), ∂J/∂(stage increments) (S, 3, m) and ∂J/∂(step end)
    (S, m) from the seeds ∂J/∂y (nt − 1, m) of the outputs after the first (times t (nt,))
    with respect to the unprojected collocation polynomial."""
    S, _, m = steps.z.shape
    which, s = output_steps(steps, t)
    weights = dense_weights(s)
    gy0, gz, gy1 = np.zeros((S, m)), np.zeros((S, 3, m)), np.zeros((S, m))
    if which.size == 0:
        return gy0, gz, gy1
    # each step's seeds summed as one run of rows (outputs in time order: a no-op sort)
    order = np.argsort(which, kind="stable")
    which, weights, seeds = which[order], weights[order], seeds[order]
    first = np.flatnonzero(np.r_[True, which[1:] != which[:-1]])
    steps_of = which[first]
    gy0[steps_of] = np.add.reduceat(weights[:, :1] * seeds, first, axis=0)
    for k in range(3):
        gz[steps_of, k] = np.add.reduceat(weights[:, 1 + k:2 + k] * seeds, first, axis=0)
    gy1[steps_of] = np.add.reduceat(weights[:, 4:] * seeds, first, axis=0)
    return gy0, gz, gy1


def radau_adjoint(h: np.ndarray, jacobians: np.ndarray, projection: np.ndarray | None,
                  gy0: np.ndarray, gz: np.ndarray, gy1: np.ndarray, lam: np.ndarray,
                  nu: int, n: int) -> tuple[np.ndarray, np.ndarray]:
    """The stage weights W (S, 3, m) and the adjoint of each step's projected end (S, m) of
    S consecutive steps of sizes h (S,), from their stage Jacobians (S, 3, m, m), the
    projection's Jacobian after each (S, m, m) or None, and their seeds (`output_seeds`);
    ``lam`` (m,): the adjoint of the last step's end from the steps after it, replaced by
    that of the first step's start (a run's steps may go in pieces, last first); nu, n:
    the state's free rigid and elastic coordinates (y = [p, ṗ, z, ż, integrals])."""
    from ._radau_adjoint_numba import radau_reverse

    S, _, m = gz.shape
    W, lam_end = np.empty((S, 3, m)), np.empty((S, m))
    P = np.zeros((0, m, m)) if projection is None else np.ascontiguousarray(projection)
    r = m - nu - n
    radau_reverse(np.ascontiguousarray(h, dtype=float), COEFFICIENTS,
                  COEFFICIENTS @ COEFFICIENTS, np.ascontiguousarray(jacobians), P,
                  np.ascontiguousarray(gy0), np.ascontiguousarray(gz),
                  np.ascontiguousarray(gy1), W, lam_end, lam, nu, n,
                  np.empty((3 * r, 3 * r)), np.empty(3 * m), np.empty(3 * r), np.empty(m))
    return W, lam_end
