"""Scenario keys of the forward dynamics: ``[base]`` and driven ``[[joints]]``.

Same contract as load.py: every problem is collected in `Problems`, the resolved dict keeps
every default (and absolute CSV paths), and building from the resolved dict gives the model.
Angles are written in degrees and converted here, once.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from .. import model
from ..model import JointMotion
from .errors import REQUIRED, Problems, describe
from .schema import (
    BASE,
    DRIVE,
    HISTORIES,
    HISTORY_CSV,
    HISTORY_PROFILE,
    LOADS,
    POSITION,
    SERVO,
    TORQUE,
    VELOCITY_PID,
    read_field,
    read_fields,
)

_BASE_FIELDS = BASE.pick("mass", "inertia", "position", "attitude_deg", "velocity", "rate_deg_s")
_SERVOS = {"velocity_pid": VELOCITY_PID, "position": POSITION}
_SERVO_COMMON = set(VELOCITY_PID.keys) & set(POSITION.keys)
_TORQUE_INITIAL = TORQUE.pick("initial_angle_deg", "initial_rate_deg_s")
# read first: the keys of one servo only (its gains)
_SERVO_OWN = {name: tuple(f for f in s.fields if f.key not in _SERVO_COMMON)
              for name, s in _SERVOS.items()}

SegmentReader = Callable[[Any, str, Problems], tuple[dict[str, Any], JointMotion | None]]


def read_base(raw: Any, base_dir: Path, p: Problems) -> dict[str, Any] | None:
    """The resolved ``[base]`` table, or None if absent (a cart's ``[base.cart]`` table is
    read by scenario/cart.py)."""
    if raw is None:
        return None
    if not isinstance(raw, Mapping):
        p.add(f"base: expected a table [base], got {describe(raw)}")
        return None
    path = "base"
    p.unknown_keys(raw, BASE.keys, path)
    kind = read_field(raw, BASE["type"], path, p)
    moving = kind in ("free", "pinned")
    out: dict[str, Any] = {"type": kind, **read_fields(raw, _BASE_FIELDS, path, p, defaults={
        "mass": REQUIRED if kind in ("free", "cart") else None,
        "inertia": REQUIRED if moving else None})}
    if kind == "pinned" and (out["position"] != [0.0, 0.0] or out["velocity"] != [0.0, 0.0]):
        p.add("base: a pinned base turns about its fixed reference point: position and "
              "velocity must be [0, 0] (give type = \"free\" to let it translate)")
    if kind == "fixed" and (out["attitude_deg"] or out["rate_deg_s"] or "loads" in raw):
        p.add("base: a fixed base does not move: attitude_deg, rate_deg_s and loads need "
              "type = \"free\" or \"pinned\"")
    if kind == "cart":
        if out["velocity"] != [0.0, 0.0] or out["rate_deg_s"] or "inertia" in raw:
            p.add("base: a cart moves along its rail only: give its initial speed as "
                  "base.cart.initial_velocity, and no velocity, rate_deg_s or inertia")
        if "cart" not in raw:
            p.add("base: type = \"cart\" needs a [base.cart] table (the rail and the drive)")
    elif "cart" in raw:
        p.add("base.cart: only a base with type = \"cart\" takes a [base.cart] table")
    loads = raw.get("loads", [])
    if not isinstance(loads, list):
        p.add(f"base.loads: expected an array of tables [[base.loads]], got {describe(loads)}")
        loads = []
    out["loads"] = [_load(t, f"base.loads[{i}]", base_dir, p) for i, t in enumerate(loads)]
    return {k: v for k, v in out.items() if v is not None}


def _load(table: Any, path: str, base_dir: Path, p: Problems) -> dict[str, Any]:
    if not isinstance(table, Mapping):
        p.add(f"{path}: expected a table, got {describe(table)}")
        return {}
    p.unknown_keys(table, LOADS.keys, path)
    out: dict[str, Any] = {f.key: read_history(table[f.key], f"{path}.{f.key}", base_dir, p)
                           for f in LOADS.fields if f.kind == "history" and f.key in table}
    if not out:
        p.add(f"{path}: give at least one of force_x, force_y (N) or moment (N·m), each an "
              "array of segments like [{ profile = \"bang_bang\", amplitude = 1.0, start = 0.0, "
              "duration = 10.0 }]")
    out.update(read_fields(table, LOADS.pick("point", "frame"), path, p))
    return out


def read_history(value: Any, path: str, base_dir: Path, p: Problems) -> list[dict[str, Any]]:
    """An input history: a non-empty array of segments, summed."""
    if not isinstance(value, list) or not value:
        p.add(f"{path}: expected a non-empty array of segments, e.g. [{{ profile = "
              f"\"bang_bang\", amplitude = 1.0, start = 0.0, duration = 10.0 }}], "
              f"got {describe(value)}")
        return []
    return [_segment(s, f"{path}[{i}]", base_dir, p) for i, s in enumerate(value)]


def _segment(seg: Any, path: str, base_dir: Path, p: Problems) -> dict[str, Any]:
    if not isinstance(seg, Mapping):
        p.add(f"{path}: expected a table, got {describe(seg)}")
        return {}
    if "csv" in seg:
        p.unknown_keys(seg, HISTORY_CSV.keys, path)
        out = read_fields(seg, HISTORY_CSV.fields, path, p)
        if out["csv"] is not None:
            out["csv"] = str((base_dir / out["csv"]).resolve())
        if out["csv"] is not None and not Path(out["csv"]).is_file():
            p.add(f"{path}.csv: file not found: {out['csv']} (paths are relative to the "
                  "scenario file's folder)")
        elif None not in out.values():
            try:
                _csv_table(out)
            except ValueError as exc:
                p.add(f"{path}.csv: {exc}")
        return {k: v for k, v in out.items() if v is not None}
    profile = read_field(seg, HISTORY_PROFILE, path, p)
    if profile is None:
        return dict(seg)
    section = HISTORIES[profile]
    p.unknown_keys(seg, ("profile", *section.keys), path)
    out = {"profile": profile}
    if profile == "table":
        for key in section.keys:
            v = seg.get(key)
            if not (isinstance(v, list) and len(v) >= 2 and all(
                    isinstance(x, int | float) and not isinstance(x, bool) for x in v)):
                p.add(f"{path}.{key}: expected an array of at least two numbers, got "
                      f"{describe(v)}")
                return out
        try:
            model.Table(tuple(map(float, seg["t"])), tuple(map(float, seg["values"])))
        except ValueError as exc:
            p.add(f"{path}: {exc}")
        out.update(t=[float(x) for x in seg["t"]], values=[float(x) for x in seg["values"]])
        return out
    out.update(read_fields(seg, section.fields, path, p))  # a step's duration is optional
    return {k: v for k, v in out.items() if v is not None}


def _csv_table(entry: Mapping[str, Any]) -> model.Table:
    import pandas as pd

    try:
        frame = pd.read_csv(entry["csv"])
    except (OSError, ValueError) as exc:
        raise ValueError(f"cannot read {entry['csv']}: {exc}") from None
    for col in (entry["time_column"], entry["column"]):
        if col not in frame.columns:
            raise ValueError(f"column {col!r} not in {entry['csv']} (columns: "
                             + ", ".join(map(str, frame.columns)) + ")")
    t = frame[entry["time_column"]].to_numpy(float)
    u = frame[entry["column"]].to_numpy(float)
    return model.Table(tuple(t), tuple(u))


def build_history(segments: list[dict[str, Any]]) -> model.History:
    parts: list[model.History] = []
    for s in segments:
        if "csv" in s:
            parts.append(_csv_table(s))
        elif s["profile"] == "table":
            parts.append(model.Table(tuple(s["t"]), tuple(s["values"])))
        elif s["profile"] == "bang_bang":
            parts.append(model.BangBang(s["amplitude"], s["start"], s["duration"]))
        else:
            parts.append(model.Step(s["amplitude"], s["start"],
                                     s.get("duration", float("inf"))))
    return parts[0] if len(parts) == 1 else model.Sum(tuple(parts))


def read_driven_joint(table: Mapping[str, Any], path: str, base_dir: Path, p: Problems,
                      motion_reader: Callable[[Any, str], tuple[Any, JointMotion | None]]
                      ) -> dict[str, Any]:
    """The resolved table of a joint with ``drive = "torque"`` or ``"servo"``."""
    drive = read_field(table, DRIVE, path, p)
    out: dict[str, Any] = {"drive": drive}
    if drive == "torque":
        p.unknown_keys(table, TORQUE.keys, path)
        if "torque" not in table:
            p.add(f"{path}: drive = \"torque\" needs 'torque', an array of segments (N·m)")
        else:
            out["torque"] = read_history(table["torque"], f"{path}.torque", base_dir, p)
        out.update(read_fields(table, _TORQUE_INITIAL, path, p))
    elif drive == "free":
        p.unknown_keys(table, tuple(k for k in TORQUE.keys if k != "torque"), path)
        out.update(read_fields(table, _TORQUE_INITIAL, path, p))
    elif drive == "servo":
        servo = read_field(table, SERVO, path, p)
        out["servo"] = servo
        if servo is not None:
            p.unknown_keys(table, _SERVOS[servo].keys, path)
            out.update(read_fields(table, _SERVO_OWN[servo], path, p))
        # an unknown servo is reported already; its common keys are still checked
        section = _SERVOS.get(servo, VELOCITY_PID)
        out.update(read_fields(table, section.pick("loop_gain", "torque_limit"), path, p))
        if "reference" not in table:
            p.add(f"{path}: drive = \"servo\" needs 'reference', an array of motion profiles "
                  "like the prescribed 'motion'")
        else:
            out["reference"], _ = motion_reader(table["reference"], f"{path}.reference")
    else:
        p.unknown_keys(table, TORQUE.keys + VELOCITY_PID.keys + POSITION.keys, path)
    out["motor_inertia"] = read_field(table, TORQUE["motor_inertia"], path, p)
    if "base_point" in table:
        out["base_point"] = read_field(table, TORQUE["base_point"], path, p)
    return {k: v for k, v in out.items() if v is not None}


def build_drive(entry: Mapping[str, Any], reference: JointMotion | None) -> model.Drive:
    if entry["drive"] in ("torque", "free"):
        torque = build_history(entry["torque"]) if entry["drive"] == "torque" else model.ZERO
        return model.TorqueDrive(torque,
                                  math.radians(entry["initial_angle_deg"]),
                                  math.radians(entry["initial_rate_deg_s"]),
                                  entry["motor_inertia"])
    assert reference is not None
    limit = entry.get("torque_limit", float("inf"))
    if entry["servo"] == "velocity_pid":
        return model.VelocityServo(reference, entry["P"], entry["I"], entry["D"],
                                    entry["saturation_V"],
                                    math.radians(entry["rate_per_volt_deg_s"]),
                                    entry["loop_gain"], limit, entry["motor_inertia"])
    return model.PositionServo(reference, entry["bandwidth"],
                                math.radians(entry["rate_limit_deg_s"]), entry["loop_gain"],
                                limit, entry["motor_inertia"])


def build_base(entry: Mapping[str, Any] | None, joints: list[Mapping[str, Any]],
               cart: model.Cart | None = None) -> model.Base | None:
    """The model's base of a resolved ``[base]`` table (``cart``: a cart base's rail and
    drive, built by scenario/cart.py)."""
    attachments = tuple((k, (float(j["base_point"][0]), float(j["base_point"][1])))
                        for k, j in enumerate(joints) if "base_point" in j)
    if entry is None:
        return model.Base("fixed", attachments=attachments) if attachments else None
    loads = tuple(model.BaseLoad(
        **{k: build_history(v) for k, v in load.items() if k in ("force_x", "force_y", "moment")},
        point=(load["point"][0], load["point"][1]), frame=load["frame"])
        for load in entry["loads"])
    return model.Base(entry["type"], entry.get("mass", 0.0), entry.get("inertia", 0.0),
                       attachments, loads, tuple(entry["position"]),  # type: ignore[arg-type]
                       math.radians(entry["attitude_deg"]), tuple(entry["velocity"]),  # type: ignore[arg-type]
                       math.radians(entry["rate_deg_s"]), cart)


__all__ = ["build_base", "build_drive", "read_base", "read_driven_joint", "read_history"]
