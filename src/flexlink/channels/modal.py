"""Readings that are the same function of a link's modal coordinates q in every model: a PZT
patch (paper eq. 37), the section rotation ψ = Φ′q, and the surface strain −(h/2) Φ″q (the
exact curvature of the inextensible axis, docs/nonlinear.md)."""

from __future__ import annotations

import functools

import numpy as np

from ..model import Chain, PiezoSensor, PointSensor, Sensor
from ..modes import ModeShapes


def modal_reading(sensor: Sensor, shapes: ModeShapes, q: np.ndarray,
                  chain: Chain) -> np.ndarray | None:
    """The reading (nt,) from q (nt, n_k) of the sensor's link, or None for the kinds whose
    reading depends on the model (deflection, acceleration)."""
    if isinstance(sensor, PiezoSensor):
        return sensor.gain * (q @ (shape_row(shapes, sensor.x_end, 1)
                                   - shape_row(shapes, sensor.x_start, 1)))
    if sensor.kind == "slope":
        return q @ shape_row(shapes, sensor.x, 1)
    if sensor.kind == "strain":
        return -0.5 * strain_thickness(sensor, chain) * (q @ shape_row(shapes, sensor.x, 2))
    return None


@functools.lru_cache(maxsize=256)
def shape_row(shapes: ModeShapes, x: float, derivative: int) -> np.ndarray:
    """Φ or its derivative at one point x (m), (n,), read-only: what a sensor reads its
    modal coordinates with. Remembered per mode shapes (compared by identity; a link's
    shapes are shared by its runs), since evaluating them cost more than the reading."""
    row = shapes.evaluate(np.array([x]), derivative)[0]
    row.flags.writeable = False
    return row


def strain_thickness(sensor: PointSensor, chain: Chain) -> float:
    """The section depth h (m) a strain gauge reads at: its own, else its link's."""
    h = sensor.thickness if sensor.thickness is not None else chain.links[sensor.link].thickness
    if h is None:
        raise ValueError(f"strain sensor {sensor.name!r} needs a thickness")
    return h
