"""[[closures]]: the joints that close loops of the tree (model/loops.py), read and checked
against the links, joints and settings before anything runs."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .. import model
from .errors import Problems
from .schema import CLOSURES, read_fields


def read_closures(tables: list[tuple[str, dict[str, Any]]], links: list[dict[str, Any]],
                  joints: list[dict[str, Any]], simulation: Mapping[str, Any],
                  taken: set[str], p: Problems
                  ) -> list[dict[str, Any]]:
    """Resolved closure dicts (links by name, points filled in with the links' tips).
    ``taken``: names the closures must not reuse (links, sensors, actuators, automatic
    channels)."""
    if not tables:
        return []
    by_name = {lk["name"]: lk for lk in links if "name" in lk}
    known = ", ".join(repr(n) for n in by_name) or "none"
    out = []
    for path, table in tables:
        p.unknown_keys(table, CLOSURES.keys, path)
        entry = read_fields(table, CLOSURES.fields, path, p)
        if entry["name"] is not None and entry["name"] in taken:
            p.add(f"{path}.name {entry['name']!r} is already a link's, sensor's, actuator's or "
                  "automatic channel's name; choose another")
        for key, x_key in (("link", "x"), ("to_link", "x_to")):
            name = entry[key]
            if name is None:
                continue
            if name not in by_name:
                p.add(f"{path}.{key}: unknown link {name!r} (known links: {known})")
                entry[key] = None
                continue
            length = by_name[name].get("length")
            if entry[x_key] is None:
                entry[x_key] = length
            elif length is not None and entry[x_key] > length * (1 + 1e-12):
                p.add(f"{path}.{x_key} = {entry[x_key]:g} m is beyond link {name!r}'s length "
                      f"{length:g} m")
        kind = entry["kind"]
        if kind == "revolute":
            if ("to_link" in table) == (entry["ground"] is not None):
                p.add(f"{path}: a revolute closure needs either 'to_link' (another link) or "
                      "'ground' (a fixed pivot [x, y] in m), not both")
            if entry.pop("angle_deg") not in (0.0, None):
                p.add(f"{path}.angle_deg: only a slider has a line; drop it")
        elif kind == "slider":
            if "to_link" in table or "x_to" in table:
                p.add(f"{path}: a slider closure runs on a fixed line ('ground', 'angle_deg'); "
                      "drop 'to_link' and 'x_to'")
            if entry["ground"] is None:
                entry["ground"] = [0.0, 0.0]
        if entry["link"] is not None and entry["link"] == entry["to_link"]:
            p.add(f"{path}: 'link' and 'to_link' are the same link {entry['link']!r}")
        out.append({k: v for k, v in entry.items() if v is not None})
    p.check_names([c.get("name") for c in out], "closures")
    if simulation.get("model") == "nonlinear" and simulation.get("step") is not None:
        p.add("closures: closed loops on the nonlinear model run with error-controlled steps; "
              "drop simulation.step")
    movable = [i for i, j in enumerate(joints) if "drive" in j]
    equations = sum(1 if c.get("kind") == "slider" else 2 for c in out)
    if not movable:
        p.add("closures: every joint is prescribed, so nothing can move to close the loop; "
              "give the loop's passive joints drive = \"free\" (and initial_angle_deg near "
              "the closed configuration)")
    elif len(movable) < equations:
        held = ", ".join(f"joints[{i}] (joint{i + 1})" for i, j in enumerate(joints)
                         if "drive" not in j)
        p.add(f"closures: the mechanism has more drives than degrees of freedom: its "
              f"{equations} closure equations need as many joints the dynamics move (drive = "
              f"\"free\", \"torque\" or \"servo\"), it has {len(movable)} — more prescribed "
              f"joints than degrees of freedom (prescribed: {held}); set drive = \"free\" on "
              "the loop's passive joints")
    return out


def build_closure(entry: Mapping[str, Any], index: Mapping[str, int]) -> model.Closure:
    """The model's Closure of a resolved [[closures]] entry."""
    to = entry.get("to_link")
    ground = entry.get("ground", (0.0, 0.0))
    return model.Closure(entry["name"], entry["kind"], index[entry["link"]], float(entry["x"]),
                         index[to] if to is not None else None,
                         float(entry.get("x_to", 0.0)), (float(ground[0]), float(ground[1])),
                         math.radians(entry.get("angle_deg", 0.0)))
