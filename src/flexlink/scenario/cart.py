"""Scenario keys of a cart base: the ``[base.cart]`` table (its rail, travel and drive).

Same contract as drives.py: every problem is collected in `Problems`, the resolved dict keeps
every default, and `build_cart` makes the model from it. Lengths are metres; the rail's angle
is written in degrees and converted here.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from .. import model
from .drives import build_history, read_history
from .errors import REQUIRED, Problems, describe
from .schema import CART, CART_PROFILE, CART_PROFILES, read_field, read_fields

_COMMON = ("rail_angle_deg", "travel", "drive")
_OWN = {"free": ("initial_position", "initial_velocity"),
        "force": ("force", "initial_position", "initial_velocity"),
        "prescribed": ("motion",),
        "servo": ("servo", "reference", "loop_gain", "force_limit")}
_SERVO_OWN = {"position": ("bandwidth", "rate_limit"),
              "velocity_pid": ("P", "I", "D", "saturation_V", "rate_per_volt")}
_REQUIRED = {"force", "motion", "servo", "reference", "loop_gain", "bandwidth", "rate_limit",
             "P", "rate_per_volt"}


def read_cart(table: Any, path: str, base_dir: Path, t_end: float | None,
              p: Problems, rail_keys: tuple[str, ...] = ("rail_angle_deg",)
              ) -> dict[str, Any]:
    """The resolved ``[base.cart]`` table; a prescribed travel (or a start) outside
    ``travel`` over [0, t_end] is a problem naming the field. ``rail_keys``: the keys an
    unknown key is matched against in place of ``rail_angle_deg`` (a slider's own)."""
    if not isinstance(table, Mapping):
        p.add(f"{path}: expected a table [base.cart] with the rail and the drive, got "
              f"{describe(table)}")
        return {}
    out = read_fields(table, CART.pick(*_COMMON), path, p)
    drive = out["drive"]
    own = _OWN.get(drive, ())
    servo = None
    if drive == "servo":
        servo = read_field(table, CART["servo"], path, p, default=REQUIRED)
        own = own + _SERVO_OWN.get(servo, ())
    p.unknown_keys(table, (*rail_keys, *_COMMON[1:], *own), path)
    if drive is None:
        return out
    if servo is not None:
        out["servo"] = servo
    scalars = [CART[k] for k in own if CART[k].kind not in ("history", "profiles", "string")]
    out.update(read_fields(table, scalars, path, p, defaults={
        k: REQUIRED for k in own if k in _REQUIRED}))
    for key in own:
        if CART[key].kind == "history":
            if key not in table:
                p.add(f"{path}: drive = \"force\" needs 'force', an array of segments (N)")
            else:
                out[key] = read_history(table[key], f"{path}.{key}", base_dir, p)
        elif CART[key].kind == "profiles":
            if key not in table:
                p.add(f"{path}: drive = {drive!r} needs {key!r}, an array of travel profiles "
                      "like [{ profile = \"cycloidal\", from = 0.0, to = 0.3, start = 0.0, "
                      "duration = 1.0 }] (m)")
            else:
                out[key] = _profiles(table[key], f"{path}.{key}", p)
    travel = out["travel"]
    if travel is not None and not travel[0] < travel[1]:
        p.add(f"{path}.travel: need lower < upper, got {travel} m")
    out = {k: v for k, v in out.items() if v is not None}
    if len(p.messages) == 0 and t_end is not None:
        try:
            build_cart(out).check_travel(t_end)
        except ValueError as exc:
            message = str(exc).replace("(base.travel)", f"({path}.travel)")
            for key in ("motion", "reference"):
                message = message.replace(f"base.{key}:", f"{path}.{key}:")
            p.add(message if message.startswith(path) else f"{path}: "
                  + message.removeprefix("base: "))
    return out


def _profiles(value: Any, path: str, p: Problems) -> list[dict[str, Any]]:
    """An array of travel profiles (m), each checked; a Sequence is checked at build."""
    if not isinstance(value, list) or not value:
        p.add(f"{path}: expected a non-empty array of travel profiles, got {describe(value)}")
        return []
    before = len(p.messages)
    out = []
    for i, seg in enumerate(value):
        where = f"{path}[{i}]"
        if not isinstance(seg, Mapping):
            p.add(f"{where}: expected a table like {{profile = \"hold\", position = 0.0}}, got "
                  f"{describe(seg)}")
            continue
        profile = read_field(seg, CART_PROFILE, where, p)
        if profile is None:
            continue
        section = CART_PROFILES[profile]
        p.unknown_keys(seg, ("profile", *section.keys), where)
        out.append({"profile": profile, **read_fields(seg, section.fields, where, p)})
    if before == len(p.messages):
        try:
            _motion(out)
        except ValueError as exc:
            p.add(f"{path}: {exc}".replace("_deg", "").replace(" deg", " m"))
    return out


def _motion(segments: list[dict[str, Any]]) -> model.JointMotion:
    """The cart's travel s(t) (m) of resolved profiles."""
    from ..motion import Cycloidal, Hold, Quintic, Sequence, Travel

    parts: list[Any] = []
    for s in segments:
        if s["profile"] == "hold":
            parts.append(Hold(s["position"]))
        else:
            cls = Cycloidal if s["profile"] == "cycloidal" else Quintic
            parts.append(cls(s["from"], s["to"], s["start"], s["duration"]))
    return Travel(parts[0] if len(parts) == 1 else Sequence(tuple(parts)))


def build_cart(entry: Mapping[str, Any]) -> model.Cart:
    """The model.Cart of a resolved ``[base.cart]`` table."""
    drive: model.Joint
    kind = entry["drive"]
    limit = entry.get("force_limit", math.inf)
    if kind in ("free", "force"):
        force = model.ZERO
        if kind == "force":
            force = build_history(entry["force"])
        drive = model.TorqueDrive(force, entry["initial_position"], entry["initial_velocity"])
    elif kind == "prescribed":
        drive = _motion(entry["motion"])
    elif entry["servo"] == "position":
        drive = model.PositionServo(_motion(entry["reference"]), entry["bandwidth"],
                                    entry["rate_limit"], entry["loop_gain"], limit)
    else:
        drive = model.VelocityServo(_motion(entry["reference"]), entry["P"], entry["I"],
                                    entry["D"],
                                    entry["saturation_V"], entry["rate_per_volt"],
                                    entry["loop_gain"], limit)
    travel = entry.get("travel")
    return model.Cart(drive, math.radians(entry["rail_angle_deg"]),
                      (-math.inf, math.inf) if travel is None else (travel[0], travel[1]))
