"""The gradient of one scalar of a Lawson run's outputs by a reverse (adjoint) pass of its steps.

`lawson_sensitivity` steps one tangent per parameter alongside the run; for a scalar J of the
outputs, J's gradient in every parameter comes from one backward pass of the same steps on the
same discretisation (`_lawson_adjoint_numba`): the adjoint λ = ∂J/∂y runs backwards through
the fine steps' stages, and ∂A/∂p enters J through weights the pass collects once, whatever
the number of parameters — per piece of the table the monomials' weights G (a stage's slope
reads ∂A/∂p(τ) y at its local time τ), per static block Σ ∂J/∂z̈ yᵀ and the weight W of its
propagator exp(Δt Ã). The pairing of W with the Fréchet derivative L(Δt Ã, Δt ∂Ã/∂p) is
⟨Δt ∂Ã/∂p, L(Δt Ãᵀ, W)⟩: one exponential of a doubled matrix per static block, not per
parameter. So the gradient is the derivative of what the run computed, as the tangents are
(`tests/unit/test_adjoint.py` compares the two to round-off).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.linalg import expm

from .coefficient_table import CoefficientTable, sample_weights
from .lawson import Discretisation
from .lawson_sensitivity import DerivativeRows, steps_on
from .magnus import augmented
from .solution import LinearSystem
from .threads import single_threaded

# times (nt,), weights (nt, n, 2n+1) → Σ_t ⟨∂A/∂p_k(t), weights_t⟩ (K,)
DerivativePairing = Callable[[np.ndarray, np.ndarray], np.ndarray]


def lawson_gradient(system: LinearSystem, derivative_rows: DerivativeRows, t_out: np.ndarray,
                    discretisation: Discretisation, seed_q: np.ndarray, seed_qd: np.ndarray,
                    seed_qdd: np.ndarray, settled_system: bool = False,
                    pairing: DerivativePairing | None = None
                    ) -> tuple[np.ndarray, np.ndarray]:
    """dJ/dp_k (K,) of J with ∂J/∂q, ∂J/∂q̇, ∂J/∂q̈ = ``seed_q``, ``seed_qd``, ``seed_qdd``
    (nt, n each) along the system's run on ``discretisation`` from rest at t_out[0]
    (`lawson_sensitivity.lawson_sensitivities`' run), through its dependence on A only
    (``derivative_rows``: ∂A/∂p_k at given times, (nt, K, n, 2n+1)); and the run's augmented
    states (nt, 2n+1). ``settled_system``: the system is the one whose run settled the
    discretisation (its table is then the one the discretisation keeps, and its steps the
    run's, where the discretisation keeps them: `Discretisation.steps`). ``pairing``:
    Σ_i ⟨∂A/∂p_k(t_i), W_i⟩ (K,) at given times t_i and weights W_i (nt, n, 2n+1), where
    that is cheaper than ``derivative_rows`` (none: from them)."""
    from ._lawson_adjoint_numba import lawson_adjoint_blocks

    n = system.n
    m = 2 * n + 1
    nt = t_out.size
    seed_y = np.zeros((nt, m))
    seed_y[:, :n] = seed_q
    seed_y[:, n: 2 * n] = seed_qd
    seed_acc = np.ascontiguousarray(seed_qdd, dtype=float)
    with single_threaded():
        table, reference, ET, E2T = steps_on(system, t_out, discretisation, settled_system)
        polyT = np.ascontiguousarray(np.swapaxes(table.poly, 2, 3))
        referenceT = np.ascontiguousarray(np.swapaxes(reference, 1, 2))
        G = np.zeros((table.poly.shape[0], table.poly.shape[1], n, m))
        Gs = np.zeros((len(table), n, m))
        W = np.zeros((len(table), m, m))
        steps = discretisation.steps if settled_system else None
        if steps is None:  # the forward steps anew, in the pass
            states = np.empty((nt, m))
            starts = np.empty((int(np.sum((table.last - table.first)[~table.static]))
                               * (discretisation.substeps - 1), m))
        else:  # the run's own
            states, starts = steps.states, steps.starts
        lawson_adjoint_blocks(t_out, table.first, table.last, table.static, table.pieces,
                              table.lower, table.upper, polyT, referenceT,
                              np.ascontiguousarray(ET), np.ascontiguousarray(E2T),
                              discretisation.substeps, seed_y, seed_acc, G, Gs, W, states,
                              starts, steps is None)
        # z̈ at the first output: A at the first piece's start (its constant coefficient)
        G[0, 0] += np.outer(seed_acc[0], states[0])
        blocks = np.flatnonzero(table.static)
        if blocks.size:  # a static block's A is its piece's constant coefficient
            G[table.pieces[blocks], 0] += _static_weights(table, t_out, blocks, Gs, W, n)
        # J's derivative pairs ∂A/∂p with G through the table of ∂A/∂p on the run's
        # layout, which is linear in its samples: pair the samples instead, no table made
        times, weights = sample_weights(table, t_out, G)
        if pairing is None:
            gradient = np.einsum("tkij,tij->k", derivative_rows(times), weights)
        else:
            gradient = pairing(times, weights)
    return gradient, states


def _static_weights(table: CoefficientTable, t_out: np.ndarray, blocks: np.ndarray,
                    Gs: np.ndarray, W: np.ndarray, n: int) -> np.ndarray:
    """Per static block, the weight of its ∂A/∂p (n, 2n+1): Σ ∂J/∂z̈ yᵀ, plus the rows of
    A in Δt L(Δt Ãᵀ, W) (the pairing of W with the derivative of exp(Δt Ã))."""
    m = 2 * n + 1
    dt = (t_out[table.last[blocks]] - t_out[table.first[blocks]]) / (
        table.last[blocks] - table.first[blocks])
    X = np.swapaxes(augmented(table.reference[blocks]), 1, 2) * dt[:, None, None]
    # L is linear in W: W scaled to unit size, so that it does not set the exponential's
    # scaling and squaring
    size = np.maximum(np.abs(W[blocks]).max(axis=(1, 2)), 1e-300)
    big = np.zeros((blocks.size, 2 * m, 2 * m))
    big[:, :m, :m] = X
    big[:, m:, m:] = X
    big[:, :m, m:] = W[blocks] / size[:, None, None]
    frechet = expm(big)[:, :m, m:] * size[:, None, None]  # L(Δt Ãᵀ, W)
    return Gs[blocks] + dt[:, None, None] * frechet[:, n: 2 * n]
