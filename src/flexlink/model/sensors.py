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
class PiezoPatch:
    """A PZT patch bonded on one link between x_start and x_end (m, from the link's joint),
    in the pin-force model: the patch and the host's surface exchange a moment pair of
    w_p E_p d31 (t/2) per volt at the patch ends (paper eq. 37). Read as a sensor
    (`PiezoSensor`) or driven as an actuator (`model.actuators.PiezoActuator`)."""

    name: str
    link: int  # index into Chain.links
    x_start: float  # m
    x_end: float  # m
    width: float  # m, patch width w_p
    E_p: float  # Pa
    d31: float  # m/V
    thickness: float  # m, host beam thickness t

    @property
    def moment_per_volt(self) -> float:
        """Moment of the pair per volt, N·m/V."""
        return self.width * self.E_p * self.d31 * 0.5 * self.thickness


@dataclass(frozen=True)
class PiezoSensor(PiezoPatch):
    """A PZT patch read through a charge amplifier (paper eq. 37):

    v = w_p E_p d31 (t/2) [w'(x_end) − w'(x_start)] / C_c   [V].
    """

    capacitance: float  # F, charge-amplifier capacitance C_c

    @property
    def gain(self) -> float:
        """Volts per radian of slope difference."""
        return self.moment_per_volt / self.capacitance


Sensor = PointSensor | PiezoSensor
