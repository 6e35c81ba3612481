"""The ``[[actuators]]`` section: piezo patches driven by a voltage, checked against their link
(the patch keys as a piezo sensor's, `sensors.py`), or copied from a collocated sensor."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from .. import model
from .drives import build_history, read_history
from .errors import Problems
from .schema import ACTUATORS, read_field
from .sensors import host_thickness, link_of, position_on_link

# the patch keys a collocated sensor provides
_PATCH = ("x_start", "x_end", "width", "E_p", "d31", "thickness")


def read_actuators(
    tables: list[tuple[str, dict[str, Any]]],
    links: list[dict[str, Any]],
    sensors: list[dict[str, Any]],
    base_dir: Path,
    p: Problems,
) -> list[dict[str, Any]]:
    """Resolved actuator dicts (link by name, thickness filled in, collocated keys copied)."""
    by_name = {lk["name"]: lk for lk in links if "name" in lk}
    sensor_by_name = {s.get("name"): s for s in sensors}
    out = []
    for path, table in tables:
        p.unknown_keys(table, ACTUATORS.keys, path)
        name = read_field(table, ACTUATORS["name"], path, p)
        read_field(table, ACTUATORS["kind"], path, p)
        source = read_field(table, ACTUATORS["collocated_with"], path, p)
        if source is not None:
            table = _collocated(table, source, sensor_by_name, path, p)
            if table is None:
                out.append({"name": name})
                continue
        elif "link" not in table:
            p.add(f"{path}: missing required key 'link' (the `name` of a link), or give "
                  "collocated_with = \"<piezo sensor name>\"")
        link = link_of(table, path, by_name, p) if "link" in table else None
        entry: dict[str, Any] = {"name": name, "kind": "piezo", "link": link and link["name"]}
        for key in ("x_start", "x_end"):
            if key not in table:
                p.add(f"{path}: missing required key '{key}' (m)")
            else:
                entry[key] = position_on_link(table, ACTUATORS[key], path, link, p)
        for key in ("width", "E_p", "d31"):
            if key not in table:
                p.add(f"{path}: missing required key '{key}' ({ACTUATORS[key].unit})")
            else:
                entry[key] = read_field(table, ACTUATORS[key], path, p)
        entry["thickness"] = host_thickness(table, ACTUATORS["thickness"], path, link, p)
        start, end = entry.get("x_start"), entry.get("x_end")
        if start is not None and end is not None and start >= end:
            p.add(f"{path}: x_start must be < x_end, got x_start = {start!r} m, "
                  f"x_end = {end!r} m")
        entry["limit"] = read_field(table, ACTUATORS["limit"], path, p)
        if "voltage" in table:
            entry["voltage"] = read_history(table["voltage"], f"{path}.voltage", base_dir, p)
        if source is not None:
            entry["collocated_with"] = source
        out.append({k: v for k, v in entry.items() if v is not None})
    return out


def _collocated(table: dict[str, Any], source: str, sensors: dict[str, dict[str, Any]],
                path: str, p: Problems) -> dict[str, Any] | None:
    """The table with the patch keys of the piezo sensor ``source`` filled in; a key given
    here with another value is refused."""
    sensor = sensors.get(source)
    if sensor is None or sensor.get("kind") != "piezo":
        known = ", ".join(repr(n) for n, s in sensors.items() if s.get("kind") == "piezo")
        p.add(f"{path}.collocated_with: {source!r} is not a piezo sensor "
              f"(piezo sensors: {known or 'none'})")
        return None
    merged = dict(table)
    for key in ("link", *_PATCH):
        if key not in sensor:
            continue
        if key in table and table[key] != sensor[key]:
            p.add(f"{path}.{key} = {table[key]!r} conflicts with collocated_with = {source!r} "
                  f"(its {key} is {sensor[key]!r}): leave {key} out or change it there")
        merged[key] = sensor[key]
    return merged


def build_actuator(entry: dict[str, Any], link_index: dict[str, int]) -> model.PiezoActuator:
    voltage = build_history(entry["voltage"]) if "voltage" in entry else model.ZERO
    return model.PiezoActuator(entry["name"], link_index[entry["link"]], entry["x_start"],
                               entry["x_end"], entry["width"], entry["E_p"], entry["d31"],
                               entry["thickness"], voltage, entry.get("limit", float("inf")))
