"""Generalized forces of the actuators on the elastic coordinates (N·m per volt per mode)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..model import PiezoActuator
from ..modes import ModalData


def piezo_load(actuator: PiezoActuator, data: ModalData) -> np.ndarray:
    """(n_k,) generalized force per volt on the modal coordinates of the actuator's link:
    M/V · [Φ′(x_end) − Φ′(x_start)], N·m/V (docs/control.md)."""
    slopes = data.shapes.evaluate(np.array([actuator.x_start, actuator.x_end]), 1)
    return actuator.moment_per_volt * (slopes[1] - slopes[0])


def actuator_matrix(actuators: Sequence[PiezoActuator], modal: Sequence[ModalData]
                    ) -> np.ndarray:
    """(n, n_act) map from actuator voltages (V) to generalized forces on all elastic
    coordinates z (links in chain order, each link's modes in turn)."""
    offsets = np.concatenate([[0], np.cumsum([d.n for d in modal])]).astype(int)
    B = np.zeros((int(offsets[-1]), len(actuators)))
    for j, act in enumerate(actuators):
        B[offsets[act.link]:offsets[act.link + 1], j] = piezo_load(act, modal[act.link])
    return B


def open_loop_voltages(actuators: Sequence[PiezoActuator], t: np.ndarray) -> np.ndarray:
    """Open-loop voltages (nt, n_act), V, at times t (s): each actuator's ``voltage``
    history clipped to its ``limit`` (the amplifier's saturation)."""
    t = np.asarray(t, dtype=float)
    if not actuators:
        return np.zeros((t.size, 0))
    return np.column_stack([np.clip(a.voltage.value(t), -a.limit, a.limit)
                            for a in actuators]).reshape(t.size, len(actuators))
