"""The step controller of the implicit integrators, written once and compiled (numba): the
error norm with per-component weights, the step-size factor (safety, shrink and growth
limits, Gustafsson's predictive variant), and the rule that keeps a step size (and so its
factorised iteration matrices) when the factor is near one. Radau IIA (`_radau_numba.
radau_advance`) and the Gauss collocation's step doubling (`_gauss_numba.gauss_doubling`,
`gauss_steps.step_doubling`) both use it; what differs between them is only the order of
their error estimates (the factor's exponent) and how far one step may grow.

Error norm: component i's error e_i counts as w_i |e_i| / (atol + rtol · max(|y_i|, P_g)),
g its group, P_g the running peak of |y| over the group's components (raised to
floor_ratio · P_f, f = floor_of[g], when that group has a floor: a velocity group at rest
in static equilibrium gets its tolerance from its coordinates), and the step's error is the
largest of these (a max norm: the few components that move are not diluted by the many that
do not). w_i are the per-component error weights (1: the plain relative error; the modal
weights of elastic coordinates, `solvers/error_weights.py`); a component of group −1 sets no
step.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation

SAFETY = 0.9
SHRINK = 0.2  # the smallest factor h_new / h
KEEP_LOW, KEEP_HIGH = 1.0, 1.2  # factors in this band keep h and its factorisations

StepControl = namedtuple("StepControl", [
    "group", "weight", "peak", "floor_of", "floor_ratio", "rtol", "atol", "exponent", "grow"])
StepControl.__doc__ = (
    "The step controller's record: each component's group (int64, −1: none) and error weight, "
    "each group's running peak |y| (updated in place), the group whose peak floors it (int64, "
    "−1: none) and the floor's ratio (1/s for rates floored by coordinates), rtol, atol, the "
    "factor's exponent (1 / (order of the error estimate + 1)) and the largest factor.")


def step_control(group: np.ndarray, weight: np.ndarray | None, groups: int, rtol: float,
                 atol: float, exponent: float, grow: float,
                 floor_of: np.ndarray | None = None, floor_ratio: float = 0.0) -> StepControl:
    """A StepControl of fixed field types (one compiled signature) with zero peaks; ``groups``
    the number of groups, ``weight`` None: all ones."""
    group = np.ascontiguousarray(group, dtype=np.int64)
    weight = (np.ones(group.size) if weight is None
              else np.ascontiguousarray(weight, dtype=np.float64))
    if weight.shape != group.shape:
        raise ValueError(f"error weights: {weight.size} for {group.size} components")
    groups = max(int(groups), 1)
    floors = (np.full(groups, -1, dtype=np.int64) if floor_of is None
              else np.ascontiguousarray(floor_of, dtype=np.int64))
    return StepControl(group, weight, np.zeros(groups), floors, float(floor_ratio),
                       float(rtol), float(atol), float(exponent), float(grow))


@njit(cache=True)
def update_peaks(control, y):
    """Raise each group's peak to the largest |y_i| of its components."""
    group, peak = control.group, control.peak
    for i in range(y.shape[0]):
        g = group[i]
        if g >= 0 and abs(y[i]) > peak[g]:
            peak[g] = abs(y[i])


@njit(cache=True)
def tolerances(control, y, scal):
    """scal_i = atol + rtol · max(|y_i|, the peak of i's group): the unweighted tolerance of
    each component (Newton's convergence test takes it as it is)."""
    group, peak, floor_of = control.group, control.peak, control.floor_of
    for i in range(y.shape[0]):
        g = group[i]
        top = abs(y[i])
        if g >= 0:
            top = max(top, peak[g])
            f = floor_of[g]
            if f >= 0:
                top = max(top, control.floor_ratio * peak[f])
        scal[i] = control.atol + control.rtol * top


@njit(cache=True)
def error_norm(control, e, scal):
    """max_i w_i |e_i| / scal_i over the components of a group (0 where e_i vanishes: a
    state still at rest)."""
    group, weight = control.group, control.weight
    acc = 0.0
    for i in range(e.shape[0]):
        if group[i] < 0 or e[i] == 0.0:
            continue
        acc = max(acc, weight[i] * abs(e[i]) / scal[i] if scal[i] > 0.0 else np.inf)
    return acc


@njit(cache=True)
def step_factor(control, err, safety):
    """h_new / h for a step of error ``err`` (fraction of its tolerance): safety · err^−k,
    between SHRINK and control.grow (``safety`` at most SAFETY; Radau IIA lowers it when
    Newton needed many iterations)."""
    if err <= 0.0:
        return control.grow
    return max(SHRINK, min(control.grow, safety * err ** -control.exponent))


@njit(cache=True)
def predictive_factor(control, factor, err, h, h_last, err_last):
    """Gustafsson's predictive factor for an accepted step of h (s) and error err after an
    accepted step of h_last and err_last: the smaller of it and ``factor``, within the
    limits (it damps the oscillation of the step size that a plain factor shows where the
    error is nearly the tolerance)."""
    if err <= 0.0 or err_last <= 0.0:
        return factor
    gus = SAFETY * (h / h_last) * (err_last / (err * err)) ** control.exponent
    return min(factor, max(SHRINK, min(control.grow, gus)))


@njit(cache=True)
def next_factor(control, err, safety, rejected_before):
    """h_new / h after a step of error err: below SAFETY (at most) when the step is rejected
    (err > 1), and no growth on the first accepted step after a rejection."""
    factor = step_factor(control, err, safety)
    if err > 1.0:
        return min(factor, SAFETY)
    if rejected_before:
        return min(factor, 1.0)
    return factor


@njit(cache=True)
def keeps(factor):
    """Whether h stays as it is (its factorisations with it): a factor in [KEEP_LOW,
    KEEP_HIGH] would buy too little to pay for new ones."""
    return KEEP_LOW <= factor <= KEEP_HIGH
