"""The ``[[controllers]]`` section: sampled feedback loops from sensors to actuators.

kind = "ppf" | "srf" (one sensor, one actuator) or "lti" (matrices). Every bad input is
refused naming its field: unknown sensor or actuator names, matrix sizes, a sample rate
≤ 0 or a filter above the Nyquist frequency, gains whose sign makes no sense. Joint PID
loops are servo drives of [[joints]] (drive = "servo"), not controllers.
"""

from __future__ import annotations

import math
from typing import Any

from .. import model
from .errors import Problems, describe
from .schema import CONTROLLER_SISO, CONTROLLERS, LTI, PPF, read_field, read_fields

_OWN = {"ppf": CONTROLLER_SISO.keys + PPF.keys, "srf": CONTROLLER_SISO.keys, "lti": LTI.keys}
_COMMON = CONTROLLERS.pick("sample_rate", "noise_seed")


def read_controllers(
    tables: list[tuple[str, dict[str, Any]]],
    sensors: list[dict[str, Any]],
    actuators: list[dict[str, Any]],
    p: Problems,
) -> list[dict[str, Any]]:
    """Resolved controller dicts (matrices as lists of rows)."""
    sensor_kinds = {s.get("name"): s.get("kind") for s in sensors}
    actuator_names = [a.get("name") for a in actuators]
    out = []
    for path, table in tables:
        name = read_field(table, CONTROLLERS["name"], path, p)
        kind = read_field(table, CONTROLLERS["kind"], path, p)
        p.unknown_keys(table, CONTROLLERS.keys + _OWN.get(kind, ()), path)
        entry: dict[str, Any] = {"name": name, "kind": kind,
                                 **read_fields(table, _COMMON, path, p)}
        if kind in ("ppf", "srf"):
            entry.update(read_fields(table, CONTROLLER_SISO.fields, path, p))
            if kind == "ppf":
                entry.update(read_fields(table, PPF.fields, path, p))
            _known(entry["sensor"], sensor_kinds, f"{path}.sensor", "sensor", p)
            _known(entry["actuator"], actuator_names, f"{path}.actuator", "actuator", p)
            inputs = [entry["sensor"]]
            rate, f = entry.get("sample_rate"), entry.get("frequency_hz")
            if kind == "ppf" and rate is not None and f is not None and f >= 0.5 * rate:
                p.add(f"{path}.sample_rate = {rate:g} Hz is too low for frequency_hz = {f:g} "
                      f"Hz: it must exceed twice the filter frequency (ten times or more "
                      "is advisable)")
        elif kind == "lti":
            inputs = _names(table, "inputs", path, p) or []
            outputs = _names(table, "outputs", path, p) or []
            for i, s in enumerate(inputs):
                _known(s, sensor_kinds, f"{path}.inputs[{i}]", "sensor", p)
            for i, a in enumerate(outputs):
                _known(a, actuator_names, f"{path}.outputs[{i}]", "actuator", p)
            entry.update(inputs=inputs, outputs=outputs,
                         **_matrices(table, len(inputs), len(outputs), path, p))
        else:
            inputs = []
        for key in ("noise_std", "quantization"):
            if key in table:
                entry[key] = _vector(table, key, len(inputs), path, p)
        out.append({k: v for k, v in entry.items() if v is not None})
    return out


def _known(name: str | None, known: Any, field: str, what: str, p: Problems) -> None:
    if name is None:
        return
    if name not in known:
        listed = ", ".join(repr(n) for n in known if n is not None) or "none"
        p.add(f"{field}: unknown {what} {name!r} (known: {listed})")
    elif what == "sensor" and known[name] == "acceleration":
        p.add(f"{field}: sensor {name!r} is an accelerometer, whose reading is not available "
              "at a sample instant in this model; use a piezo, strain, slope or deflection "
              "sensor")


def _names(table: dict[str, Any], key: str, path: str, p: Problems) -> list[str] | None:
    value = table.get(key)
    if not (isinstance(value, list) and value and all(isinstance(v, str) for v in value)):
        p.add(f"{path}.{key}: expected a non-empty array of names, got {describe(value)}")
        return None
    return list(value)


def _vector(table: dict[str, Any], key: str, size: int, path: str,
            p: Problems) -> list[float] | None:
    value = table[key]
    if isinstance(value, int | float) and not isinstance(value, bool):
        value = [value] * max(size, 1)
    ok = isinstance(value, list) and all(
        isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v) and v >= 0
        for v in value)
    if not ok:
        p.add(f"{path}.{key}: expected a number ≥ 0 or an array of them, got {describe(value)}")
        return None
    if len(value) != size:
        p.add(f"{path}.{key}: expected {size} values (one per input), got {len(value)}")
        return None
    return [float(v) for v in value]


def _matrices(table: dict[str, Any], ni: int, no: int, path: str,
              p: Problems) -> dict[str, Any]:
    """A, B, C, D as lists of rows, their sizes checked against each other and the
    numbers of inputs and outputs."""
    out: dict[str, Any] = {}
    for key in ("A", "B", "C", "D"):
        value = table.get(key)
        if value is None:
            continue
        ok = (isinstance(value, list) and all(
            isinstance(row, list) and all(isinstance(v, int | float) and not isinstance(v, bool)
                                          and math.isfinite(v) for v in row) for row in value)
            and len({len(row) for row in value}) <= 1)
        if not ok:
            p.add(f"{path}.{key}: expected an array of rows of equal length, each an array of "
                  f"finite numbers, got {describe(value)}")
            return {}
        out[key] = [[float(v) for v in row] for row in value]
    n = len(out.get("A", []))
    shape = {"A": (n, n), "B": (n, ni), "C": (no, n), "D": (no, ni)}
    meaning = {"A": "states × states", "B": "states × inputs", "C": "outputs × states",
               "D": "outputs × inputs"}
    for key, (rows, cols) in shape.items():
        if key not in out:
            if rows and cols and key != "D":
                p.add(f"{path}: missing key '{key}' ({rows} × {cols}: {meaning[key]}) for "
                      f"the {n}-state controller")
            out[key] = [[0.0] * cols for _ in range(rows)]
            continue
        got = (len(out[key]), len(out[key][0]) if out[key] else 0)
        if got != (rows, cols) and not (rows * cols == 0 and got[0] * got[1] == 0):
            p.add(f"{path}.{key}: expected {rows} × {cols} ({meaning[key]}; {n} states from "
                  f"A, {ni} inputs, {no} outputs), got {got[0]} × {got[1]}")
    return out


def build_controller(entry: dict[str, Any]) -> model.Controller:
    common = {"noise_std": tuple(entry.get("noise_std", ())),
              "quantization": tuple(entry.get("quantization", ())),
              "noise_seed": entry["noise_seed"]}
    if entry["kind"] == "ppf":
        return model.PositivePositionFeedback(
            entry["name"], entry["sensor"], entry["actuator"], entry["frequency_hz"],
            entry["damping"], entry["gain"], entry["sample_rate"], **common)
    if entry["kind"] == "srf":
        return model.StrainRateFeedback(entry["name"], entry["sensor"], entry["actuator"],
                                        entry["gain"], entry["sample_rate"], **common)

    def rows(key: str) -> tuple[tuple[float, ...], ...]:
        return tuple(tuple(r) for r in entry[key])

    return model.DiscreteLTI(entry["name"], tuple(entry["inputs"]), tuple(entry["outputs"]),
                             rows("A"), rows("B"), rows("C"), rows("D"), entry["sample_rate"],
                             **common)
