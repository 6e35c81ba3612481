"""One output channel's record: name, kind, unit (UDUNITS spelling) and description.

Values live beside the record (in `Results`, a sweep's arrays), never in it: the record is
what plots, writers, sweeps and the experiment code read to know what a column is.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from enum import StrEnum
from typing import Any, Protocol

import numpy as np


class ChannelKind(StrEnum):
    """What a channel measures; plots and readers select channels by kind, never by name."""

    SENSOR = "sensor"  # a user's [[sensors]] entry
    JOINT = "joint"  # joint angle, rate, torque, servo reference and command
    TIP = "tip"  # global tip position of a link
    BASE = "base"  # pose and rates of a moving base
    MOMENTUM = "momentum"  # linear and angular momentum of a free system
    CONTROLLER = "controller"  # controller states and commands
    CLOSURE = "closure"  # forces of the joints that close loops


class Unit:
    """Unit strings in UDUNITS spelling (what netCDF readers and CF conventions expect)."""

    SECOND = "s"
    METRE = "m"
    RADIAN = "rad"
    ONE = "1"  # dimensionless (strain)
    VOLT = "V"
    METRE_PER_SECOND = "m s-1"
    METRE_PER_SECOND2 = "m s-2"
    RADIAN_PER_SECOND = "rad s-1"
    NEWTON = "N"
    NEWTON_METRE = "N m"
    NEWTON_SECOND = "N s"
    NEWTON_METRE_SECOND = "N m s"


# The unit of each point-sensor kind (model.sensors.PointSensorKind) and of a PZT patch.
SENSOR_UNITS: dict[str, str] = {
    "deflection": Unit.METRE, "slope": Unit.RADIAN, "strain": Unit.ONE,
    "acceleration": Unit.METRE_PER_SECOND2, "piezo": Unit.VOLT,
}


@dataclass(frozen=True)
class Channel:
    """What one output column is: ``name`` (as in results.csv), ``kind``, ``unit`` (UDUNITS),
    a one-line ``description``, the ``quantity`` it measures (``angle``, ``torque``, ``X``,
    a sensor kind …) and the ``subject`` it belongs to (``joint2``, a link's name, ``base``)."""

    name: str
    kind: ChannelKind
    unit: str
    description: str
    quantity: str = ""
    subject: str = ""


def kind_summary(channels: Iterable[Channel]) -> str:
    """How many channels of each kind, in order of first appearance: ``sensor 4, joint 4``."""
    counts: dict[str, int] = {}
    for channel in channels:
        counts[channel.kind.value] = counts.get(channel.kind.value, 0) + 1
    return ", ".join(f"{kind} {count}" for kind, count in counts.items())


class ChannelTable(Protocol):
    """Channels on a time grid, as the readers of results need them (plots, file layouts):
    `flexlink.results.Results` is one."""

    time: np.ndarray
    metadata: dict[str, Any]
    channels: dict[str, Channel]
    created: str

    def __getitem__(self, name: str) -> np.ndarray: ...

    def names_of(self, *kinds: ChannelKind) -> list[str]: ...
