"""Sensors: where on which link a channel is read, and with what transducer constants."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

PointSensorKind = Literal["deflection", "slope", "strain", "acceleration"]
POINT_SENSOR_KINDS: tuple[str, ...] = get_args(PointSensorKind)


@dataclass(frozen=True)
class PointSensor:
    """A sensor at a material point x (m, from the link's joint) of one link.

    kinds: ``deflection`` w(x) [m], ``slope`` w'(x) [rad], ``strain`` surface bending strain
    on the link's +y face, −(h/2)·w''(x) [-], ``acceleration`` absolute acceleration of the
    point along the deformed normal [m/s²].
    """

    name: str
    kind: PointSensorKind
    link: int  # index into Chain.links
    x: float
    thickness: float | None = None  # m, for strain (defaults to the link's thickness)


@dataclass(frozen=True)
class PiezoSensor:
    """A PZT patch read through the pin-force model (paper eq. 37):

    v = w_p E_p d31 (t/2) [w'(x_end) − w'(x_start)] / C_c   [V].
    """

    name: str
    link: int
    x_start: float  # m
    x_end: float  # m
    width: float  # m, patch width w_p
    E_p: float  # Pa
    d31: float  # m/V
    thickness: float  # m, host beam thickness t
    capacitance: float  # F, charge-amplifier capacitance C_c

    @property
    def gain(self) -> float:
        """Volts per radian of slope difference."""
        return self.width * self.E_p * self.d31 * 0.5 * self.thickness / self.capacitance


Sensor = PointSensor | PiezoSensor
