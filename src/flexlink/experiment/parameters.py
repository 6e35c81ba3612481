"""Parameters to identify, named by path: model fields of the scenario, or the calibration of a
measured channel.

- ``links[0].EI``, ``links[link1].damping_ratio`` — a numeric field of a link (index or name):
  ``EI``, ``damping_ratio``, ``tip_mass``, ``tip_inertia``, ``mass_per_length``;
- ``sensors[pzt].capacitance`` — a numeric field of a sensor (index or name);
- ``pzt:gain``, ``pzt:offset``, ``pzt:drift``, ``pzt:delay`` — the measured channel ``pzt`` is
  compared with ``gain · sim(t − delay) + offset + drift · t`` (charge amplifier gain, zero
  offset and drift in the channel's unit (per s), timing offset in s).

Positive model fields are fitted as log(value / initial): steps are relative, the bounds stay
positive and EI and damping ratios of very different size are conditioned alike. Calibration
values are fitted linearly in units of a typical size (scale).
"""

from __future__ import annotations

import dataclasses
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..model import Scenario
from .files import MeasurementError

LINK_FIELDS = ("EI", "damping_ratio", "tip_mass", "tip_inertia", "mass_per_length")
SENSOR_FIELDS = ("x", "x_start", "x_end", "width", "E_p", "d31", "thickness", "capacitance")
CALIBRATION = ("gain", "offset", "drift", "delay")
_MODEL_PATH = re.compile(r"(links|sensors)\[([^\]]+)\]\.(\w+)")
_CAL_PATH = re.compile(r"(.+):(\w+)")


@dataclass(frozen=True)
class Parameter:
    """One fitted quantity. ``index`` points into links or sensors for model fields;
    ``channel`` names the measured channel for calibration values."""

    path: str
    kind: str  # "links", "sensors" or "calibration"
    field: str
    index: int | None = None
    channel: str | None = None
    lower: float = -math.inf
    upper: float = math.inf
    initial: float | None = None  # None: the scenario's value (model) or a linear estimate
    log: bool = False

    @property
    def is_model(self) -> bool:
        return self.kind != "calibration"


def parse_parameter(text: str, scenario: Scenario, channels: Mapping[str, str],
                    bounds: tuple[float | None, float | None] = (None, None),
                    initial: float | None = None) -> Parameter:
    """A Parameter from its path (see module doc); ``channels`` are the measured channels."""
    path = text.strip()
    model = _MODEL_PATH.fullmatch(path)
    if model:
        section, key, field_name = model.groups()
        items = scenario.chain.links if section == "links" else scenario.sensors
        index = _index(items, key, section, path)
        allowed = LINK_FIELDS if section == "links" else SENSOR_FIELDS
        if field_name not in allowed or not hasattr(items[index], field_name):
            fields = [f for f in allowed if hasattr(items[index], f)]
            raise MeasurementError(f"parameter {path!r}: {section}[{key}] has no fittable field "
                                   f"{field_name!r} (fittable: {', '.join(fields)})")
        value = getattr(items[index], field_name)
        log = value > 0
        lower, upper = _default_bounds(field_name, value)
        param = Parameter(path, section, field_name, index=index, lower=lower, upper=upper,
                          log=log)
    else:
        cal = _CAL_PATH.fullmatch(path)
        if not cal:
            raise MeasurementError(
                f"parameter {path!r}: expected links[i].FIELD, sensors[i].FIELD or "
                f"CHANNEL:{'|'.join(CALIBRATION)} (e.g. links[0].EI, pzt:gain)")
        channel, field_name = cal.groups()
        if field_name not in CALIBRATION:
            raise MeasurementError(f"parameter {path!r}: unknown calibration {field_name!r} "
                                   f"(one of {', '.join(CALIBRATION)})")
        if channel not in channels:
            raise MeasurementError(f"parameter {path!r}: {channel!r} is not a measured channel "
                                   f"(measured: {', '.join(channels) or 'none'})")
        lower, upper = (-0.05, 0.05) if field_name == "delay" else (-math.inf, math.inf)
        param = Parameter(path, "calibration", field_name, channel=channel, lower=lower,
                          upper=upper)
    lo = param.lower if bounds[0] is None else float(bounds[0])
    hi = param.upper if bounds[1] is None else float(bounds[1])
    if not lo < hi:
        raise MeasurementError(f"parameter {path!r}: lower bound {lo:g} must be below the upper "
                               f"bound {hi:g}")
    if param.log and lo <= 0:
        raise MeasurementError(f"parameter {path!r}: the lower bound must be > 0 (it is fitted "
                               f"on a log scale), got {lo:g}")
    return dataclasses.replace(param, lower=lo, upper=hi, initial=initial)


def parse_parameter_option(text: str, scenario: Scenario,
                           channels: Mapping[str, str]) -> Parameter:
    """``PATH``, ``PATH=LOW:HIGH`` or ``PATH=LOW:HIGH:INITIAL`` from the command line."""
    path, sep, rest = text.partition("=")
    if not sep:
        return parse_parameter(path, scenario, channels)
    parts = rest.split(":")
    if len(parts) not in (2, 3):
        raise MeasurementError(f"--param {text!r}: expected PATH=LOW:HIGH[:INITIAL]")
    try:
        values = [float(v) if v.strip() else None for v in parts]
    except ValueError:
        raise MeasurementError(f"--param {text!r}: bounds must be numbers") from None
    return parse_parameter(path, scenario, channels, (values[0], values[1]),
                           values[2] if len(values) == 3 else None)


def parse_parameter_table(entry: Any, where: str, scenario: Scenario,
                          channels: Mapping[str, str]) -> Parameter:
    """From a ``[[fit.parameters]]`` table: path, lower, upper, initial (all but path optional)."""
    if isinstance(entry, str):
        return parse_parameter(entry, scenario, channels)
    if not isinstance(entry, Mapping) or not isinstance(entry.get("path"), str):
        raise MeasurementError(f"{where}: expected a table with path = \"links[0].EI\" and "
                               "optional lower, upper, initial")
    unknown = set(entry) - {"path", "lower", "upper", "initial"}
    if unknown:
        raise MeasurementError(f"{where}: unknown key(s) {', '.join(sorted(unknown))} (allowed: "
                               "path, lower, upper, initial)")
    for key in ("lower", "upper", "initial"):
        value = entry.get(key)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int | float)
                                  or not math.isfinite(value)):
            raise MeasurementError(f"{where}.{key}: expected a finite number, got {value!r}")
    return parse_parameter(entry["path"], scenario, channels,
                           (entry.get("lower"), entry.get("upper")), entry.get("initial"))


def _index(items: Any, key: str, section: str, path: str) -> int:
    key = key.strip().strip("'\"")
    if key.lstrip("-").isdigit():
        index = int(key)
        if not 0 <= index < len(items):
            raise MeasurementError(f"parameter {path!r}: {section} index {index} out of range "
                                   f"(0 … {len(items) - 1})")
        return index
    names = [item.name for item in items]
    if key not in names:
        raise MeasurementError(f"parameter {path!r}: no {section[:-1]} named {key!r} (known: "
                               f"{', '.join(names)})")
    return names.index(key)


def _default_bounds(field_name: str, value: float) -> tuple[float, float]:
    if field_name == "damping_ratio":
        return 1e-4, 0.5
    if value > 0:
        return value / 10.0, value * 10.0
    return -math.inf, math.inf


def model_value(scenario: Scenario, param: Parameter) -> float:
    items = scenario.chain.links if param.kind == "links" else scenario.sensors
    return float(getattr(items[param.index], param.field))  # type: ignore[index]


def with_values(scenario: Scenario, params: list[Parameter], values: list[float]) -> Scenario:
    """``scenario`` with the model parameters set (calibration parameters are ignored)."""
    links = list(scenario.chain.links)
    sensors = list(scenario.sensors)
    for param, value in zip(params, values, strict=True):
        if param.kind == "links":
            links[param.index] = dataclasses.replace(links[param.index],  # type: ignore[index]
                                                     **{param.field: float(value)})
        elif param.kind == "sensors":
            sensors[param.index] = dataclasses.replace(sensors[param.index],  # type: ignore[index]
                                                       **{param.field: float(value)})
    chain = dataclasses.replace(scenario.chain, links=tuple(links))
    return dataclasses.replace(scenario, chain=chain, sensors=tuple(sensors))


def update_resolved(resolved: dict[str, Any], params: list[Parameter],
                    values: list[float]) -> dict[str, Any]:
    """A copy of the resolved scenario dict with the fitted model values written in."""
    import copy

    out = copy.deepcopy(resolved)
    for param, value in zip(params, values, strict=True):
        if param.is_model:
            out[param.kind][param.index][param.field] = float(value)  # type: ignore[index]
    return out
