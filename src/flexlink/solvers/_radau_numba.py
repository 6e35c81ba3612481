"""Compiled (numba) Radau IIA integrator of order 5 for M y' = f(t, y) (``radau.py``): Hairer
and Wanner's RADAU5 (Solving ODEs II, §IV.8) — three-stage collocation, simplified Newton on
the transformed stage system (one real and one complex linear system per iteration, the
Jacobian and its factorisations reused across steps while Newton converges fast), the
embedded error estimate filtered by (γ₀/h M − J)⁻¹, the step controller shared with the
Gauss collocation (`_step_control_numba`: weighted max norm, Gustafsson's predictive factor),
and the collocation polynomial as dense output. Where the model's rates of its coordinates
are its velocities exactly (a forward model's state [p, ṗ, z, ż, …]), the velocities are
eliminated from each linear system (x_V = c x_P − b_P, as RADAU5's second-order option): the
factorisations and solves are of the other half only (`_reduced_matrix`, `_solve`).

f at an accepted step's end, which the next step's error estimate reads (and nothing else),
is estimated rather than evaluated where that is safe: the last Newton iterate evaluated f
at its end stage Y₃, and y₁ = Y₃ + Δ (Δ: the last correction, and a projection's), so
f(y₁) ≈ f(Y₃) + J Δ, off by (J(y₁) − J) Δ + O(Δ²). Only when Δ is at most ESTIMATE_MOVE of
the local tolerance in every component, Newton took two iterations or more (its contraction
measured: J fits) and the step is neither a run's first nor one after a rejection; near a
singular configuration (a loop about to lock) f is far from linear over even a tolerance.
f itself is evaluated where it matters: a step that takes a fresh Jacobian (differences need
it exactly), the start of each segment, and an error estimate that would reject the step
(not rejected on an estimate).

The model is reached through `model_rates(model, u, y, dy)`: dy = f(t, y), ``u`` the input
row at t, ``model`` the addresses of the model's compiled code and its records
(`_radau_model.model_functions`): the loop is compiled once for every model, without the
model's code inside it.

Inputs are piecewise polynomials between breakpoints (`input_table.py`): u(t) is read in
the compiled loop from Chebyshev coefficients, and the columns ``held[0]:held[1]`` are
overwritten by ``held_values`` (a sampled controller's held voltages). The run is cut into
segments at every breakpoint: no step straddles one, and after one the Newton iteration
restarts from zero stage values (the extrapolated collocation polynomial would carry the
input's jump).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numba import njit

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from ._radau_model import LinearData, model_functions, model_project, model_rates
from ._step_control_numba import (
    SAFETY,
    error_norm,
    keeps,
    next_factor,
    predictive_factor,
    step_factor,
    tolerances,
    update_peaks,
)

__all__ = ["LinearData", "model_functions", "radau_advance", "rates_at", "rates_function"]


# Radau IIA (s = 3) and its transformation T⁻¹ A⁻¹ T = diag(γ, [[α, −β], [β, α]]).
_SQ6 = math.sqrt(6.0)
C1, C2 = (4.0 - _SQ6) / 10.0, (4.0 + _SQ6) / 10.0
C1M1, C2M1, C1MC2 = C1 - 1.0, C2 - 1.0, C1 - C2
DD1, DD2, DD3 = -(13.0 + 7.0 * _SQ6) / 3.0, (-13.0 + 7.0 * _SQ6) / 3.0, -1.0 / 3.0
_U1 = (6.0 + 81.0 ** (1 / 3) - 9.0 ** (1 / 3)) / 30.0
_AL = (12.0 - 81.0 ** (1 / 3) + 9.0 ** (1 / 3)) / 60.0
_BE = (81.0 ** (1 / 3) + 9.0 ** (1 / 3)) * math.sqrt(3.0) / 60.0
_CNO = _AL * _AL + _BE * _BE
GAMMA, ALPHA, BETA = 1.0 / _U1, _AL / _CNO, _BE / _CNO
T11, T12, T13 = 9.1232394870892942792e-02, -0.14125529502095420843, -3.0029194105147424492e-02
T21, T22, T23 = 0.24171793270710701896, 0.20412935229379993199, 0.38294211275726193779
T31 = 0.96604818261509293619  # T32 = 1, T33 = 0
TI11, TI12, TI13 = 4.3255798900631553510, 0.33919925181580986954, 0.54177053993587487119
TI21, TI22, TI23 = -4.1787185915519047273, -0.32768282076106238708, 0.47662355450055045196
TI31, TI32, TI33 = -0.50287263494578687595, 2.5719269498556054292, -0.59603920482822492497

NEWTON_MAX = 7  # iterations per step
# The step controller (`_step_control_numba`): the embedded estimate is of order 3, so the
# factor goes as err^(−1/4); a step may grow 8× (RADAU5's bound).
EXPONENT, GROW = 0.25, 8.0
# Newton contraction θ below which the Jacobian is kept for the next step. Hairer's default
# is 0.001 for cheap Jacobians; ours costs one rate evaluation per state component.
THETA_KEEP = 0.1
UROUND = 2.2e-16
# f at an accepted step's end is estimated, not evaluated, when the move from the last
# Newton iterate's end stage is at most this many local tolerances in every component (the
# module's docstring). The estimate's own error, in the error estimate's units, was below
# 5e-4 at this bound in the slider loop's and the slider cart's runs, but up to 0.25 at 1
# on a four-bar about to lock under a 1 MN push (0.8 with one Newton iteration).
ESTIMATE_MOVE = 0.1

# Persistent scalars of a run (``st``), so that the loop can stop and resume (progress,
# sample instants of controllers) without losing its step size or factorisations.
X, H, H_OLD, H_ACC, ERR_ACC, FACCON, THETA, SEG, NEXT_OUT = 0, 1, 2, 3, 4, 5, 6, 7, 8
FIRST, REJECT, JAC_OK, LU_OK, FRESH, F0_OK, H_LU = 9, 10, 11, 12, 13, 14, 15
STEPS, ACCEPTED, REJECTED, RATES, JACOBIANS, LUS = 16, 17, 18, 19, 20, 21
# The sizes and errors of the MEMORY accepted steps before the last (MEMORY_H + k,
# MEMORY_ERR + k), oldest first. An undamped mode that the step does not resolve makes the
# error estimate swing tenfold and more with its phase from one step to the next at the same
# h: a step sized from a small error alone was rejected a step or two later. The next step
# is sized from the largest of the recent errors, each scaled to the present h (err ∝
# h^(1/exponent)).
MEMORY = 2
RECENT = 22  # 1: size the steps from the recent errors too (a run's choice: integrate_radau)
MEMORY_H, MEMORY_ERR = 23, 23 + MEMORY
N_ST = 23 + 2 * MEMORY


@njit(cache=True)
def _piece(tab, seg, t):
    """The first piece of segment ``seg`` of the input table that ends at or after t (s)."""
    t1s, seg_piece = tab[1], tab[3]
    lo, hi = seg_piece[seg], seg_piece[seg + 1] - 1
    while lo < hi:
        mid = (lo + hi) // 2
        if t1s[mid] < t:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(inline="always")
def _chebyshev(coef, piece, column, x):
    """Σ_k coef[piece, k, column] T_k(x) by Clenshaw's recurrence (x in [-1, 1])."""
    b1 = 0.0
    b2 = 0.0
    for k in range(coef.shape[1] - 1, 0, -1):
        b1, b2 = 2.0 * x * b1 - b2 + coef[piece, k, column], b1
    return x * b1 - b2 + coef[piece, 0, column]


@njit(cache=True)
def input_integral(tab, itab, seg, t, U):
    """U = the inputs' integrals from the run's start to time t (s) inside segment ``seg``
    (itab: `input_table.integrals` of tab)."""
    t0s, t1s = tab[0], tab[1]
    icoef, offset = itab
    lo = _piece(tab, seg, t)
    a, b = t0s[lo], t1s[lo]
    x = (2.0 * t - (a + b)) / (b - a)
    for c in range(icoef.shape[2]):
        U[c] = offset[lo, c] + _chebyshev(icoef, lo, c, x)


@njit(cache=True)
def input_row(tab, held_values, held, seg, t, u):
    """u = the input row at time t (s) inside segment ``seg`` (closed at both ends: its
    polynomial pieces are continued up to the segment's breakpoints), the columns
    held[0]:held[1] replaced by held_values."""
    t0s, t1s, coef = tab[0], tab[1], tab[2]
    lo = _piece(tab, seg, t)
    a, b = t0s[lo], t1s[lo]
    x = (2.0 * t - (a + b)) / (b - a)
    for c in range(coef.shape[2]):
        u[c] = _chebyshev(coef, lo, c, x)
    for c in range(held[0], held[1]):
        u[c] = held_values[c - held[0]]


@njit(cache=True)
def _lu(A, piv):
    """LU decomposition with partial pivoting in place (real or complex A); False if
    singular."""
    n = A.shape[0]
    for c in range(n):
        p = c
        big = abs(A[c, c])
        for i in range(c + 1, n):
            if abs(A[i, c]) > big:
                big, p = abs(A[i, c]), i
        piv[c] = p
        if big == 0.0:
            return False
        if p != c:
            for j in range(n):
                A[c, j], A[p, j] = A[p, j], A[c, j]
        inv = 1.0 / A[c, c]
        for i in range(c + 1, n):
            f = A[i, c] * inv
            A[i, c] = f
            if f != 0.0:
                for j in range(c + 1, n):
                    A[i, j] -= f * A[c, j]
    return True


@njit(cache=True)
def _lu_solve(LU, piv, b):
    """b ← A⁻¹ b from `_lu`'s factors."""
    n = b.shape[0]
    for c in range(n):  # the rows were swapped whole: every interchange first
        p = piv[c]
        if p != c:
            b[c], b[p] = b[p], b[c]
    for c in range(n):
        for i in range(c + 1, n):
            b[i] -= LU[i, c] * b[c]
    for i in range(n - 1, -1, -1):
        acc = b[i]
        for j in range(i + 1, n):
            acc -= LU[i, j] * b[j]
        b[i] = acc / LU[i, i]


@njit(cache=True)
def _reduced_matrix(J, c, reduced, E):
    """E = the iteration matrix c I − J (c real or complex) reduced to the rows and columns
    of ``reduced`` = (rows, cols, vel) (`radau.second_order_reduction`): where rows P of f are
    f_P = y_V exactly (J's P rows are [0 I]), x_V = c x_P − b_P eliminates the velocities,
    leaving the rows Q (all but P) in the unknowns x_R (all but V); vel[j] is the velocity
    of the position cols[j] (−1: cols[j] is neither)."""
    rows, cols, vel = reduced
    for i in range(rows.shape[0]):
        a = rows[i]
        for j in range(cols.shape[0]):
            col, v = cols[j], vel[j]
            if v >= 0:
                E[i, j] = c * ((c if a == v else 0.0) - J[a, v]) - J[a, col]
            else:
                E[i, j] = (c if a == col else 0.0) - J[a, col]


@njit(cache=True)
def _solve(LU, piv, J, c, reduced, b, w):
    """b ← (c I − J)⁻¹ b from the factors of the iteration matrix: `_lu`'s of the whole
    (no ``reduced`` rows) or of `_reduced_matrix` (w: scratch of its size)."""
    rows, cols, vel = reduced
    r = rows.shape[0]
    if r == 0:
        _lu_solve(LU, piv, b)
        return
    for i in range(r):  # the rows Q with x_V = c x_P − b_P put in
        a = rows[i]
        acc = b[a]
        for j in range(r):
            v = vel[j]
            if v >= 0:
                acc += ((c if a == v else 0.0) - J[a, v]) * b[cols[j]]
        w[i] = acc
    _lu_solve(LU, piv, w)
    for j in range(r):
        if vel[j] >= 0:
            b[vel[j]] = c * w[j] - b[cols[j]]
    for j in range(r):
        b[cols[j]] = w[j]


# Inlined into the loop rather than compiled on its own: as a kernel of its own it would
# optimise and emit the whole model it calls once more for each record type.
@njit(inline="always")
def _jacobian(model, u, y, f0, J, yp, f1):
    """J = ∂f/∂y at y by one-sided differences (f0 = f(y) given)."""
    m = y.shape[0]
    for j in range(m):
        yp[j] = y[j]
    for j in range(m):
        step = 1e-7 * max(1.0, abs(y[j]))
        yp[j] = y[j] + step
        model_rates(model, u, yp, f1)
        yp[j] = y[j]
        for i in range(m):
            J[i, j] = (f1[i] - f0[i]) / step


@njit(cache=True)
def _mass_times(mass, identity, x, out):
    """out = M x."""
    if identity:
        for i in range(x.shape[0]):
            out[i] = x[i]
        return
    for i in range(x.shape[0]):
        acc = 0.0
        for j in range(x.shape[0]):
            acc += mass[i, j] * x[j]
        out[i] = acc


@njit(cache=True)
def _recent_factor(control, st, h, err):
    """h_new / h from the largest error of this accepted step (h, err) and the MEMORY
    accepted before it, each scaled to h; this step joins the memory, the oldest leaves."""
    top = err
    power = 1.0 / control.exponent
    for k in range(MEMORY):
        h_k, err_k = st[MEMORY_H + k], st[MEMORY_ERR + k]
        if h_k > 0.0:
            top = max(top, err_k * (h / h_k) ** power)
    for k in range(MEMORY - 1):
        st[MEMORY_H + k], st[MEMORY_ERR + k] = st[MEMORY_H + k + 1], st[MEMORY_ERR + k + 1]
    st[MEMORY_H + MEMORY - 1], st[MEMORY_ERR + MEMORY - 1] = h, err
    return step_factor(control, top, SAFETY)


@njit(cache=True)
def radau_advance(model, mass, identity, tab, seg_t, held_values, held, t_stop, hmax, control,
                  t_out, states, y, st, ws, cont, projection, box, bounds, reduced):
    """Advance y (in place) from st[X] until st[X] ≥ t_stop (s), storing the state at each
    output time t_out[k] (k from st[NEXT_OUT]) into states[k] from the dense output.

    model: `model_functions` of the model's records, its compiled code; mass (m, m) is M
    unless ``identity``; tab, seg_t: the input table (`input_row`) and the segment boundaries
    (breakpoints, s); control: the step controller's record (`_step_control_numba.StepControl`,
    its rtol and atol the local tolerances, its peaks updated after each accepted step); hmax
    the longest step (s); st the
    persistent scalars (X, H, …), ws the work arrays and cont (m, 4) the collocation
    polynomial of the last step. projection = (on, itab, U): when ``on``, each accepted
    step's end and each output state are put onto the model's known invariants
    (`model_project`; itab the inputs' integral table, U its scratch row). box (2, m): the
    range [lower, upper] each component must stay in, ±BLOW_UP but where the model has a
    narrower one (a cart's or a slider's travel). bounds (r, m + 1): r linear combinations
    of the state, each row's coefficients and then the bound of its magnitude (a link's tip
    deflection and its length). reduced: `radau.second_order_reduction` (its rows empty: the
    iteration matrices whole; else, with ``identity``, reduced to the rows of f that are
    not f_P = y_V; E1, E2 and wr, wc of that size). Returns 0 (reached t_stop), 1 (a step ended with a
    component outside its box or a combination beyond its bound, or NaN: a blow-up or a
    travel left, its output times not written), 2 (step size collapsed), 3 (singular
    iteration matrix)."""
    (J, E1, E2, piv1, piv2, y0, z1, z2, z3, f1, f2, f3, scal, tmp, yp, fp, cw, u, y3, g3, wr,
     wc) = ws
    halved = reduced[0].shape[0] > 0
    on, itab, U = projection
    m = y.shape[0]
    n_seg = seg_t.shape[0] - 1
    # Newton's stopping tolerance (Hairer's default)
    rtol = control.rtol
    fnewt = max(10.0 * UROUND / rtol, min(0.03, math.sqrt(rtol)))
    while st[X] < t_stop:
        seg = int(st[SEG])
        x = st[X]
        end = seg_t[seg + 1]
        h = st[H]
        if st[F0_OK] == 0.0:  # f at the step's start (new segment: the inputs' right side)
            input_row(tab, held_values, held, seg, x, u)
            model_rates(model, u, y, y0)
            st[RATES] += 1
            st[F0_OK] = 1.0
        tolerances(control, y, scal)
        h = min(h, hmax)
        h_natural = h
        last = False
        if x + 1.0001 * h >= end:  # land on the breakpoint
            h = end - x
            last = True
        if h <= 1e-14 * max(1.0, abs(x)):
            return 2
        caljac = st[JAC_OK] == 0.0
        if caljac:
            input_row(tab, held_values, held, seg, x, u)
            if st[F0_OK] == 2.0:  # differences need f itself, not its linear estimate
                model_rates(model, u, y, y0)
                st[RATES] += 1
                st[F0_OK] = 1.0
            _jacobian(model, u, y, y0, J, yp, fp)
            st[RATES] += m
            st[JACOBIANS] += 1
            st[JAC_OK] = 1.0
            st[LU_OK] = 0.0
        if st[LU_OK] == 0.0 or h != st[H_LU]:
            fac1 = GAMMA / h
            alphn, betan = ALPHA / h, BETA / h
            if halved:
                _reduced_matrix(J, fac1, reduced, E1)
                _reduced_matrix(J, complex(alphn, betan), reduced, E2)
            else:
                for i in range(m):
                    for j in range(m):
                        mij = (1.0 if i == j else 0.0) if identity else mass[i, j]
                        E1[i, j] = fac1 * mij - J[i, j]
                        E2[i, j] = complex(alphn * mij - J[i, j], betan * mij)
            if not (_lu(E1, piv1) and _lu(E2, piv2)):
                return 3
            st[LUS] += 1
            st[LU_OK] = 1.0
            st[H_LU] = h
        st[H] = h
        fac1 = GAMMA / h
        alphn, betan = ALPHA / h, BETA / h
        # Starting values: the last step's collocation polynomial, extrapolated.
        if st[FRESH] != 0.0 or st[FIRST] != 0.0:
            z1[:] = 0.0
            z2[:] = 0.0
            z3[:] = 0.0
            f1[:] = 0.0
            f2[:] = 0.0
            f3[:] = 0.0
        else:
            c3q = h / st[H_OLD]
            c1q, c2q = C1 * c3q, C2 * c3q
            for i in range(m):
                a1, a2, a3 = cont[i, 1], cont[i, 2], cont[i, 3]
                z1[i] = c1q * (a1 + (c1q - C2M1) * (a2 + (c1q - C1M1) * a3))
                z2[i] = c2q * (a1 + (c2q - C2M1) * (a2 + (c2q - C1M1) * a3))
                z3[i] = c3q * (a1 + (c3q - C2M1) * (a2 + (c3q - C1M1) * a3))
                f1[i] = TI11 * z1[i] + TI12 * z2[i] + TI13 * z3[i]
                f2[i] = TI21 * z1[i] + TI22 * z2[i] + TI23 * z3[i]
                f3[i] = TI31 * z1[i] + TI32 * z2[i] + TI33 * z3[i]
        # Simplified Newton iteration on the transformed stages.
        st[FACCON] = max(st[FACCON], UROUND) ** 0.8
        theta = abs(THETA_KEEP)
        newt = 0
        dynold = 1.0
        thqold = 1.0
        converged = False
        retry = 0.0  # > 0: the step is redone with h · retry
        while True:
            if newt >= NEWTON_MAX:
                retry = 0.5
                break
            for i in range(m):
                tmp[i] = y[i] + z1[i]
            input_row(tab, held_values, held, seg, x + C1 * h, u)
            model_rates(model, u, tmp, z1)
            for i in range(m):
                tmp[i] = y[i] + z2[i]
            input_row(tab, held_values, held, seg, x + C2 * h, u)
            model_rates(model, u, tmp, z2)
            for i in range(m):
                tmp[i] = y[i] + z3[i]
            input_row(tab, held_values, held, seg, x + h, u)
            model_rates(model, u, tmp, z3)
            st[RATES] += 3
            for i in range(m):  # the step's end as this iterate has it, and f there
                y3[i] = tmp[i]
                g3[i] = z3[i]
            for i in range(m):
                a1, a2, a3 = z1[i], z2[i], z3[i]
                z1[i] = TI11 * a1 + TI12 * a2 + TI13 * a3
                z2[i] = TI21 * a1 + TI22 * a2 + TI23 * a3
                z3[i] = TI31 * a1 + TI32 * a2 + TI33 * a3
            # right-hand sides of the real and the complex system
            _mass_times(mass, identity, f1, tmp)
            _mass_times(mass, identity, f2, fp)
            _mass_times(mass, identity, f3, yp)
            for i in range(m):
                s2, s3 = -fp[i], -yp[i]
                z1[i] -= tmp[i] * fac1
                z2[i] += s2 * alphn - s3 * betan
                z3[i] += s3 * alphn + s2 * betan
                cw[i] = complex(z2[i], z3[i])
            _solve(E1, piv1, J, fac1, reduced, z1, wr)
            _solve(E2, piv2, J, complex(alphn, betan), reduced, cw, wc)
            for i in range(m):
                z2[i] = cw[i].real
                z3[i] = cw[i].imag
            newt += 1
            acc = 0.0
            for i in range(m):
                acc += (z1[i] / scal[i]) ** 2 + (z2[i] / scal[i]) ** 2 + (z3[i] / scal[i]) ** 2
            dyno = math.sqrt(acc / (3 * m))
            if not math.isfinite(dyno):
                retry = 0.5
                break
            if 1 < newt < NEWTON_MAX:
                thq = dyno / dynold
                theta = thq if newt == 2 else math.sqrt(thq * thqold)
                thqold = thq
                if theta < 0.99:
                    st[FACCON] = theta / (1.0 - theta)
                    dyth = st[FACCON] * dyno * theta ** (NEWTON_MAX - 1 - newt) / fnewt
                    if dyth >= 1.0:  # would not converge in time: a smaller step
                        qnewt = max(1e-4, min(20.0, dyth))
                        retry = 0.8 * qnewt ** (-1.0 / (4.0 + NEWTON_MAX - 1 - newt))
                        break
                else:
                    retry = 0.5
                    break
            dynold = max(dyno, UROUND)
            for i in range(m):
                f1[i] += z1[i]
                f2[i] += z2[i]
                f3[i] += z3[i]
                z1[i] = T11 * f1[i] + T12 * f2[i] + T13 * f3[i]
                z2[i] = T21 * f1[i] + T22 * f2[i] + T23 * f3[i]
                z3[i] = T31 * f1[i] + f2[i]
            if st[FACCON] * dyno <= fnewt:
                converged = True
                break
        st[STEPS] += 1
        if not converged:
            st[REJECTED] += 1
            st[H] = h * retry
            st[REJECT] = 1.0
            if not caljac:
                st[JAC_OK] = 0.0  # a Jacobian from an earlier step: take a fresh one
            continue
        # Error estimate.
        for i in range(m):
            f1[i] = (DD1 * z1[i] + DD2 * z2[i] + DD3 * z3[i]) / h
        _mass_times(mass, identity, f1, f2)
        for i in range(m):
            tmp[i] = f2[i] + y0[i]
        _solve(E1, piv1, J, fac1, reduced, tmp, wr)
        err = max(error_norm(control, tmp, scal), 1e-10)
        if err >= 1.0 and st[F0_OK] == 2.0:  # not rejected on f's estimate: f itself
            input_row(tab, held_values, held, seg, x, u)
            model_rates(model, u, y, y0)
            st[RATES] += 1
            st[F0_OK] = 1.0
            for i in range(m):
                tmp[i] = f2[i] + y0[i]
            _solve(E1, piv1, J, fac1, reduced, tmp, wr)
            err = max(error_norm(control, tmp, scal), 1e-10)
        if err >= 1.0 and (st[FIRST] != 0.0 or st[REJECT] != 0.0):
            for i in range(m):
                yp[i] = y[i] + tmp[i]
            input_row(tab, held_values, held, seg, x, u)
            model_rates(model, u, yp, f1)
            st[RATES] += 1
            for i in range(m):
                tmp[i] = f1[i] + f2[i]
            _solve(E1, piv1, J, fac1, reduced, tmp, wr)
            err = max(error_norm(control, tmp, scal), 1e-10)
        # many Newton iterations: a more cautious factor (RADAU5)
        safety = min(SAFETY, SAFETY * (1 + 2 * NEWTON_MAX) / (newt + 2 * NEWTON_MAX))
        factor = next_factor(control, err, safety, st[REJECT] != 0.0)
        if err < 1.0:
            st[ACCEPTED] += 1
            trusted = st[FIRST] == 0.0 and st[REJECT] == 0.0  # f's estimate: see ESTIMATE_MOVE
            if st[FIRST] == 0.0 and st[FRESH] == 0.0:
                factor = predictive_factor(control, factor, err, h, st[H_ACC], st[ERR_ACC])
            if st[RECENT] != 0.0:
                factor = min(factor, _recent_factor(control, st, h, err))
            hnew = h * factor
            st[H_ACC] = h
            st[ERR_ACC] = max(1e-2, err)
            st[FIRST] = 0.0
            st[FRESH] = 0.0
            x = x + h if not last else end
            bad = False
            for i in range(m):
                y[i] += z3[i]
                if not box[0, i] <= y[i] <= box[1, i]:  # also catches NaN
                    bad = True
                z2i, z1i = z2[i], z1[i]
                cont[i, 0] = y[i]
                cont[i, 1] = (z2i - z3[i]) / C2M1
                ak = (z1i - z2i) / C1MC2
                acont3 = (ak - z1i / C1) / C2
                cont[i, 2] = (ak - cont[i, 1]) / C1M1
                cont[i, 3] = cont[i, 2] - acont3
            for j in range(bounds.shape[0]):
                s = 0.0
                for i in range(m):
                    s += bounds[j, i] * y[i]
                if not abs(s) <= bounds[j, m]:
                    bad = True
            update_peaks(control, y)
            st[X] = x
            st[H_OLD] = h
            if bad:
                return 1
            if on:  # onto the invariants; the dense output moved by (1 + s) Δ: continuous
                for i in range(m):
                    yp[i] = y[i]
                input_row(tab, held_values, held, seg, x, u)
                input_integral(tab, itab, seg, x, U)
                model_project(model, u, U, x, y)
                for i in range(m):
                    delta = y[i] - yp[i]
                    cont[i, 0] = y[i]
                    cont[i, 1] += delta
            k = int(st[NEXT_OUT])
            while k < t_out.shape[0] and t_out[k] <= x + 1e-12 * max(1.0, abs(x)):
                s = (t_out[k] - x) / h
                for i in range(m):
                    states[k, i] = cont[i, 0] + s * (cont[i, 1] + (s - C2M1)
                                                      * (cont[i, 2] + (s - C1M1) * cont[i, 3]))
                if on:
                    input_row(tab, held_values, held, seg, t_out[k], u)
                    input_integral(tab, itab, seg, t_out[k], U)
                    model_project(model, u, U, t_out[k], states[k])
                k += 1
            st[NEXT_OUT] = k
            st[REJECT] = 0.0
            if last:
                if seg + 1 < n_seg:
                    st[SEG] = seg + 1
                st[FRESH] = 1.0
                st[F0_OK] = 0.0
            else:
                # f at the new start: f at the last iterate's end moved to y along J when
                # that move is well inside the tolerance, else a new evaluation
                big = 0.0
                for i in range(m):
                    tmp[i] = y[i] - y3[i]
                    big = max(big, abs(tmp[i]) / scal[i])
                if trusted and newt >= 2 and big <= ESTIMATE_MOVE:
                    for i in range(m):
                        acc = g3[i]
                        for j in range(m):
                            acc += J[i, j] * tmp[j]
                        y0[i] = acc
                    st[F0_OK] = 2.0
                else:
                    input_row(tab, held_values, held, seg, x, u)
                    model_rates(model, u, y, y0)
                    st[RATES] += 1
            if theta > THETA_KEEP:
                st[JAC_OK] = 0.0
            if last:
                st[H] = max(hnew, h_natural)
            elif not (theta <= THETA_KEEP and keeps(factor)):
                st[H] = hnew  # otherwise the same h: the same factorisations
        else:
            st[REJECTED] += 1
            st[REJECT] = 1.0
            st[H] = 0.1 * h if st[FIRST] != 0.0 else h * factor
            # Newton converged: the Jacobian is good enough for the smaller step (RADAU5
            # takes a fresh one here; ours costs a rate evaluation per state component).
    return 0


@njit(cache=True)
def _rates_at(model, u, states, out):
    """out[i] = f at states[i] with input row u[i] (``model``: `model_functions`)."""
    for i in range(states.shape[0]):
        model_rates(model, u[i], states[i], out[i])


def rates_at(d, w, u: np.ndarray, states: np.ndarray, out: np.ndarray) -> None:
    """out[i] = f at states[i] with input row u[i], for the model whose kernel data ``d`` is
    (``w`` its workspace): the accelerations at the outputs of a model without an outputs
    pass of its own (closed loops)."""
    rows = out if out.flags.c_contiguous and out.dtype == np.float64 else np.empty(out.shape)
    _rates_at(model_functions(d, w), np.ascontiguousarray(u, dtype=float),
              np.ascontiguousarray(states, dtype=float), rows)
    if rows is not out:
        out[...] = rows


def rates_function(d, w) -> Callable[[np.ndarray, np.ndarray, np.ndarray], None]:
    """rates(u, y, dy): dy = f at the state y with the input row u, for the model whose
    kernel data ``d`` is (``w`` its workspace, which each call overwrites), through the
    compiled code the integrator calls: for many single evaluations (finite differences,
    Newton iterations), the model looked up once. ``dy`` a float row (C-contiguous)."""
    model = model_functions(d, w)

    def rates(u: np.ndarray, y: np.ndarray, dy: np.ndarray,
              _records=(d, w)) -> None:  # the context borrows the records' arrays
        _rates_at(model, np.ascontiguousarray(u, dtype=float)[None],
                  np.ascontiguousarray(y, dtype=float)[None], dy[None])
    return rates
