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


# What an Accuracy's estimate measures (its ``measure``), by integrator family.
RICHARDSON = ("Richardson: the largest |y_h − y_2h| / 15 of two runs with steps h and 2h at "
              "the output times, relative to the peak of the coordinates and of their rates")
STEP_DOUBLING = ("step doubling: the largest local error of one step, |two steps h/2 − one "
                 "step h| / 15, relative to the peak of the coordinates and of their rates "
                 "so far")
FIXED_STEP = "none: a fixed step (simulation.step), no error estimate"
LOCAL_CONTROL = ("none reported: Radau IIA keeps each step's local error (its embedded "
                 "estimate) such that the global error of the coordinates and rates stays near "
                 "rtol of their peaks (measured 0.65–0.93 rtol: benchmarks/forward_integrators.py)")
SCIPY = "none: scipy solve_ivp controls its local error by rtol and atol, without a reported estimate"


@dataclass(frozen=True)
class StepReach:
    """How far the bounded combinations of an integrator's state went over every step it
    took, not only at the output times (`tip_bounds`: each link's tip deflection
    over its length): ``peak`` (r,) the largest magnitude of each, ``beyond`` (r,) the end
    time (s) of its first step whose magnitude exceeded 1 (inf where none did)."""

    peak: np.ndarray
    beyond: np.ndarray


def unreached(bounds: np.ndarray | None) -> StepReach | None:
    """The reach of ``bounds`` (r, m) before any step (`StepReach`: peak 0, none beyond),
    which the integrators update in place; None without bounds."""
    if bounds is None:
        return None
    return StepReach(np.zeros(bounds.shape[0]), np.full(bounds.shape[0], np.inf))


def tip_bounds(system: object) -> np.ndarray | None:
    """The system's rows over the augmented state [w, ẇ, 1] whose magnitude exceeds 1 where
    a link's tip deflects beyond its length (``tip_bounds()`` of a first-order system; None
    for a system without them): the linear integrators read them at every step."""
    rows = getattr(system, "tip_bounds", None)
    return None if rows is None else np.ascontiguousarray(rows(), dtype=float)


@dataclass(frozen=True)
class Accuracy:
    """What an integrator was asked for and what its own error estimate reached: ``rtol``
    the tolerance requested, ``estimate`` the estimate of the run it returned (a fraction of
    the peak, as rtol; None where the integrator makes none), ``measure`` what the estimate
    is (one of this module's texts)."""

    rtol: float
    estimate: float | None
    measure: str


@dataclass(frozen=True)
class Solution:
    """Coordinates q, rates q̇ and accelerations q̈ (each (nt, n)) at times t (s); the
    integrator that ran (``method``, which may differ from the one asked for after a
    fallback), its step statistics, ``extra`` states of the run ((nt, m), e.g. servo
    integrals) when it has any, its ``accuracy`` (the tolerance asked for and the error
    estimate reached) when it integrated anything, and its ``reach`` over every step where
    the integrator keeps one (`StepReach`)."""

    t: np.ndarray
    q: np.ndarray
    q_dot: np.ndarray
    q_ddot: np.ndarray
    method: str
    stats: Mapping[str, float] = field(default_factory=dict)
    extra: np.ndarray | None = None
    accuracy: Accuracy | None = None
    reach: StepReach | None = None

    def __post_init__(self) -> None:
        for name in ("q", "q_dot", "q_ddot"):
            if not all_finite(getattr(self, name)):
                from ..errors import SimulationError

                what = {"q": "coordinates", "q_dot": "rates", "q_ddot": "accelerations"}[name]
                raise SimulationError(f"{what} are not finite")


def all_finite(values: np.ndarray) -> bool:
    """Whether every entry of ``values`` is finite. A 2-D float array by one product with
    ones: a NaN or an infinity makes its row's sum non-finite, and BLAS reads a column slice
    of a wider array (a solver's states) at full speed where ``np.isfinite`` of it costs
    ~4× more; a non-finite sum of finite entries (an overflow) is told apart element-wise."""
    values = np.asarray(values)
    if values.ndim == 2 and values.dtype == np.float64:
        with np.errstate(all="ignore"):  # the overflow, or the NaN, is the answer
            if np.isfinite(values @ np.ones(values.shape[1])).all():
                return True
    return bool(np.all(np.isfinite(values)))


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
