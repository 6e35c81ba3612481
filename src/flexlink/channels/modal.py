"""Readings that are the same function of a link's modal coordinates q in every model: a PZT
patch (paper eq. 37), the section rotation ψ = Φ′q, and the surface strain −(h/2) Φ″q (the
exact curvature of the inextensible axis, docs/nonlinear.md)."""

from __future__ import annotations

import numpy as np

from ..model import Chain, PiezoSensor, PointSensor, Sensor
from ..modes import ModeShapes


def modal_reading(sensor: Sensor, shapes: ModeShapes, q: np.ndarray,
                  chain: Chain) -> np.ndarray | None:
    """The reading (nt,) from q (nt, n_k) of the sensor's link, or None for the kinds whose
    reading depends on the model (deflection, acceleration)."""
    if isinstance(sensor, PiezoSensor):
        slopes = shapes.evaluate(np.array([sensor.x_start, sensor.x_end]), 1)
        return sensor.gain * (q @ (slopes[1] - slopes[0]))
    x = np.array([sensor.x])
    if sensor.kind == "slope":
        return q @ shapes.evaluate(x, 1)[0]
    if sensor.kind == "strain":
        return -0.5 * strain_thickness(sensor, chain) * (q @ shapes.evaluate(x, 2)[0])
    return None


def strain_thickness(sensor: PointSensor, chain: Chain) -> float:
    """The section depth h (m) a strain gauge reads at: its own, else its link's."""
    h = sensor.thickness if sensor.thickness is not None else chain.links[sensor.link].thickness
    if h is None:
        raise ValueError(f"strain sensor {sensor.name!r} needs a thickness")
    return h
