"""Matrix exponentials of a stack of small matrices in a few vectorised calls.

scipy.linalg.expm accepts a stack but treats its matrices one by one in Python; for thousands of
17×17 Magnus propagators that loop dominated a run. This is the same algorithm — scaling and
squaring with a diagonal Padé approximant of degree 3, 5, 7, 9 or 13 chosen from the 1-norm
(Higham, SIAM J. Matrix Anal. Appl. 26, 2005) — with the degree chosen for the whole stack, the
number of squarings per matrix, and all arithmetic done on the whole stack.
"""

from __future__ import annotations

from collections.abc import Sequence
from math import factorial

import numpy as np

# Largest 1-norm for which the [m/m] approximant is accurate to double precision (Higham 2005).
_THETA = {3: 1.495585217958292e-2, 5: 2.539398330063230e-1, 7: 9.504178996162932e-1,
          9: 2.097847961257068e0, 13: 5.371920351148152e0}


def _pade_coefficients(m: int) -> list[float]:
    """b_j of the [m/m] Padé approximant of exp: b_j = (2m−j)! m! / ((2m)! j! (m−j)!)."""
    return [factorial(2 * m - j) * factorial(m) / (factorial(2 * m) * factorial(j)
                                                    * factorial(m - j)) for j in range(m + 1)]


_COEFFICIENTS = {m: _pade_coefficients(m) for m in _THETA}


def expm_stack(A: np.ndarray, degree: int | None = None) -> np.ndarray:
    """exp(A[i]) for a stack A of shape (m, d, d); ``degree``: the Padé degree (default:
    the one the stack's largest 1-norm needs, `pade_degree`)."""
    A = np.asarray(A, dtype=float)
    if A.shape[0] == 0:
        return A.copy()
    norm = np.abs(A).sum(axis=1).max(axis=1)  # 1-norm of every matrix
    if not np.all(np.isfinite(norm)):
        raise FloatingPointError("matrix exponential of a non-finite matrix")
    degree = degree or next((m for m, theta in _THETA.items() if norm.max() <= theta), 13)
    squarings = np.maximum(0, np.ceil(np.log2(np.maximum(norm, 1e-300) / _THETA[degree])))
    squarings = squarings.astype(int)
    X = A * np.ldexp(1.0, -squarings)[:, None, None]
    U, V = _pade_terms(X, degree)
    P, Q = V + U, V - U
    E = np.linalg.solve(Q, P)
    for level in range(1, int(squarings.max()) + 1):
        needs = squarings >= level
        E[needs] = E[needs] @ E[needs]
    return E


def _pade_terms(X: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """U (odd part) and V (even part) of the [m/m] Padé approximant at X, exp(X) ≈ (V − U)⁻¹
    (V + U), with the fewest products (Higham 2005, §2): the even powers X², X⁴, … for m ≤ 9
    (m/2 + 1 products), X², X⁴, X⁶ and three more for m = 13 (6 instead of 8). The identity
    terms go on the diagonal only."""
    b = _COEFFICIENTS[degree]
    diagonal = np.arange(X.shape[1])
    X2 = X @ X
    if degree == 13:
        X4 = X2 @ X2
        X6 = X4 @ X2
        inner = X6 @ (b[13] * X6 + b[11] * X4 + b[9] * X2) + b[7] * X6 + b[5] * X4 + b[3] * X2
        inner[:, diagonal, diagonal] += b[1]
        V = X6 @ (b[12] * X6 + b[10] * X4 + b[8] * X2) + b[6] * X6 + b[4] * X4 + b[2] * X2
        V[:, diagonal, diagonal] += b[0]
        return X @ inner, V
    odd = b[3] * X2
    even = b[2] * X2
    power = X2
    for i in range(2, degree // 2 + 1):  # X2^i contributes b_{2i} to V and b_{2i+1} to U
        power = power @ X2
        even += b[2 * i] * power
        odd += b[2 * i + 1] * power
    odd[:, diagonal, diagonal] += b[1]
    even[:, diagonal, diagonal] += b[0]
    return X @ odd, even


def pade_degree(A: np.ndarray) -> int:
    """The Padé degree `expm_stack` chooses for the stack A (m, d, d)."""
    norm = np.abs(A).sum(axis=1).max(axis=1)
    top = norm.max() if norm.size else 0.0
    return next((m for m, theta in _THETA.items() if top <= theta), 13)


def expm_balanced_many(stacks: Sequence[tuple[np.ndarray, int, float]]) -> list[np.ndarray]:
    """`expm_balanced` of each (Ω, n, scale), the stacks that need the same Padé degree in
    one `expm_stack` call: numpy multiplies and solves each matrix of a stack on its own and
    the squarings are per matrix, so each result equals its own call's bit for bit, for
    fewer numpy calls."""
    balanced, ratios = [], []
    for omega, n, scale in stacks:
        ratio = _balancing(omega.shape[-1], n, scale)
        balanced.append(omega * ratio)
        ratios.append(ratio)
    degrees = [pade_degree(b) for b in balanced]
    out: list[np.ndarray] = [np.empty(0)] * len(stacks)
    for degree in set(degrees):
        members = [i for i, d in enumerate(degrees) if d == degree]
        E = expm_stack(np.concatenate([balanced[i] for i in members]), degree)
        ends = np.cumsum([balanced[i].shape[0] for i in members])
        for i, part in zip(members, np.split(E, ends[:-1])):
            out[i] = part * ratios[i].T
    return out


def _balancing(size: int, n: int, scale: float) -> np.ndarray:
    """D_i / D_j of `expm_balanced`'s D = diag(scale·I, I, 1) (size entries, n scaled)."""
    d = np.concatenate([np.full(n, scale), np.ones(size - n)])
    return d[:, None] / d[None, :]


def expm_balanced(omega: np.ndarray, n: int, scale: float) -> np.ndarray:
    """exp(Ω) for a stack of augmented generators Ω ~ h·[[0, I, 0], [−ω², ·, ·], [0, 0, 0]] of
    state [z (n), ż (n), 1]: computed as D⁻¹ exp(D Ω D⁻¹) D with D = diag(scale·I, I, 1) and
    scale ~ the highest natural frequency (rad/s). Unbalanced, the ω² entries make ‖Ω‖ ~ h·ω²
    and the exponential needs many squarings; balanced, ‖Ω‖ ~ h·ω."""
    ratio = _balancing(omega.shape[-1], n, scale)  # one pass over the stack each way
    E = expm_stack(omega * ratio)
    return E * ratio.T
