"""The ``[[sensors]]`` section: point sensors and PZT patches, checked against their link."""

from __future__ import annotations

from typing import Any

from .errors import Problems
from .schema import PIEZO, POINT_SENSORS, SENSORS, Field, read_field, read_fields

_PIEZO_MIDDLE = PIEZO.pick("width", "E_p", "d31")
# only a strain gauge has a thickness (its distance from the neutral axis)
_UNSTRAINED_KEYS = tuple(k for k in POINT_SENSORS.keys if k != "thickness")


def read_sensors(
    tables: list[tuple[str, dict[str, Any]]],
    links: list[dict[str, Any]],
    reserved: set[str],
    p: Problems,
) -> list[dict[str, Any]]:
    """Resolved sensor dicts (link by name, strain/piezo thickness filled in from the link).

    ``links`` are the resolved link dicts (possibly incomplete when they had problems);
    ``reserved`` are the automatic channel names a sensor must not take.
    """
    by_name = {lk["name"]: lk for lk in links if "name" in lk}
    out = []
    for path, table in tables:
        name = read_field(table, SENSORS["name"], path, p)
        if name is not None and name in reserved:
            p.add(f"{path}.name {name!r} clashes with an automatic output channel "
                  "(t, time, joint<k>_angle, joint<k>_torque, <link>_tip_X, <link>_tip_Y); choose another")
        kind = read_field(table, SENSORS["kind"], path, p)
        link = link_of(table, path, by_name, p)
        entry: dict[str, Any] = {"name": name, "kind": kind, "link": link and link["name"]}
        if kind == "piezo":
            p.unknown_keys(table, SENSORS.keys + PIEZO.keys, path)
            entry.update(_piezo(table, path, link, p))
        elif kind is not None:
            keys = POINT_SENSORS.keys if kind == "strain" else _UNSTRAINED_KEYS
            p.unknown_keys(table, SENSORS.keys + keys, path)
            entry.update(_point(table, path, kind, link, p))
        out.append({k: v for k, v in entry.items() if v is not None})
    return out


def link_of(table: dict[str, Any], path: str, by_name: dict[str, dict[str, Any]],
             p: Problems) -> dict[str, Any] | None:
    name = read_field(table, SENSORS["link"], path, p)
    if name is None:
        return None
    if name not in by_name:
        known = ", ".join(repr(n) for n in by_name) or "none"
        p.add(f"{path}.link: unknown link {name!r} (known links: {known})")
        return None
    return by_name[name]


def position_on_link(table: dict[str, Any], field: Field, path: str, link: dict[str, Any] | None,
              p: Problems) -> float | None:
    """A position along the link (m), at most the link's length when that is known."""
    value = read_field(table, field, path, p)
    length = link.get("length") if link else None
    if value is not None and length is not None and value > length:
        p.add(f"{path}.{field.key} must be <= {length!r} m (the length of link "
              f"{link['name']!r}), got {value!r}")  # type: ignore[index]
        return None
    return value


def host_thickness(table: dict[str, Any], field: Field, path: str, link: dict[str, Any] | None,
               p: Problems) -> float | None:
    """The host beam thickness (m): given here, else the link's ``thickness``."""
    if "thickness" in table:
        return read_field(table, field, path, p)
    if link is None:  # the unknown link is reported already
        return None
    if link.get("thickness") is None:
        p.add(f"{path}: missing required key 'thickness' (m, > 0; link {link['name']!r} "
              "gives no thickness to default to)")
    return link.get("thickness")


def _point(table: dict[str, Any], path: str, kind: str, link: dict[str, Any] | None,
           p: Problems) -> dict[str, Any]:
    out = {"x": position_on_link(table, POINT_SENSORS["x"], path, link, p)}
    if kind == "strain":
        out["thickness"] = host_thickness(table, POINT_SENSORS["thickness"], path, link, p)
    return out


def _piezo(table: dict[str, Any], path: str, link: dict[str, Any] | None,
           p: Problems) -> dict[str, Any]:
    out = {
        "x_start": position_on_link(table, PIEZO["x_start"], path, link, p),
        "x_end": position_on_link(table, PIEZO["x_end"], path, link, p),
        **read_fields(table, _PIEZO_MIDDLE, path, p),
        "thickness": host_thickness(table, PIEZO["thickness"], path, link, p),
        "capacitance": read_field(table, PIEZO["capacitance"], path, p),
    }
    start, end = out["x_start"], out["x_end"]
    if start is not None and end is not None and start >= end:
        p.add(f"{path}: x_start must be < x_end, got x_start = {start!r} m, x_end = {end!r} m")
    return out
