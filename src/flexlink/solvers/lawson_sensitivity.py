"""Forward sensitivities of a Lawson run: ∂(z, ż, z̈)/∂p on the run's own discretisation.

A prescribed first-order run solves ẏ = Ã(t; p) y, y = [z, ż, 1]. `integrate_lawson_on`
runs a system on a fixed `Discretisation` (the table layout, the steps per output interval
and the moving blocks' references Ã_ref with their propagators exp(h/2 Ã_ref)); at the run's
own parameters it reproduces the run. Its derivative in p is the same Lawson scheme applied
to the tangent s = ∂y/∂p, whose slope is Ã s + (∂Ã/∂p) y: each stage k_i = ΔÃ(t_i) s_i +
∂A/∂p(t_i) y_i, with y_i the run's own stages (the forcing of M z̈ + C ż + K z = f
differentiated: ∂f/∂p − ∂M/∂p z̈ − ∂C/∂p ż − ∂K/∂p z, here through A = M⁻¹[−K, −C, f]).
A static block (joints at rest, y⁺ = exp(Δt Ã) y) contributes the Fréchet derivative of its
exponential. So the sensitivities are the derivative of what the run computed, to round-off,
not an approximation of the continuous sensitivity (which they approach as the run's
tolerance does).

∂A/∂p is given as a function of time (``derivative_rows``), tabulated on the run's layout
like A itself: the table's polynomials are linear in their samples, so the table of ∂A/∂p
is the derivative of the table of A.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.linalg import expm

from ..errors import SimulationError
from .coefficient_table import CoefficientTable, tabulate_on
from .lawson import Discretisation, _block_propagators
from .magnus import augmented, state_rows
from .solution import FIXED_STEP, Accuracy, LinearSystem, Solution
from .threads import single_threaded

DerivativeRows = Callable[[np.ndarray], np.ndarray]  # times (nt,) → ∂A/∂p_k (nt, K, n, 2n+1)


def lawson_sensitivities(system: LinearSystem, derivative_rows: DerivativeRows,
                         t_out: np.ndarray, discretisation: Discretisation,
                         settled_system: bool = False
                         ) -> tuple[Solution, np.ndarray, np.ndarray, np.ndarray]:
    """The system's solution on ``discretisation`` (as `integrate_lawson_on`) and its
    derivatives ∂q, ∂q̇, ∂q̈ in each of K parameters, (K, nt, n) each, from rest at
    t_out[0]; ``derivative_rows``: ∂A/∂p_k of A = M⁻¹[−K, −C, f] at given times;
    ``settled_system``: the system is the one whose run settled the discretisation (its
    table is then the one the discretisation keeps)."""
    from ._lawson_sensitivity_numba import lawson_tangent_blocks

    n = system.n
    with single_threaded():
        table, reference, ET, E2T = steps_on(system, t_out, discretisation, settled_system)
        dtable = tabulate_on(derivative_rows, t_out, discretisation.layout,
                             moving_references=False)
        K = dtable.poly.shape[2]
        static = table.static
        PdT = _static_derivatives(table, dtable, t_out, n)
        m = 2 * n + 1
        polyT = np.ascontiguousarray(np.swapaxes(table.poly, 2, 3))
        pieces, coefficients = dtable.poly.shape[:2]
        dpolyT = np.ascontiguousarray(np.transpose(dtable.poly, (0, 1, 4, 2, 3))).reshape(
            pieces, coefficients, m, K * n)
        referenceT = np.ascontiguousarray(np.swapaxes(reference, 1, 2))
        states = np.empty((t_out.size, m))
        acc = np.empty((t_out.size, n))
        dstates = np.zeros((K, t_out.size, m))
        dacc = np.empty((K, t_out.size, n))
        lawson_tangent_blocks(t_out, table.first, table.last, static, table.pieces,
                              table.lower, table.upper, polyT, dpolyT, referenceT,
                              np.ascontiguousarray(ET), np.ascontiguousarray(E2T), PdT,
                              discretisation.substeps, states, acc, dstates, dacc)
    y0 = states[0]
    acc[0] = table.poly[0, 0] @ y0
    dacc[:, 0] = dtable.poly[0, 0] @ y0
    for b in np.flatnonzero(static):
        a, e = table.first[b] + 1, table.last[b] + 1
        A, dA = table.reference[b], dtable.reference[b]
        acc[a:e] = states[a:e] @ A.T
        # written in place, a parameter at a time: no (K, steps, n) temporaries
        np.matmul(dstates[:, a:e], A.T, out=dacc[:, a:e])
        for k in range(dA.shape[0]):
            dacc[k, a:e] += states[a:e] @ dA[k].T
    if not (np.all(np.isfinite(states)) and np.all(np.isfinite(dstates))):
        raise SimulationError("the state or its sensitivities became non-finite")
    stats = {"steps_per_output_interval": discretisation.substeps, "table_blocks": len(table)}
    solution = Solution(t_out, states[:, :n], states[:, n: 2 * n], acc, "lawson", stats,
                        accuracy=Accuracy(discretisation.rtol, None, FIXED_STEP))
    return solution, dstates[:, :, :n], dstates[:, :, n: 2 * n], dacc


def steps_on(system: LinearSystem, t_out: np.ndarray, discretisation: Discretisation,
             settled_system: bool = False
             ) -> tuple[CoefficientTable, np.ndarray, np.ndarray, np.ndarray]:
    """The system's table on the discretisation's layout, each block's reference (the
    settled one on moving blocks, the system's own on static ones) and the propagators the
    steps read, transposed: E = exp(h/2 Ã_ref) and E² on moving blocks, exp(Δt Ã) on static
    ones (E² unused there). ``settled_system``: the system whose run settled the
    discretisation, whose table it keeps (the same numbers as tabulating it anew)."""
    n = system.n
    rows = getattr(system, "state_rows", None) or (
        lambda times: state_rows(system.matrices, times))
    table = discretisation.table if settled_system else None
    if table is None:
        table = tabulate_on(rows, t_out, discretisation.layout)
    static = table.static
    reference = np.where(static[:, None, None], table.reference, discretisation.reference)
    ET = discretisation.propagators.copy()
    # the settling run's own table: its static blocks' exp(Δt Ã) are the run's (the same
    # arguments); another system's are its own
    if static.any() and table is not discretisation.table:
        ET[static] = _block_propagators(table, n, t_out, discretisation.substeps, static)
    E2T = ET.copy()
    E2T[~static] = ET[~static] @ ET[~static]
    return table, reference, ET, E2T


def _static_derivatives(table: CoefficientTable, dtable: CoefficientTable, t_out: np.ndarray,
                        n: int) -> np.ndarray:
    """Per parameter and block, transposed (K, blocks, m, m): on a static block the
    derivative of its propagator exp(Δt Ã) in the direction Δt ∂Ã/∂p (the Fréchet
    derivative: the upper right block of exp([[Ã, ∂Ã], [0, Ã]] Δt)), zero on moving blocks."""
    K = dtable.poly.shape[2]
    m = 2 * n + 1
    out = np.zeros((K, len(table), m, m))
    blocks = np.flatnonzero(table.static)
    if blocks.size == 0:
        return out
    dt = (t_out[table.last[blocks]] - t_out[table.first[blocks]]) / (
        table.last[blocks] - table.first[blocks])
    big = np.zeros((blocks.size, K, 2 * m, 2 * m))
    A = augmented(table.reference[blocks]) * dt[:, None, None]
    big[:, :, :m, :m] = A[:, None]
    big[:, :, m:, m:] = A[:, None]
    big[:, :, n: 2 * n, m:] = dtable.reference[blocks] * dt[:, None, None, None]
    frechet = expm(big.reshape(-1, 2 * m, 2 * m))[:, :m, m:].reshape(blocks.size, K, m, m)
    out[:, blocks] = np.swapaxes(np.swapaxes(frechet, 0, 1), 2, 3)
    return out
