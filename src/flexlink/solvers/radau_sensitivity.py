"""Forward sensitivities of a compiled Radau IIA run (`radau.py`): the derivative, in model
parameters p, of what the run computed on its own accepted step sequence.

Each accepted step from y0 at t with step h has stage increments z_i (stage states
Y_i = y0 + z_i at t + c_i h) that solve the collocation equations

    z_i = h Σ_j a_ij f(t + c_j h, y0 + z_j; p),   y1 = y0 + z_3 (stiffly accurate).

Held at the run's steps, their derivative in p solves, per step, one linear system with
the Jacobian J_j = ∂f/∂y at each stage (not the run's frozen Newton Jacobian):

    dz_i − h Σ_j a_ij J_j dz_j = h Σ_j a_ij (J_j dy0 + ∂f/∂p(Y_j)),   dy1 = dy0 + dz_3,

for every parameter at once (one factorisation per step). A model that projects onto
known invariants after each step passes the derivative of its projection. The outputs
come from the step's collocation polynomial (the run's dense output), differentiated
alike. The Jacobians are central differences of the compiled rates (f is smooth in y;
fourth order for closed loops: `stage_jacobians`); so the derivative equals the exact
derivative of the computed run up to those differences (~1e-10 relative, ~1e-7 through
a closed loop's Newton tolerance) and the Newton iteration's residual (a small fraction
of the local error tolerance), and approaches the continuous sensitivity as the run's
tolerance does.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

_SQ6 = math.sqrt(6.0)
C1, C2 = (4.0 - _SQ6) / 10.0, (4.0 + _SQ6) / 10.0
NODES = np.array([C1, C2, 1.0])
COEFFICIENTS = np.array([  # Radau IIA (s = 3): a_ij
    [(88 - 7 * _SQ6) / 360, (296 - 169 * _SQ6) / 1800, (-2 + 3 * _SQ6) / 225],
    [(296 + 169 * _SQ6) / 1800, (88 + 7 * _SQ6) / 360, (-2 - 3 * _SQ6) / 225],
    [(16 - _SQ6) / 36, (16 + _SQ6) / 36, 1 / 9]])
C1M1, C2M1, C1MC2 = C1 - 1.0, C2 - 1.0, C1 - C2
JACOBIAN_STEP = 6e-6  # relative (absolute below 1): ~ the cube root of the unit round-off
CHUNK = 128  # steps whose Jacobians and stage systems are formed at once (memory)

# rates(u (n, columns), Y (n, m)) → f (n, m) of the nominal model
Rates = Callable[[np.ndarray, np.ndarray], np.ndarray]
# jacobians(u (n, columns), Y (n, m)) → ∂f/∂y (n, m, m) of the nominal model
Jacobians = Callable[[np.ndarray, np.ndarray], np.ndarray]
# forcing(stage times (n,), segments (n,), Y (n, m)) → ∂f/∂p (n, m, K)
Forcing = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
# project(step index, y1 (m,), dy1 (m, K)) → the derivative of the projected y1 (m, K)
Projector = Callable[[int, np.ndarray, np.ndarray], np.ndarray]
# held(step index, dy at its start (m, K)) → the held inputs' derivative (a, K) over it
Held = Callable[[int, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class StepSequence:
    """A run's accepted steps (S of them): start times t (S,) and steps h (S,) in s, input
    segment of each (S,), states at their start y0 (S, m) and end y1 (S, m, projected if
    the run projects), stage increments z (S, 3, m)."""

    t: np.ndarray
    h: np.ndarray
    segment: np.ndarray
    y0: np.ndarray
    y1: np.ndarray
    z: np.ndarray

    @property
    def ends(self) -> np.ndarray:
        """The steps' end times (s)."""
        return np.append(self.t[1:], self.t[-1] + self.h[-1]) if self.t.size else self.t


def step_sequence(records: list) -> StepSequence:
    """The StepSequence of `integrate_radau`'s ``steps`` records."""
    if not records:
        raise ValueError("the run took no steps")
    return StepSequence(np.array([r[0] for r in records]), np.array([r[1] for r in records]),
                        np.array([r[2] for r in records], dtype=np.int64),
                        np.array([r[3] for r in records]), np.array([r[4] for r in records]),
                        np.array([r[5] for r in records]))


def stage_jacobians(rates: Rates, u: np.ndarray, Y: np.ndarray, order: int = 2
                    ) -> np.ndarray:
    """∂f/∂y (n, r, m) at states Y (n, m) with input rows u (n, columns), f of r rows
    (r = m for rates; the Gauss stage residuals take more arguments than they return):
    central differences of the rates with steps of JACOBIAN_STEP · max(1, |y_j|), and with
    ``order`` = 4 those at half the steps combined by Richardson. Central, with steps far
    above √ε: a model's rates may close the state by an iteration that stops at a
    tolerance (closed loops: |Φ| ≤ 1e-12 of the loop's size), whose jitter a step of √ε
    would turn into Jacobian errors of 1e-5. Fourth order where the rates are nonlinear on
    a scale not far above the step: a closed loop's rates in a light link's elastic
    coordinates (mass-normalised, through the closure's foreshortening), where second
    order leaves 7e-6 of a column on examples/four_bar.toml (falling as the step
    squared) and the tangent's closure forces 1e-3 off."""
    if order == 4:
        return (4.0 * _central(rates, u, Y, 0.5 * JACOBIAN_STEP)
                - _central(rates, u, Y, JACOBIAN_STEP)) / 3.0
    return _central(rates, u, Y, JACOBIAN_STEP)


def _central(rates: Rates, u: np.ndarray, Y: np.ndarray, relative: float) -> np.ndarray:
    """Central differences of the rates at Y, steps relative · max(1, |y_j|)."""
    n, m = Y.shape
    eps = relative * np.maximum(1.0, np.abs(Y))  # (n, m)
    moved = np.repeat(Y[:, None, None, :], 2, axis=1).repeat(m, axis=2)  # (n, 2, m, m)
    idx = np.arange(m)
    moved[:, 0, idx, idx] += eps
    moved[:, 1, idx, idx] -= eps
    span = moved[:, 0, idx, idx] - moved[:, 1, idx, idx]  # the steps as represented
    f = rates(np.repeat(u, 2 * m, axis=0), moved.reshape(-1, m)).reshape(n, 2, m, -1)
    return np.swapaxes((f[:, 0] - f[:, 1]) / span[:, :, None], 1, 2)


def radau_tangent(steps: StepSequence, rates: Rates, stage_inputs: np.ndarray,
                  forcing: Forcing, dy0: np.ndarray, project: Projector | None = None,
                  jacobians: Jacobians | None = None, jacobian_order: int = 2,
                  held: Held | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The derivatives of each step's start state, stage increments and end state in K
    parameters: dy0 (S, m, K), dz (S, 3, m, K), dy1 (S, m, K), from the derivative of the
    initial state ``dy0`` (m, K); stage_inputs (S, 3, columns) the input rows the run's
    stages used; ``jacobians``: the model's own ∂f/∂y (default: `stage_jacobians` of
    ``rates`` with differences of order ``jacobian_order``). ``held``: inputs held over each
    step whose values depend on the state (sampled controllers' voltages): held(step, dy at
    its start) gives their derivative (a, K) over the step, and ``forcing`` returns K + a
    columns, the last a being ∂f/∂(held inputs)."""
    if jacobians is None:
        def jacobians(u: np.ndarray, Y: np.ndarray) -> np.ndarray:
            return stage_jacobians(rates, u, Y, jacobian_order)
    S, _, m = steps.z.shape
    K = dy0.shape[1]
    h = steps.h
    starts, ends = np.empty((S, m, K)), np.empty((S, m, K))
    dz = np.empty((S, 3, m, K))
    eye = np.eye(3 * m)
    dy = dy0.copy()
    for a in range(0, S, CHUNK):
        b = min(S, a + CHUNK)
        n = b - a
        Y = (steps.y0[a:b, None, :] + steps.z[a:b]).reshape(-1, m)  # (n·3, m)
        u = stage_inputs[a:b].reshape(n * 3, -1)
        J = jacobians(u, Y).reshape(n, 3, m, m)
        times = (steps.t[a:b, None] + NODES[None, :] * h[a:b, None]).ravel()
        Fp = forcing(times, np.repeat(steps.segment[a:b], 3), Y).reshape(n, 3, m, -1)
        hA = h[a:b, None, None] * COEFFICIENTS[None]  # (n, 3, 3)
        G = eye - np.einsum("sij,sjab->siajb", hA, J).reshape(n, 3 * m, 3 * m)
        rhs = np.concatenate([np.einsum("sij,sjab->siab", hA, J).reshape(n, 3 * m, m),
                              np.einsum("sij,sjak->siak", hA, Fp).reshape(n, 3 * m, -1)],
                             axis=2)
        X = np.linalg.solve(G, rhs)  # dz = Φ dy0 + Ψ per step
        Phi, Psi = X[:, :, :m], X[:, :, m:]
        for s in range(n):
            starts[a + s] = dy
            d = Phi[s] @ dy + Psi[s, :, :K]
            if held is not None:
                d = d + Psi[s, :, K:] @ held(a + s, dy)
            dz[a + s] = d.reshape(3, m, K)
            dy = dy + d[2 * m:]
            if project is not None:
                dy = project(a + s, steps.y1[a + s], dy)
            ends[a + s] = dy
    return starts, dz, ends


def output_steps(steps: StepSequence, t_out: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The step (nt − 1,) whose collocation polynomial gives each output after the first,
    and its abscissa s ∈ [−1, 0] there (as the compiled loop assigns them)."""
    x_end = steps.ends
    tol = 1e-12 * np.maximum(1.0, np.abs(x_end))
    which = np.minimum(np.searchsorted(x_end + tol, t_out[1:], side="left"), x_end.size - 1)
    return which, (t_out[1:] - x_end[which]) / steps.h[which]


def dense(y0: np.ndarray, z: np.ndarray, y1: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The collocation polynomial of steps from y0 (n, m, …) with stage increments z
    (n, 3, m, …) to y1 (n, m, …; projected if the run projects: the compiled loop shifts
    its polynomial by (1 + s) of the projection's change) at abscissae s (n,). Linear in
    (y0, z, y1): derivatives go through it alike."""
    d1, d2, d3 = z[:, 0], z[:, 1], z[:, 2]
    c1o = (d2 - d3) / C2M1
    c1 = c1o + (y1 - y0 - d3)
    ak = (d1 - d2) / C1MC2
    c2 = (ak - c1o) / C1M1
    c3 = c2 - (ak - d1 / C1) / C2
    ss = s.reshape(-1, *([1] * (y1.ndim - 1)))
    return y1 + ss * (c1 + (ss - C2M1) * (c2 + (ss - C1M1) * c3))


def table_rows(table: tuple, segment: np.ndarray, times: np.ndarray,
               basis: tuple | None = None) -> np.ndarray:
    """Input rows (n, columns) of an input table (`input_table.tabulate`) at ``times``
    (n,) inside their ``segment`` (n,), as the compiled loop reads them
    (`_radau_numba.input_row`: a segment's pieces continued up to its ends); ``basis``:
    the pieces read (n,) and the Chebyshev polynomials there (n, degree + 1), if already
    made for a table with the same pieces at the same times."""
    if basis is None:
        piece, x = table_piece(table, segment, times)
        basis = piece, np.polynomial.chebyshev.chebvander(x, table[2].shape[1] - 1)
    piece, T = basis
    return np.einsum("nk,nkc->nc", T, table[2][piece])


def table_piece(table: tuple, segment: np.ndarray, times: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
    """The piece (n,) of an input table that each of ``times`` (n,) inside its ``segment``
    (n,) reads, and the time's abscissa in it (n,), in [−1, 1] inside the piece."""
    a, b, _, first = table
    piece = np.searchsorted(b, times, side="left")
    piece = np.clip(piece, first[segment], first[segment + 1] - 1)
    return piece, (2.0 * times - (a[piece] + b[piece])) / (b[piece] - a[piece])
