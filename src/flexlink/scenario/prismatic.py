"""Scenario keys of a slider inside a chain: a ``[[joints]]`` table with ``type =
"prismatic"`` (schema.PRISMATIC) whose other keys are a cart's travel and drive
(``[base.cart]`` without ``rail_angle_deg``, read by cart.py: one reader of drives in
metres). Same contract as load.py: every problem is collected before anything runs."""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .. import model
from ..model.prismatic import slider_message
from .cart import build_cart, read_cart
from .errors import Problems
from .schema import PRISMATIC, read_fields


def read_prismatic(table: Mapping[str, Any], path: str, base_dir: Path, t_end: float | None,
                   p: Problems) -> tuple[dict[str, Any], model.PrismaticJoint | None]:
    """The resolved table and the model of a slider; a start, prescribed travel or servo
    reference outside ``travel`` is a problem naming the key and the time."""
    own = read_fields(table, PRISMATIC.fields, path, p)
    if "rail_angle_deg" in table:
        p.add(f"{path}: unknown key 'rail_angle_deg' (a slider's line is 'axis_angle_deg', "
              "from the parent link's tip section)")
    rest = {k: v for k, v in table.items() if k not in (*PRISMATIC.keys, "rail_angle_deg")}
    inner = Problems()
    drive = read_cart(rest, path, base_dir, t_end, inner, PRISMATIC.keys)
    for message in inner.messages:
        p.add(slider_message(message, path).replace(f"{path}: the cart", f"{path}: the slider"))
    drive.pop("rail_angle_deg", None)
    entry = {**{k: v for k, v in own.items() if k != "line_at" or v is not None}, **drive}
    if inner or None in (v for k, v in own.items() if k != "line_at"):
        return entry, None
    cart = build_cart({**drive, "rail_angle_deg": 0.0})
    return entry, model.PrismaticJoint(cart.drive, math.radians(own["axis_angle_deg"]),
                                       math.radians(own["link_angle_deg"]), cart.travel,
                                       own["mass"], own["line_at"])


def check_sliders(joint_tables: list[tuple[str, Any]], base: Mapping[str, Any] | None,
                  simulation: Mapping[str, Any], closures: list[Any], controllers: list[Any],
                  p: Problems, links: list[Any] = ()) -> None:
    """What a slider is not combined with (model.prismatic.check_slider), and a line point
    off its parent (``links``: the resolved link tables), as problems naming the joint and
    the field."""
    for k, (path, table) in enumerate(joint_tables):
        if not isinstance(table, Mapping) or table.get("type") != "prismatic":
            continue
        if k == 0 or "base_point" in table:
            p.add(f"{path}: a slider rides on the tip of the link before it; the first joint "
                  "of a branch cannot be one (a slider on the ground is a cart: [base] type = "
                  "\"cart\")")
        at = table.get("line_at")
        parent = links[k - 1] if 0 < k <= len(links) else None
        length = parent.get("length") if isinstance(parent, Mapping) else None
        if (isinstance(at, int | float) and not isinstance(at, bool) and length is not None
                and at > length):
            p.add(f"{path}.line_at: {at:g} m is beyond the parent link's length {length:g} m "
                  f"(links[{k - 1}].length); give a point in [0, {length:g}] m")


__all__ = ["check_sliders", "read_prismatic"]
