"""How far a first-order run is from the geometrically nonlinear model: the one source of
every accuracy statement flexlink makes (the run's metadata, the command's summary,
results.nc, report.html; docs/validation.md, "How far is first order from nonlinear").

The estimate is of the largest difference of a link's tip deflection from the nonlinear
model's, relative to the nonlinear model's peak tip deflection. Two terms, each measured
from the run itself:

- every first-order model drops terms of second order in the deflection: an error growing
  as the square of the peak tip deflection per length δ, and as δ times S, the geometric
  stiffness of the axial load a spinning, accelerating link carries relative to its bending
  stiffness (`axial_load_parameter`); a link joined to another elastic link (I = 1, else
  0) carries an error growing as δ itself (measured on two-link arms);
- the paper's model (``geometric_stiffening = false``) also drops that geometric stiffness
  itself, an error growing with S alone.

expected error = E with stiffening, √(E² + (B S^P)²) without, E = A δ² + C δ S + D δ I.
A, C, D, B, P are calibrated against the nonlinear model by ``scripts/accuracy_calibration.py`` on a set
of arms and manoeuvres (its table is docs/validation.md's); the held-out cases are in
``tests/validation/test_accuracy_estimate.py``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..model import Base, Link
from ..modes import ModalData

# Calibrated by scripts/accuracy_calibration.py (least squares in log error).
A_DEFLECTION = 0.294
C_COUPLING = 0.0922
D_INBOARD = 0.0551
B_AXIAL = 2.23
P_AXIAL = 1.16

# Expected error (fraction of peak) above which a run carries a warning.
WARN_ABOVE = 0.02
# Peak tip deflection per length above which a forward run (no estimate) carries a warning.
FORWARD_WARN_DEFLECTION = 0.1
# The forward run's limits (`forward_validity_warning`; δ the peak tip deflection per length,
# S `axial_load_parameter`, μ the share of a free coordinate's inertia). The stiffened
# model's coupling C δ S, alone WARN_ABOVE where δ·S reaches the limit (the prescribed runs'
# estimate, whose links no free coordinate moves); the others measured on forward runs
# against the nonlinear model by scripts/forward_validity_calibration.py
# (docs/validation.md): their largest error over the measure, 6.0 for μ²·δ·√S and 10.8
# for the paper's model's S, times the limit is 3% of peak.
FORWARD_COUPLING_LIMIT = WARN_ABOVE / C_COUPLING
FORWARD_FREE_LIMIT = 0.005
FORWARD_PAPER_AXIAL_LIMIT = 0.0025
# Links whose far end a closed loop holds (`loop_held_measure`): points of the span where the
# deflection is read (interior, equally spaced) and the limits of the measure, measured on
# closed loops against the nonlinear model (scripts/forward_validity_calibration.py): the
# largest error over the measure 0.47 on a link joined to rigid ones, 4.7 on one joined to
# another elastic link (a long undamped run near the loop's first frequency), times the
# limit is about 3% of peak.
LOOP_SPAN_POINTS = 7
FORWARD_LOOP_LIMIT = 0.05
FORWARD_LOOP_ON_ELASTIC_LIMIT = 0.006


def axial_load_parameter(links: Sequence[Link], modal: Sequence[ModalData],
                         base: Base | None, theta: np.ndarray, omega: np.ndarray,
                         alpha: np.ndarray, origin_accel: np.ndarray) -> np.ndarray:
    """S_k = max_t |K_g(t)| / K of every link's first assumed mode (0 for a rigid link): the
    geometric stiffness of the axial load the link carries over its bending stiffness.
    K_g = Ω_k² ∫N_Ω φ'² dx − a_k ∫N_a φ'² dx + P_k ∫φ'² dx with N_Ω = m(L² − x²)/2 + m_t L,
    N_a = m(L − x) + m_t (the modal integrals ``foreshortening_moment``, ``_mass``,
    ``_tip``) and P_k the pull of the outboard links of its branch on its tip, from their
    rigid centres' accelerations. ``theta``, ``omega``, ``alpha`` (nt, N): each frame's
    absolute angle (rad), rate, acceleration; ``origin_accel`` (nt, N, 2): its origin's
    acceleration in its own axes (m/s²)."""
    n = len(links)
    out = np.zeros(n)
    for k, data in enumerate(modal):
        if data.n == 0 or omega.size == 0:
            continue
        pull = np.zeros(omega.shape[0])
        for j in range(k + 1, n):
            if base is not None and base.attachment(j) is not None:
                break  # link j starts another branch on the base
            mass = modal[j].mass
            if mass == 0.0:
                continue
            centre = modal[j].first_moment / mass
            # the rigid centre's acceleration in frame j, turned into frame k's x axis
            ax = origin_accel[:, j, 0] - omega[:, j] ** 2 * centre
            ay = origin_accel[:, j, 1] + alpha[:, j] * centre
            turn = theta[:, j] - theta[:, k]
            pull -= mass * (ax * np.cos(turn) - ay * np.sin(turn))
        geometric = (omega[:, k] ** 2 * data.foreshortening_moment[0, 0]
                     - origin_accel[:, k, 0] * data.foreshortening_mass[0, 0]
                     + pull * data.foreshortening_tip[0, 0])
        out[k] = float(np.abs(geometric).max()) / data.stiffness_matrix[0, 0]
    return out


def hangs_on_elastic(links: Sequence[Link], base: Base | None) -> np.ndarray:
    """Whether each link is joined to another elastic link of its branch (it hangs on one,
    or one hangs on it)."""
    def joined(k: int, j: int) -> bool:  # link j hangs on link k
        return 0 <= k < j < len(links) and (base is None or base.attachment(j) is None)

    return np.array([(joined(k - 1, k) and not links[k - 1].rigid)
                     or (joined(k, k + 1) and not links[k + 1].rigid)
                     for k in range(len(links))], dtype=bool)


def expected_error(deflection_per_length: float, axial_load: float,
                   geometric_stiffening: bool, inboard: bool = False) -> float:
    """The expected largest difference of a tip deflection from the nonlinear model's, as a
    fraction of its peak: δ = peak tip deflection / length, S = `axial_load_parameter`,
    ``inboard``: the link hangs on an elastic link (`hangs_on_elastic`)."""
    d, S = deflection_per_length, axial_load
    second_order = A_DEFLECTION * d * d + C_COUPLING * d * S + D_INBOARD * d * float(inboard)
    if geometric_stiffening:
        return second_order
    return float(np.hypot(second_order, B_AXIAL * S ** P_AXIAL))


def accuracy_metadata(links: Sequence[Link], deflection_per_length: np.ndarray,
                      axial_load: np.ndarray, geometric_stiffening: bool,
                      inboard: np.ndarray | None = None) -> dict[str, Any]:
    """The run's accuracy metadata: for the link with the largest peak tip deflection per
    length (``deflection_per_length``, per link), its expected error and the statement the
    summary, results.nc and report.html carry; a warning above WARN_ABOVE."""
    k = int(np.argmax(deflection_per_length))
    on_elastic = bool(inboard[k]) if inboard is not None else False
    error = expected_error(float(deflection_per_length[k]), float(axial_load[k]),
                           geometric_stiffening, on_elastic)
    model = ("the first-order model" if geometric_stiffening
             else "the paper's first-order model without geometric stiffening")
    statement = (f"{links[k].name}'s tip deflection is expected to differ from the nonlinear "
                 f"model's by about {_percent(error)} of its peak ({model}; peak tip deflection "
                 f"{100 * deflection_per_length[k]:.1f}% of the link's length)")
    out: dict[str, Any] = {"expected_error_vs_nonlinear": error,
                           "expected_error_link": links[k].name,
                           "axial_load_parameter": float(axial_load[k]),
                           "hangs_on_elastic_link": on_elastic, "accuracy": statement}
    if error > WARN_ABOVE:
        fix = ("model = \"nonlinear\" is accurate at large deflections" if geometric_stiffening
               else "geometric_stiffening = true removes most of it, model = \"nonlinear\" "
                    "all of it")
        out["validity_warning"] = (
            f"the tip of {links[k].name} deflected {100 * deflection_per_length[k]:.0f}% of its "
            f"length and {model} is expected to be {_percent(error)} of peak off the "
            f"nonlinear model: {fix}")
    return out


def unestimated_metadata(links: Sequence[Link], deflection_per_length: np.ndarray,
                         axial_load: np.ndarray, geometric_stiffening: bool = True,
                         shares: np.ndarray | None = None) -> dict[str, Any]:
    """The accuracy metadata of a forward run (driven joints or a moving base), for which the
    estimate is not calibrated (its measured error against the nonlinear forward model
    scatters beyond a factor 1.5 of it: docs/validation.md, Case 12b): the peak deflection
    and a pointer to the nonlinear model (S and the forward measure recorded too), a warning
    past FORWARD_WARN_DEFLECTION or past a limit of `forward_validity_warning`. ``shares``:
    each link's `ForwardSystem.inertia_shares` (none if not given)."""
    k = int(np.argmax(deflection_per_length))
    peak = 100 * float(deflection_per_length[k])
    mu = np.zeros(len(links)) if shares is None else np.asarray(shares, float)
    free = forward_free_measure(deflection_per_length, axial_load, mu)
    j = int(np.argmax(free))
    out: dict[str, Any] = {
        "axial_load_parameter": float(axial_load[k]),
        "forward_validity_measure": float(free[j]), "forward_validity_link": links[j].name,
        "accuracy": (f"not estimated for driven joints or a moving base (peak tip deflection "
                     f"{peak:.1f}% of {links[k].name}'s length): run it with model = "
                     "\"nonlinear\" to compare")}
    warnings = []
    if deflection_per_length[k] > FORWARD_WARN_DEFLECTION:
        warnings.append(
            f"the tip of {links[k].name} deflected {peak:.0f}% of its length, beyond "
            f"{100 * FORWARD_WARN_DEFLECTION:.0f}%: the first-order model's error grows with "
            "the deflection and is not estimated for forward runs: model = \"nonlinear\" is "
            "accurate at large deflections")
    axial = forward_validity_warning(links, deflection_per_length, axial_load, mu,
                                     geometric_stiffening)
    if axial:
        warnings.append(axial)
    if warnings:
        out["validity_warning"] = "; ".join(warnings)
    return out


def forward_free_measure(deflection_per_length: np.ndarray, axial_load: np.ndarray,
                         shares: np.ndarray) -> np.ndarray:
    """μ²·δ·√S of every link (non-finite: inf): δ its peak tip deflection per length, S its
    `axial_load_parameter`, μ its share of the inertia of a free rigid coordinate that moves
    it (`ForwardSystem.inertia_shares`). A free coordinate's motion follows the link's
    first-order reaction, whose dropped second-order terms then feed back into the rigid
    motion and the deflection: measured, the forward error grows as δ√S times a factor that
    falls fast as the rest of the inertia grows (scripts/forward_validity_calibration.py)."""
    d, S, mu = (np.asarray(a, float) for a in (deflection_per_length, axial_load, shares))
    value = mu * mu * d * np.sqrt(np.maximum(S, 0.0))
    return np.where(np.isfinite(value), value, np.inf)


def forward_validity_warning(links: Sequence[Link], deflection_per_length: np.ndarray,
                             axial_load: np.ndarray, shares: np.ndarray,
                             geometric_stiffening: bool) -> str:
    """The forward run's warning where a link's axial load takes the first-order model past
    its validity ("" if none does). With geometric stiffening: μ²·δ·√S beyond
    FORWARD_FREE_LIMIT (`forward_free_measure`), or δ·S beyond FORWARD_COUPLING_LIMIT (the
    dropped coupling of the deflection with the axial load, C δ S, alone 2% of peak: the
    prescribed runs' estimate). Without: S beyond FORWARD_PAPER_AXIAL_LIMIT (the missing
    geometric stiffness). Both limits measured on forward runs against the nonlinear model
    (scripts/forward_validity_calibration.py, docs/validation.md). Non-finite values count
    as beyond."""
    d, S = np.asarray(deflection_per_length, float), np.asarray(axial_load, float)
    if not geometric_stiffening:
        measure = np.where(np.isfinite(S), S, np.inf)
        k = int(np.argmax(measure))
        if not measure[k] > FORWARD_PAPER_AXIAL_LIMIT:
            return ""
        return (f"{links[k].name} carries an axial load S = {S[k]:.3g} times its first mode's "
                f"bending stiffness (axial_load_parameter), beyond {FORWARD_PAPER_AXIAL_LIMIT:.2g}, "
                "where forward runs of the paper's model (geometric_stiffening = false), which "
                "leaves out its geometric stiffness, measured more than 3% of peak off the "
                "nonlinear model: set geometric_stiffening = true, or model = \"nonlinear\"")
    free = forward_free_measure(d, S, shares)
    k = int(np.argmax(free))
    if free[k] > FORWARD_FREE_LIMIT:
        mu = float(np.asarray(shares, float)[k])
        return (f"{links[k].name} carries {100 * mu:.0f}% of the inertia of a free coordinate "
                f"that moves it, an axial load S = {S[k]:.3g} times its first mode's bending "
                f"stiffness (axial_load_parameter: spin, acceleration, outboard pull) and a tip "
                f"deflection of {100 * d[k]:.3g}% of its length: μ²·δ·√S = {free[k]:.3g}, beyond "
                f"{FORWARD_FREE_LIMIT:.2g}, where forward runs measured up to 3% of peak off "
                "the nonlinear model: model = \"nonlinear\" keeps the terms the first-order "
                "model drops")
    measure = np.where(np.isfinite(d * S), d * S, np.inf)
    k = int(np.argmax(measure))
    if not measure[k] > FORWARD_COUPLING_LIMIT:
        return ""
    return (f"{links[k].name} carries an axial load S = {S[k]:.3g} times its first mode's "
            f"bending stiffness (axial_load_parameter: spin, acceleration, outboard pull) "
            f"with a tip deflection of {100 * d[k]:.3g}% of its length: δ·S = "
            f"{measure[k]:.3g}, beyond {FORWARD_COUPLING_LIMIT:.2g}, where the coupling "
            "of the deflection with the axial load that the first-order model drops is "
            "alone about 2% of peak: model = \"nonlinear\" keeps it")


def loop_held_measure(span_per_length: np.ndarray, axial_load: np.ndarray) -> np.ndarray:
    """δ_s/(1 − S) of every link a closed loop holds at both ends (S ≥ 1 or non-finite:
    inf): δ_s its peak span deflection per length (its tip's is zero), S its axial load over
    the first mode's bending stiffness, |P| L²/(π² EI) for a pinned–pinned member (its own
    inertia's `axial_load_parameter` plus the closures' force along its chord). 1/(1 − S)
    is the amplification of a compressed member's deflection by its axial load."""
    d, S = np.asarray(span_per_length, float), np.asarray(axial_load, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        value = np.where(S < 1.0, d / (1.0 - S), np.inf)
    return np.where(np.isfinite(value), value, np.inf)


def loop_limits(on_elastic: np.ndarray) -> np.ndarray:
    """The limit of `loop_held_measure` of each held link: FORWARD_LOOP_ON_ELASTIC_LIMIT
    where it is joined to another elastic link (at its joint or by the closure), else
    FORWARD_LOOP_LIMIT."""
    return np.where(np.asarray(on_elastic, bool), FORWARD_LOOP_ON_ELASTIC_LIMIT,
                    FORWARD_LOOP_LIMIT)


def loop_validity_warning(links: Sequence[Link], held: Sequence[int],
                          span_per_length: np.ndarray, axial_load: np.ndarray,
                          on_elastic: np.ndarray) -> str:
    """The warning where a link held at both ends by a closed loop takes the first-order
    model past its validity ("" if none does): `loop_held_measure` beyond its
    `loop_limits` (scripts/forward_validity_calibration.py, docs/validation.md)."""
    if not len(held):
        return ""
    measure = loop_held_measure(span_per_length, axial_load)
    limits = loop_limits(on_elastic)
    i = int(np.argmax(measure / limits))
    if not measure[i] > limits[i]:
        return ""
    k = held[i]
    joined = ", joined to another elastic link," if on_elastic[i] else ","
    return (f"{links[k].name}, held at both ends by the closed loop{joined} deflected "
            f"{100 * span_per_length[i]:.3g}% of its length across its span under an axial "
            f"load S = {axial_load[i]:.3g} of its buckling load (|P| L²/(π² EI)): "
            f"δ_s/(1 − S) = {measure[i]:.3g}, beyond {limits[i]:.2g}, where closed-loop runs "
            "measured more than 3% of peak off the nonlinear model: model = \"nonlinear\" "
            "keeps the terms the first-order model drops")


def _percent(fraction: float) -> str:
    """A fraction as a percentage with two significant digits (0.21%, 2.1%, 22%, 140%)."""
    value = 100 * fraction
    return f"{value:.0f}%" if value >= 10 else f"{value:.2g}%"
