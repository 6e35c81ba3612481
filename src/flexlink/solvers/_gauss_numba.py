"""Compiled (numba) step loops of the Gauss collocation for both nonlinear models — the same
algorithm as the numpy loop in ``gauss.py`` (which the tests compare them with), without
Python overhead per step: the Newton stage solver (`solve_stages`), the uniform-step loop
(`gauss_loop`) and the step-doubling loop (`gauss_doubling`), each written once.

The model is its residual, reached through `model_residual` from the ``model`` that
`residual_model` makes of its kernel-data record ``d`` (`dynamics/nonlinear_kernel.py`):
(address of the record type's residual trampoline, context, d.n), the context holding the
record, as `_radau_model` does for Radau IIA (`_TRAMPOLINES`: NonlinearData → the
prescribed-joint residual, NonlinearForwardData → the residual with rigid coordinates). The
loops' types do not depend on the model, so each is
compiled (and cached on disk) once for both models, without the model's code inside. Stage
inputs are a `StageInputs` record of rows, two per step (six per doubled step); the
tableau, Newton's settings and the step control are records of `gauss_steps.py`.

Why numba: one step costs a few small matrix–vector products (~10⁴ flops); in numpy each call
costs more in dispatch than in arithmetic, an order of magnitude more per Newton iteration
than the compiled loop (benchmarks/nonlinear_vs_fe.py).
"""

from __future__ import annotations

import struct
from typing import Any

import numpy as np
from numba import njit, typeof, types
from numba.extending import intrinsic

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from .._compiled_calls import borrowed, stack_array
from ..dynamics._nonlinear_forward_numba import residual as forward_residual
from ..dynamics._nonlinear_numba import residual as prescribed_residual
from ..dynamics.nonlinear_kernel import NonlinearData, NonlinearForwardData
from ._radau_model import (
    CONTEXT,
    ROW,
    _address,
    _call_codegen,
    _check,
    _layout,
    _load,
    _pack,
    _type_key,
)
from ._step_control_numba import error_norm, tolerances, update_peaks

# `solve_stages`' ``which`` (the caller's first or second iteration matrix) as int64 values,
# not literals: numba compiles a function once per literal value, so callers passing 0 and 1
# compiled it twice
MATRIX_0, MATRIX_1 = np.int64(0), np.int64(1)
_ROWS = (ROW,) * 9  # Y, V, X, ang, rate, acc, rot_acc, u, out: every row a residual takes


def residual_model(d: Any) -> tuple[int, np.ndarray, int]:
    """The ``model`` argument of the compiled loops for kernel data ``d``: (address of the
    residual trampoline of d's record type, context, d.n elastic coordinates). ``d`` must
    outlive every use of it (the context borrows its arrays)."""
    trampoline = _TRAMPOLINES.get(type(d))
    if trampoline is None:
        raise TypeError(f"no compiled residual for kernel data {type(d).__name__}: add its "
                        "record class and trampoline to _gauss_numba._TRAMPOLINES")
    records = (d,)
    key = _type_key(records)
    found = _MODELS.get(key)
    if found is None:
        found = _MODELS[key] = _address_of(trampoline, records)
    address, fields = found
    return address, _pack(records, fields, (0, 0)), int(d.n)


# _type_key(records) → the trampoline's address and the records' layout: numba's typeof of a
# record of dozens of arrays costs milliseconds, more than a short run's step loop
_MODELS: dict[Any, tuple[int, struct.Struct]] = {}


def _address_of(trampoline: Any, records: tuple) -> tuple[int, struct.Struct]:
    """The address of ``trampoline`` compiled for these records' types, and the records'
    `_layout`."""
    records_type = typeof(records)
    return (_address(trampoline, (CONTEXT,) + _ROWS + (types.TypeRef(records_type),)),
            _layout(records_type))


@intrinsic
def _call_residual_from(typingctx, address, context, Y, V, X, ang, rate, acc, rot_acc, u,
                        out):
    """The residual trampoline (`_prescribed_from`, `_forward_from`) at ``address``."""
    _check("the residual trampoline", (context, Y, V, X, ang, rate, acc, rot_acc, u, out),
           (CONTEXT,) + _ROWS)
    return (types.none(address, context, Y, V, X, ang, rate, acc, rot_acc, u, out),
            _call_codegen(1))


# One trampoline per model, calling its residual by name: a generic trampoline calling the
# residual through an address hands it the whole record, hundreds of words, at every call,
# a sixth of the residual's time (1.09 against 0.91 µs on Case 23's slider, 6 modes). Neither
# counts references (no runtime): it only passes arrays on.
@njit(cache=True, _nrt=False)
def _prescribed_from(context, Y, V, X, ang, rate, acc, rot_acc, u, out, records_type):
    """The residual of one state into ``out`` for the prescribed-joint model whose record
    (NonlinearData) the context holds (its type given)."""
    (d,) = _load(context, records_type)
    prescribed_residual(d, Y, V, X, ang, rate, acc, rot_acc, u, out)


@njit(cache=True, _nrt=False)
def _forward_from(context, Y, V, X, ang, rate, acc, rot_acc, u, out, records_type):
    """The residual of one state into ``out`` for the model with rigid coordinates whose
    record (NonlinearForwardData) the context holds (its type given)."""
    (d,) = _load(context, records_type)
    forward_residual(d, Y, V, X, ang, rate, acc, rot_acc, u, out)


# kernel-data record class → the trampoline of its compiled residual
_TRAMPOLINES = {NonlinearData: _prescribed_from, NonlinearForwardData: _forward_from}


@njit(inline="always")
def model_residual(model, Y, V, X, ang, rate, acc, rot_acc, u, out):
    """The residual of one state into ``out`` for ``model`` (`residual_model`)."""
    _call_residual_from(model[0], model[1], Y, V, X, ang, rate, acc, rot_acc, u, out)


@njit(cache=True)
def stage_partials(model, rows, r, Q, V, X, partials):
    """The residual's partial derivatives at one stage state Q, V, X (stage inputs in row r)
    into ``partials`` (n, 3n) = [∂R/∂q | ∂R/∂q̇ | ∂R/∂q̈]: forward differences in q and q̇,
    unit steps in q̈ (exact: R is affine in q̈)."""
    n = Q.size
    angle, rate, acc, rot, u = _borrowed_rows(rows)
    eps = 1e-7
    r0 = stack_array(n)
    r1 = stack_array(n)
    Qp = stack_array(n)
    Vp = stack_array(n)
    Xp = stack_array(n)
    for m in range(n):
        Qp[m], Vp[m], Xp[m] = Q[m], V[m], X[m]
    model_residual(model, Q, V, X, angle[r], rate[r], acc[r], rot[r], u[r], r0)
    for m in range(n):
        Qp[m] += eps
        model_residual(model, Qp, V, X, angle[r], rate[r], acc[r], rot[r], u[r], r1)
        Qp[m] = Q[m]
        for i in range(n):
            partials[i, m] = (r1[i] - r0[i]) / eps
        Vp[m] += eps
        model_residual(model, Q, Vp, X, angle[r], rate[r], acc[r], rot[r], u[r], r1)
        Vp[m] = V[m]
        for i in range(n):
            partials[i, n + m] = (r1[i] - r0[i]) / eps
        Xp[m] += 1.0
        model_residual(model, Q, V, Xp, angle[r], rate[r], acc[r], rot[r], u[r], r1)
        Xp[m] = X[m]
        for i in range(n):
            partials[i, 2 * n + m] = r1[i] - r0[i]


@njit(cache=True)
def iteration_inverse(partials, shared, h, tab, inverse):
    """The inverse of the stage system's iteration matrix for steps of h (s) into ``inverse``
    (2n, 2n): J_ij = h² (a²)_ij ∂R_i/∂q + h a_ij ∂R_i/∂q̇ + δ_ij ∂R_i/∂q̈ (stages i, j), the
    partials (`stage_partials`) of stage i in partials[i] (2, n, 3n), or partials[0] for
    both when ``shared``."""
    n = partials.shape[1]
    coeffs, coeffs2 = tab.coeffs, tab.coeffs2
    Jm = np.empty((2 * n, 2 * n))
    for st in range(2):
        p = partials[0] if shared else partials[st]
        for j in range(2):
            cq = h * h * coeffs2[st, j]
            cv = h * coeffs[st, j]
            cx = 1.0 if st == j else 0.0
            for i in range(n):
                for m in range(n):
                    Jm[st * n + i, j * n + m] = (cq * p[i, m] + cv * p[i, n + m]
                                                 + cx * p[i, 2 * n + m])
    inverse_h = np.linalg.inv(Jm)
    for i in range(2 * n):
        for j in range(2 * n):
            inverse[i, j] = inverse_h[i, j]


@njit(cache=True)
def solve_stages(model, rows, k, y0, v0, X, h, tab, newton, inverse, have, which, partials,
                 counts, peak):
    """The stage accelerations X (2, n) of one step of h (s) from y0, v0, solved in place by
    simplified Newton from the guess in X; stage inputs in rows k, k + 1.

    ``inverse`` (2n, 2n) is the iteration matrix for h (`iteration_inverse`), assembled
    again when ``have[which]`` is 0 from the partial derivatives ``partials`` (2, n, 3n) of
    each stage's residual at its iterate (with newton.shared_partials the first stage's
    only, for both), which are evaluated again (`stage_partials`) when ``have[-1]`` is 0 or
    when an iteration's contraction rate exceeds newton.slow_contraction; ``have``
    (k + 1,) flags each of the caller's k matrices (one per step size it keeps) and, last, the
    partials: an evaluation clears every matrix's flag. A caller may keep the partials
    across step sizes (the matrices' inverses cost no residual).

    Newton stops when its remaining error (the last correction times θ/(1 − θ), θ the
    contraction rate; the first correction itself) is within newton.tol of the largest
    stage acceleration (and of ``peak[0]``, the largest of the run so far, kept up to date
    when newton.running_peak: a rigid arm coasting has vanishing accelerations that no
    elastic term keeps finite) or within newton.floor (1/s²) · max|q| (the first model[2]
    unknowns, the elastic coordinates): the round-off of the elastic forces (at a static
    equilibrium under a constant load the accelerations vanish and no relative test can be
    met), or within newton.state_round_off · max|y| / h² (every unknown, rigid ones too): a
    correction that moves no stage position beyond its round-off (a chain of rigid links in
    exact equilibrium has no elastic coordinate to set the floor). counts[0] += evaluations
    of the partials, counts[1] += iterations. Returns whether it converged."""
    n = y0.size
    nodes, coeffs, coeffs2 = tab.nodes, tab.coeffs, tab.coeffs2
    # the residual's arguments uncounted, on the stack or borrowed from the caller's
    angle, rates, acc, rot, u = _borrowed_rows(rows)
    X = borrowed(X)
    last = have.size - 1
    Q = stack_array((2, n))
    V = stack_array((2, n))
    R = stack_array(2 * n)
    r0 = stack_array(n)
    previous = np.inf
    fresh = False
    q_size = 0.0
    for m in range(model[2]):
        q_size = max(q_size, abs(y0[m]))
    state_floor = 0.0
    for m in range(n):
        state_floor = max(state_floor, abs(y0[m]))
    state_floor *= newton.state_round_off / (h * h)
    for _ in range(newton.max_iterations):
        counts[1] += 1
        for st in range(2):
            # (explicit loops, here and below: an array assigned to a slice links numba's
            # shape-mismatch error into the kernel, several times its compile time)
            for m in range(n):
                V[st, m] = v0[m] + h * (coeffs[st, 0] * X[0, m] + coeffs[st, 1] * X[1, m])
                Q[st, m] = y0[m] + nodes[st] * h * v0[m] + h * h * (coeffs2[st, 0] * X[0, m]
                                                                    + coeffs2[st, 1] * X[1, m])
        if have[last] == 0:
            for st in range(1 if newton.shared_partials else 2):
                stage_partials(model, rows, k + st, Q[st], V[st], X[st], partials[st])
            for i in range(last + 1):
                have[i] = 0
            have[last] = 1
            fresh = True
            counts[0] += 1
        if have[which] == 0:
            iteration_inverse(partials, newton.shared_partials, h, tab, inverse)
            have[which] = 1
        for st in range(2):
            r = k + st
            model_residual(model, Q[st], V[st], X[st], angle[r], rates[r], acc[r], rot[r], u[r],
                           r0)
            for m in range(n):
                R[st * n + m] = r0[m]
        size = 0.0
        largest = 0.0
        for st in range(2):
            for m in range(n):
                i = st * n + m
                dx = 0.0
                for j in range(2 * n):
                    dx += inverse[i, j] * R[j]
                X[st, m] -= dx
                size = max(size, abs(dx))
                largest = max(largest, abs(X[st, m]))
        theta = size / previous
        # (first iteration: no rate yet, the increment itself must be small)
        remaining = size * theta / (1.0 - theta) if 0.0 < theta < 1.0 else size
        if remaining <= (newton.tol * max(largest, peak[0], 1e-300) + newton.floor * q_size
                         + state_floor):
            if newton.running_peak:
                peak[0] = max(peak[0], largest)
            return True
        if theta > newton.slow_contraction and not fresh:
            have[last] = 0
        previous = size
        fresh = False
    return False


@njit(inline="always")
def _borrowed_rows(rows):
    """The stage input rows' arrays (a StageInputs), borrowed (`borrowed`)."""
    angle, rate, acc, rot, u = rows
    return borrowed(angle), borrowed(rate), borrowed(acc), borrowed(rot), borrowed(u)


@njit(cache=True)
def _advance(y0, v0, X, h, tab, y1, v1):
    """The step's end y1, v1 from its start y0, v0 and stage accelerations X (2, n)."""
    w, w2 = tab.weights, tab.weights2
    for m in range(v0.size):  # (loops: see solve_stages)
        v1[m] = v0[m] + h * (w[0] * X[0, m] + w[1] * X[1, m])
        y1[m] = y0[m] + h * v0[m] + h * h * (w2[0] * X[0, m] + w2[1] * X[1, m])


@njit(cache=True)
def gauss_loop(model, rows, y, v, X, h, tab, newton, predict_first, peak):
    """Advance y, v (steps+1, n) in place from row 0 by uniform steps h (s); X (2, n) holds
    the stage accelerations of the step before (extrapolated first if ``predict_first``,
    else the guess itself). Stage inputs: two rows per step; ``peak`` as in
    `solve_stages`. Returns (failed step or −1, matrix rebuilds, Newton iterations)."""
    n = y.shape[1]
    steps = y.shape[0] - 1
    nodes = tab.nodes
    inverse = np.zeros((2 * n, 2 * n))
    have = np.zeros(2, np.int64)
    partials = np.empty((2, n, 3 * n))
    counts = np.zeros(2, np.int64)
    for i in range(steps):
        if i > 0 or predict_first:
            for m in range(n):
                slope = (X[1, m] - X[0, m]) / (nodes[1] - nodes[0])
                X[0, m] += slope
                X[1, m] += slope
        if not solve_stages(model, rows, 2 * i, y[i], v[i], X, h, tab, newton, inverse, have,
                            MATRIX_0, partials, counts, peak):
            return i, counts[0], counts[1]
        _advance(y[i], v[i], X, h, tab, y[i + 1], v[i + 1])
    return -1, counts[0], counts[1]


@njit(cache=True)
def gauss_doubling(model, rows, y, v, X, h_prev, H, tab, newton, control, errors, inverse, have,
                   partials, counts, peak, every=1):
    """Advance y, v (count+1, n) in place from row 0 by steps H, checked by step doubling:
    one step H and two steps H/2 from the same state, the two H/2 steps kept
    (``step_doubling`` in gauss_steps.py). Steps 0, ``every``, 2·``every``, … are checked;
    the others are their two H/2 steps alone (error 0), Newton's guess for the first
    extrapolated from the step before. Stage inputs: six rows per step (the H step's two
    stages, then the two H/2 steps'; an unchecked step reads the last four). X (2, n): the
    stage accelerations of the last step, of length h_prev (s), on return those of the last
    accepted step. ``control``: a `gauss_steps.step_control`; ``errors`` (count,): each
    step's error as a fraction of its tolerance (doubling_error). ``inverse`` (2, 2n, 2n),
    ``have`` (3,) and ``partials`` (2, n, 3n): the iteration matrices for H and H/2, kept
    across calls while H is unchanged, and the partial derivatives they are assembled from
    (`solve_stages`); ``peak`` as in `solve_stages`. Returns (status, accepted steps):
    status 0 all accepted, 1 a step's error above its tolerance, 2 a step whose Newton
    iteration did not converge."""
    n = y.shape[1]
    count = y.shape[0] - 1
    nodes = tab.nodes
    big = np.empty((2, n))
    fine = np.empty((2, n))
    last = np.empty((2, n))
    y_big = np.empty(n)
    v_big = np.empty(n)
    y_mid = np.empty(n)
    v_mid = np.empty(n)
    h = 0.5 * H
    for i in range(count):
        checked = i % every == 0
        if checked:
            predict(big, X, h_prev, h_prev, H, nodes)
            if not solve_stages(model, rows, 6 * i, y[i], v[i], big, H, tab, newton,
                                inverse[0], have, MATRIX_0, partials, counts, peak):
                return 2, i
            _advance(y[i], v[i], big, H, tab, y_big, v_big)
            predict(fine, big, H, 0.0, h, nodes)
        else:
            predict(fine, X, h_prev, h_prev, h, nodes)
        if not solve_stages(model, rows, 6 * i + 2, y[i], v[i], fine, h, tab, newton, inverse[1],
                            have, MATRIX_1, partials, counts, peak):
            return 2, i
        _advance(y[i], v[i], fine, h, tab, y_mid, v_mid)
        if checked:
            predict(fine, big, H, h, h, nodes)
        else:
            for st in range(2):
                for m in range(n):
                    last[st, m] = fine[st, m]
            predict(fine, last, h, h, h, nodes)
        if not solve_stages(model, rows, 6 * i + 4, y_mid, v_mid, fine, h, tab, newton, inverse[1],
                            have, MATRIX_1, partials, counts, peak):
            return 2, i
        _advance(y_mid, v_mid, fine, h, tab, y[i + 1], v[i + 1])
        if checked:
            errors[i] = doubling_error(y_big, v_big, y[i + 1], v[i + 1], control)
            if errors[i] > 1.0:
                return 1, i
        for st in range(2):
            for m in range(n):
                X[st, m] = fine[st, m]
        h_prev = h
    return 0, count


@njit(cache=True)
def doubling_error(q_big, v_big, q_fine, v_fine, control):
    """The step-doubling estimate of one step's local error, |fine − big| / 15 (fourth
    order), in the step controller's norm (`_step_control_numba.error_norm`) of [q, q̇]:
    ``control`` a StepControl of 2n components (`gauss_steps.step_control`: the rates'
    groups floored by their coordinates'), its peaks updated here with the fine state."""
    n = q_fine.size
    e = np.empty(2 * n)
    y = np.empty(2 * n)
    for m in range(n):
        e[m] = (q_fine[m] - q_big[m]) / 15.0
        e[n + m] = (v_fine[m] - v_big[m]) / 15.0
        y[m] = q_fine[m]
        y[n + m] = v_fine[m]
    update_peaks(control, y)
    scal = np.empty(2 * n)
    tolerances(control, y, scal)
    return error_norm(control, e, scal)


@njit(cache=True)
def predict(X, X_prev, h_prev, start, h, nodes):
    """Stage accelerations X (2, n) of a step of h (s) starting ``start`` (s) after the start
    of the step of length h_prev whose stage accelerations were X_prev (2, n): X_prev's
    linear collocation polynomial extrapolated (the predictor of Newton)."""
    for st in range(2):
        s = (start + nodes[st] * h) / h_prev
        w = (s - nodes[0]) / (nodes[1] - nodes[0])
        for m in range(X.shape[1]):
            X[st, m] = X_prev[0, m] + w * (X_prev[1, m] - X_prev[0, m])
