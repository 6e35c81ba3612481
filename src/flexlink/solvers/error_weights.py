"""Per-mode error weights of the step controller (`_step_control_numba`): how much the local
error of each elastic coordinate and rate counts.

Displacements against rates (every first-order forward run). An error of amplitude ε in
mode j (ω_j its frequency) sits in its displacement as ε or in its rate as ω_j ε, depending
on the phase of the oscillation at that step. The displacements of a link share one
tolerance (rtol times their peak P_z, mostly the first mode's) and its rates another (rtol
times P_ż ≈ ω₁ P_z): counted plainly, an amplitude error of a high mode is allowed ω_j/ω₁
times more when it happens to sit in the displacement than in the rate. The controller then
accepts long steps whenever the error of a ringing high mode sits in its displacement and
rejects the next (a third of all steps on the slider case), and the high mode's amplitude,
with the momentum it exchanges with the rigid joints, drifts. `displacement_weights` weighs
mode j's displacement by ω_j/ω₁ times its rate's weight: the same amplitude error counts the
same at every phase (with rate weight 1, the error in the energy norm, Σ ω_j² ε_j², against
the kinetic scale P_ż²).

Rates (not applied by default). A local error δ in the rate of mode j changes that mode's
amplitude by δ/ω_j. A channel that reads the link's displacements — a tip or a deflection
sensor, the angles and travels of the joints it moves — sees that amplitude, Φ_j δ/ω_j,
with mode shapes of one size: mode j's rate error matters ω₁/ω_j as much as the first
mode's. A channel that reads curvature or acceleration — a strain or acceleration sensor, a
joint torque or force computed from the motion (a prescribed joint, a prescribed cart), a
controller fed by sensors — sees Φ_j'' δ/ω_j or ω_j Φ_j δ, in which the high modes count as
much as the first or more: there every rate keeps weight 1.
`elastic_rate_weights` gives ω₁/ω_j to the elastic rates of a run whose every read is a
displacement, 1 otherwise; `solvers.forward.integrate_forward(rate_weights=…)` takes them.
No run applies them by default: the local bound is right, but Radau IIA's error estimate
overstates the true local error of a mode by a factor that falls with ω_j h (about
30/(ω_j h)² below ω_j h ≈ 2), so a high mode whose estimate is allowed to reach the
tolerance accumulates a global error that a low mode at the same estimate does not: on the
torque-driven hub–beam the tip's error grew from 1e-4 to 9e-4 of its peak at rtol 1e-4, a
third of the model's own error (docs/performance.md, "Per-mode error weights").
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..model import Base
from ..model.joints import is_driven
from ..model.sensors import PointSensor
from ..modes import ModalData


def mode_frequencies(modal: Sequence[ModalData]) -> list[np.ndarray]:
    """Each link's clamped natural frequencies ω_j (rad/s), ascending, one per elastic
    coordinate (the j-th coordinate's shape is nearest the j-th mode)."""
    return [2.0 * np.pi * np.asarray(data.natural_frequencies_hz[:data.n], dtype=float)
            for data in modal]


def displacement_rate_weights(modal: Sequence[ModalData]) -> np.ndarray:
    """(n,) the weight ω₁/ω_j of each elastic rate, ω₁ its link's lowest frequency: the
    rate error counted by the displacement it makes."""
    parts = [np.zeros(0)]
    for w in mode_frequencies(modal):
        if w.size:
            first = float(w.min())
            parts.append(first / np.maximum(w, first) if first > 0.0 else np.ones(w.size))
    return np.concatenate(parts)


def displacement_weights(modal: Sequence[ModalData],
                         rate_weights: np.ndarray | None = None) -> np.ndarray:
    """(n,) the weight of each elastic coordinate: ω_j/ω₁ (ω₁ its link's lowest frequency)
    times its rate's weight (``rate_weights`` (n,), None: 1), so that an amplitude error of
    mode j counts the same in its displacement as in its rate (module docstring)."""
    rates = (np.ones(sum(d.n for d in modal)) if rate_weights is None
             else np.asarray(rate_weights, dtype=float))
    return rates / displacement_rate_weights(modal)


def reads_displacements_only(joints: Sequence[object], base: Base | None,
                             sensors: Sequence[object], controllers: Sequence[object]) -> bool:
    """Whether every channel of the run reads displacements (module docstring): no sensor but
    deflection sensors, no controller, every joint driven (no torque or force computed from
    a prescribed motion), no prescribed cart."""
    if controllers or any(not (isinstance(s, PointSensor) and s.kind == "deflection")
                          for s in sensors):
        return False
    if base is not None and base.cart is not None and base.cart.prescribed:
        return False
    return all(is_driven(joint) for joint in joints)


def elastic_rate_weights(modal: Sequence[ModalData], joints: Sequence[object],
                         base: Base | None, sensors: Sequence[object],
                         controllers: Sequence[object]) -> np.ndarray:
    """(n,) the error weight of each elastic rate of a run (module docstring)."""
    n = sum(d.n for d in modal)
    if reads_displacements_only(joints, base, sensors, controllers):
        return displacement_rate_weights(modal)
    return np.ones(n)
