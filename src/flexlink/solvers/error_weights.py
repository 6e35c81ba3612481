"""Per-mode error weights of the step controller (`_step_control_numba`): how much the local
error of each elastic rate counts, from what the run's channels read of it.

A local error δ in the rate of mode j (ω_j its frequency) changes that mode's amplitude by
δ/ω_j. A channel that reads the link's displacements — a tip or a deflection sensor, the
angles and travels of the joints it moves — sees that amplitude, Φ_j δ/ω_j, with mode shapes of
one size: mode j's rate error matters ω₁/ω_j as much as the first mode's. A channel that
reads curvature or acceleration — a strain or acceleration sensor, a joint torque or force
computed from the motion (a prescribed joint, a prescribed cart), a controller fed by
sensors — sees Φ_j'' δ/ω_j or ω_j Φ_j δ, in which the high modes count as much as the first or
more: there every rate keeps weight 1 (the plain max norm of the group).

`elastic_rate_weights` gives ω₁/ω_j to the elastic rates of a run whose every read is a
displacement, 1 otherwise; `solvers.forward.integrate_forward(rate_weights=…)` takes them.
No run applies them by default: on the slider case they halve the steps with the tip,
travel and hub angle as accurate as before, but on the torque-driven hub–beam (also read by
displacements only) the tip's error grew from 1.1e-4 to 8.8e-4 of its peak at rtol 1e-4,
a third of the model's own error instead of a twenty-fourth (docs/performance.md,
"Per-mode error weights"). The elastic coordinates themselves always keep weight 1.
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
