"""What every integrator returns, and what the linear integrators take.

As scipy's ``solve_ivp`` returns one ``OdeResult`` whatever the method, every flexlink
integrator returns one `Solution`; the linear ones (Lawson, Magnus, scipy) take the system
they solve as one argument, any object of the `LinearSystem` protocol.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

Matrices = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
Progress = Callable[[float], None]
BLOW_UP = 1e8  # |state| beyond this (SI units) is a blow-up, not a motion of the model


@dataclass(frozen=True)
class Solution:
    """Coordinates q, rates q̇ and accelerations q̈ (each (nt, n)) at times t (s); the
    integrator that ran (``method``, which may differ from the one asked for after a
    fallback), its step statistics, and ``extra`` states of the run ((nt, m), e.g. servo
    integrals) when it has any."""

    t: np.ndarray
    q: np.ndarray
    q_dot: np.ndarray
    q_ddot: np.ndarray
    method: str
    stats: Mapping[str, float] = field(default_factory=dict)
    extra: np.ndarray | None = None

    def __post_init__(self) -> None:
        for name in ("q", "q_dot", "q_ddot"):
            if not np.all(np.isfinite(getattr(self, name))):
                from ..errors import SimulationError

                what = {"q": "coordinates", "q_dot": "rates", "q_ddot": "accelerations"}[name]
                raise SimulationError(f"{what} are not finite")


def rigid_solution(t: np.ndarray, method: str) -> Solution:
    """The solution of a system without coordinates (every link rigid, joints prescribed):
    nothing to integrate, arrays of shape (nt, 0)."""
    none = np.zeros((np.size(t), 0))
    return Solution(np.asarray(t, dtype=float), none, none, none, method)


class LinearSystem(Protocol):
    """M(t) q̈ + C(t) q̇ + K(t) q = f(t), coefficients at any time; q starts at rest."""

    @property
    def n(self) -> int:
        """Number of coordinates."""
        ...

    @property
    def max_frequency(self) -> float:
        """Highest natural frequency (rad/s): sets the first step."""
        ...

    def matrices(self, t: np.ndarray) -> Matrices:
        """M, C, K (nt, n, n) and f (nt, n) at times t (s)."""
        ...

    # Labels of instants t: equal labels ⇒ equal coefficients (rest phases); None: none equal.
    coefficient_keys: Callable[[np.ndarray], np.ndarray] | None

    def breakpoints(self) -> np.ndarray:
        """Times (s) where the coefficients are not smooth."""
        ...


@dataclass(frozen=True)
class GivenMatrices:
    """A `LinearSystem` from a function of time (tests, comparisons): no instants known to
    be equal, no breakpoints unless given."""

    function: Callable[[np.ndarray], Matrices]
    n: int
    max_frequency: float = 0.0
    breaks: tuple[float, ...] = ()
    coefficient_keys: Callable[[np.ndarray], np.ndarray] | None = None

    def matrices(self, t: np.ndarray) -> Matrices:
        return self.function(t)

    def breakpoints(self) -> np.ndarray:
        return np.asarray(self.breaks, dtype=float)
