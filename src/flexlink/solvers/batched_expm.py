"""Matrix exponentials of a stack of small matrices in a few vectorised calls.

scipy.linalg.expm accepts a stack but treats its matrices one by one in Python; for thousands of
17×17 Magnus propagators that loop dominated a run. This is the same algorithm — scaling and
squaring with a diagonal Padé approximant of degree 3, 5, 7, 9 or 13 chosen from the 1-norm
(Higham, SIAM J. Matrix Anal. Appl. 26, 2005) — with the degree chosen for the whole stack, the
number of squarings per matrix, and all arithmetic done on the whole stack.
"""

from __future__ import annotations

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


def expm_stack(A: np.ndarray) -> np.ndarray:
    """exp(A[i]) for a stack A of shape (m, d, d)."""
    A = np.asarray(A, dtype=float)
    if A.shape[0] == 0:
        return A.copy()
    norm = np.abs(A).sum(axis=1).max(axis=1)  # 1-norm of every matrix
    if not np.all(np.isfinite(norm)):
        raise FloatingPointError("matrix exponential of a non-finite matrix")
    degree = next((m for m, theta in _THETA.items() if norm.max() <= theta), 13)
    squarings = np.maximum(0, np.ceil(np.log2(np.maximum(norm, 1e-300) / _THETA[degree])))
    squarings = squarings.astype(int)
    X = A * np.ldexp(1.0, -squarings)[:, None, None]
    b = _COEFFICIENTS[degree]
    X2 = X @ X
    power = np.broadcast_to(np.eye(A.shape[1]), A.shape)
    odd = b[1] * power
    even = b[0] * power
    for i in range(1, degree // 2 + 1):  # X2^i contributes b_{2i} to V and b_{2i+1} to U
        power = power @ X2
        even = even + b[2 * i] * power
        odd = odd + b[2 * i + 1] * power
    U = X @ odd
    E = np.linalg.solve(even - U, even + U)
    for level in range(1, int(squarings.max()) + 1):
        needs = squarings >= level
        E[needs] = E[needs] @ E[needs]
    return E


def expm_balanced(omega: np.ndarray, n: int, scale: float) -> np.ndarray:
    """exp(Ω) for a stack of augmented generators Ω ~ h·[[0, I, 0], [−ω², ·, ·], [0, 0, 0]] of
    state [z (n), ż (n), 1]: computed as D⁻¹ exp(D Ω D⁻¹) D with D = diag(scale·I, I, 1) and
    scale ~ the highest natural frequency (rad/s). Unbalanced, the ω² entries make ‖Ω‖ ~ h·ω²
    and the exponential needs many squarings; balanced, ‖Ω‖ ~ h·ω."""
    d = np.concatenate([np.full(n, scale), np.ones(omega.shape[-1] - n)])
    E = expm_stack(omega * d[:, None] / d[None, :])
    return E * (1.0 / d)[:, None] * d[None, :]
