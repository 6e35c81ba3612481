"""Parameters to identify, named by path: a numeric field of the scenario, or the calibration
of a measured channel.

- a field path of `flexlink.scenario.fields`, the grammar sweeps use: ``links[0].EI``,
  ``links[link1].damping_ratio``, ``sensors[pzt].capacitance``, ``links[0].E`` (a link given
  by E, width and thickness: EI follows), ``base.mass``, ``joints[1].P`` — any real-valued
  field the file sets or leaves at its default;
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
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from ..scenario import ScenarioError
from ..scenario.fields import (
    FieldPath,
    FieldPathError,
    ScenarioFile,
    Target,
    format_path,
    is_time_grid,
)
from .files import MeasurementError

CALIBRATION = ("gain", "offset", "drift", "delay")
DAMPING_BOUNDS = (1e-4, 0.5)  # default bounds of a damping ratio
RANGE = 10.0  # default bounds of other positive fields: value / RANGE … value · RANGE
BOUND_STEPS = 30  # bisections that pull a default bound into the scenario's valid range


@dataclass(frozen=True)
class Parameter:
    """One fitted quantity: a model field (``target``, its path with entry names as indices,
    and the scenario's ``value``) or the calibration ``field`` of a measured ``channel``."""

    path: str
    field: str  # the model field's key, or one of CALIBRATION
    target: FieldPath | None = None
    channel: str | None = None
    lower: float = -math.inf
    upper: float = math.inf
    initial: float | None = None  # None: the scenario's value (model) or a linear estimate
    log: bool = False
    value: float | None = None  # the scenario's value of a model field
    unit: str = ""  # UDUNITS unit of its values ("" where the schema spells none)

    @property
    def is_model(self) -> bool:
        return self.target is not None


def parse_parameter(text: str, scenario: ScenarioFile, channels: Mapping[str, str],
                    bounds: tuple[float | None, float | None] = (None, None),
                    initial: float | None = None) -> Parameter:
    """A Parameter from its path (see module doc); ``channels`` are the measured channels."""
    path = text.strip()
    if ":" in path:  # field paths never hold a colon
        param = _calibration(path, channels)
    else:
        param = _model_field(path, scenario, initial, bounds)
    lo = param.lower if bounds[0] is None else float(bounds[0])
    hi = param.upper if bounds[1] is None else float(bounds[1])
    if not lo < hi:
        raise MeasurementError(f"parameter {path!r}: lower bound {lo:g} must be below the upper "
                               f"bound {hi:g}")
    if param.log and lo <= 0:
        raise MeasurementError(f"parameter {path!r}: the lower bound must be > 0 (it is fitted "
                               f"on a log scale), got {lo:g}")
    if param.is_model:
        for bound, given in ((lo, bounds[0]), (hi, bounds[1])):
            if given is not None:
                _check_value(scenario, param, bound, "bound ")
    if initial is not None and not lo <= initial <= hi:  # also NaN
        raise MeasurementError(f"parameter {path!r}: the initial value {initial:g} must lie "
                               f"within its bounds, {lo:g} to {hi:g}")
    return dataclasses.replace(param, lower=lo, upper=hi, initial=initial)


def check_distinct(params: list[Parameter], option: str) -> None:
    """MeasurementError naming two parameters that are one field of the scenario
    (``links[0].EI`` and ``links[link1].EI``)."""
    seen: dict[Any, str] = {}
    for param in params:
        key = param.target if param.target is not None else param.path
        if key in seen:
            raise MeasurementError(f"{option}: {seen[key]!r} and {param.path!r} are the same "
                                   f"field ({format_path(key) if param.target else key}); "
                                   "give it once")
        seen[key] = param.path


def _calibration(path: str, channels: Mapping[str, str]) -> Parameter:
    channel, _, quantity = path.rpartition(":")
    if quantity not in CALIBRATION:
        raise MeasurementError(f"parameter {path!r}: unknown calibration {quantity!r} "
                               f"(one of {', '.join(CALIBRATION)})")
    if channel not in channels:
        raise MeasurementError(f"parameter {path!r}: {channel!r} is not a measured channel "
                               f"(measured: {', '.join(channels) or 'none'})")
    lower, upper = (-0.05, 0.05) if quantity == "delay" else (-math.inf, math.inf)
    return Parameter(path, quantity, channel=channel, lower=lower, upper=upper,
                     unit=calibration_unit(quantity, channels[channel]))


def calibration_unit(quantity: str, channel_unit: str) -> str:
    """UDUNITS unit of a channel's calibration ``quantity``: gain 1, offset the channel's
    unit, drift the channel's unit per second, delay s."""
    if quantity == "gain":
        return "1"
    if quantity == "delay":
        return "s"
    if quantity == "offset":
        return channel_unit
    return per_second(channel_unit)


def per_second(unit: str) -> str:
    """``unit`` divided by s, in UDUNITS spelling: ``V`` → ``V s-1``, ``m s-2`` → ``m s-3``,
    ``1`` → ``s-1``."""
    factors = [] if unit in ("", "1") else unit.split()
    for k, factor in enumerate(factors):
        if factor == "s" or (factor.startswith("s") and factor[1:].lstrip("-").isdigit()):
            power = (int(factor[1:]) if len(factor) > 1 else 1) - 1
            factors[k] = "" if power == 0 else ("s" if power == 1 else f"s{power}")
            return " ".join(f for f in factors if f) or "1"
    return " ".join([*factors, "s-1"])


def _model_field(path: str, scenario: ScenarioFile, initial: float | None,
                 bounds: tuple[float | None, float | None]) -> Parameter:
    """A field of the scenario file, its default bounds inside the scenario's valid range."""
    target = _target(path, scenario)
    value = target.value if target.value is not None else initial
    if value is None:
        raise MeasurementError(
            f"parameter {path}: the scenario does not set {target.key} and it has no default; "
            f"give an initial value (-p {path}=LOW:HIGH:INITIAL, or initial = … in "
            "[[fit.parameters]])")
    value = float(value)
    if value == 0.0 and None in bounds:
        raise MeasurementError(f"parameter {path} is 0 in the scenario: give both bounds "
                               f"(-p {path}=LOW:HIGH) so the fit knows its scale")
    param = Parameter(path, target.key, target.path, value=value, log=value > 0,
                      unit=_field_unit(target))
    _check_value(scenario, param, value, "")
    if target.key == "damping_ratio":
        lower, upper = DAMPING_BOUNDS
    elif value > 0:
        lower, upper = value / RANGE, value * RANGE
    else:
        lower, upper = -math.inf, math.inf
    if bounds[0] is None:  # a given bound is checked as given, never moved
        lower = _valid_bound(scenario, param, lower)
    if bounds[1] is None:
        upper = _valid_bound(scenario, param, upper)
    return dataclasses.replace(param, lower=lower, upper=upper)


def _field_unit(target: Target) -> str:
    from ..simulation.sensitivities import field_unit  # the schema's, as a sweep's parameters

    return field_unit(target)


def _target(path: str, scenario: ScenarioFile) -> Target:
    try:
        target = scenario.locate(path)
    except FieldPathError as exc:
        raise MeasurementError(f"parameter {exc}") from None
    if is_time_grid(target.path):
        raise MeasurementError(f"parameter {path} cannot be fitted: the measurement is compared "
                               "on the simulation's time grid (set it in the scenario)")
    if target.integer:
        raise MeasurementError(f"parameter {path}: {target.key} takes integers; only "
                               "real-valued fields can be fitted (sweep it instead)")
    return target


def _check_value(scenario: ScenarioFile, param: Parameter, value: float, what: str) -> None:
    """Raise MeasurementError when the scenario is invalid with ``param`` at ``value``."""
    try:
        scenario.build({param.target: value})  # type: ignore[dict-item]
    except ScenarioError as exc:
        raise MeasurementError(f"parameter {param.path}: at the {what}value {value:g} the "
                               f"scenario is invalid: {'; '.join(exc.problems)}") from None


def _valid_bound(scenario: ScenarioFile, param: Parameter, bound: float) -> float:
    """``bound``, or the valid value nearest to it found by bisection towards the scenario's
    value (a sensor at the tip of a link cannot move by ten times its position)."""
    if not math.isfinite(bound) or _valid(scenario, param, bound):
        return bound
    good, bad = float(param.value), bound  # type: ignore[arg-type]
    for _ in range(BOUND_STEPS):
        middle = math.sqrt(good * bad) if param.log else 0.5 * (good + bad)
        good, bad = (middle, bad) if _valid(scenario, param, middle) else (good, middle)
    return good


def _valid(scenario: ScenarioFile, param: Parameter, value: float) -> bool:
    try:
        scenario.build({param.target: value})  # type: ignore[dict-item]
    except ScenarioError:
        return False
    return True


def model_values(params: list[Parameter], values: list[float]) -> dict[FieldPath, float]:
    """{path: value} of the model fields among ``params`` (calibration values left out)."""
    return {p.target: float(v) for p, v in zip(params, values, strict=True)
            if p.target is not None}


def parse_parameter_option(text: str, scenario: ScenarioFile,
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


def parse_parameter_table(entry: Any, where: str, scenario: ScenarioFile,
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
