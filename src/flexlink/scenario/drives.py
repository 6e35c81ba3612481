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
from .errors import Problems, describe

BASE_KEYS = ("type", "mass", "inertia", "position", "attitude_deg", "velocity", "rate_deg_s",
             "loads")
LOAD_KEYS = ("force_x", "force_y", "moment", "point", "frame")
HISTORY_PROFILES: dict[str, tuple[str, ...]] = {
    "bang_bang": ("amplitude", "start", "duration"),
    "step": ("amplitude", "start", "duration"),
    "table": ("t", "values"),
}
HISTORY_CSV_KEYS = ("csv", "time_column", "column")
TORQUE_KEYS = ("drive", "torque", "initial_angle_deg", "initial_rate_deg_s", "motor_inertia",
               "base_point")
SERVO_COMMON = ("drive", "servo", "reference", "loop_gain", "torque_limit", "motor_inertia",
                "base_point")
VELOCITY_PID_KEYS = (*SERVO_COMMON, "P", "I", "D", "saturation_V", "rate_per_volt_deg_s")
POSITION_KEYS = (*SERVO_COMMON, "bandwidth", "rate_limit_deg_s")

SegmentReader = Callable[[Any, str, Problems], tuple[dict[str, Any], JointMotion | None]]


def read_base(raw: Any, base_dir: Path, p: Problems) -> dict[str, Any] | None:
    """The resolved ``[base]`` table, or None if absent."""
    if raw is None:
        return None
    if not isinstance(raw, Mapping):
        p.add(f"base: expected a table [base], got {describe(raw)}")
        return None
    path = "base"
    p.unknown_keys(raw, BASE_KEYS, path)
    kind = p.string(raw, "type", path, choices=("free", "pinned", "fixed"))
    out: dict[str, Any] = {"type": kind}
    moving = kind in ("free", "pinned")
    # 0 is allowed: the first link is then the free body itself (a flexible beam in flight)
    out["mass"] = p.number(raw, "mass", path, unit="kg", ge=0, default=None if kind != "free"
                           else _required())
    out["inertia"] = p.number(raw, "inertia", path, unit="kg·m² (about the reference point)",
                              ge=0, default=_required() if moving else None)
    out["position"] = _pair(raw, "position", path, p, "m", default=[0.0, 0.0])
    out["attitude_deg"] = p.number(raw, "attitude_deg", path, unit="deg", default=0.0)
    out["velocity"] = _pair(raw, "velocity", path, p, "m/s", default=[0.0, 0.0])
    out["rate_deg_s"] = p.number(raw, "rate_deg_s", path, unit="deg/s", default=0.0)
    if kind == "pinned" and (out["position"] != [0.0, 0.0] or out["velocity"] != [0.0, 0.0]):
        p.add("base: a pinned base turns about its fixed reference point: position and "
              "velocity must be [0, 0] (give type = \"free\" to let it translate)")
    if kind == "fixed" and (out["attitude_deg"] or out["rate_deg_s"] or "loads" in raw):
        p.add("base: a fixed base does not move: attitude_deg, rate_deg_s and loads need "
              "type = \"free\" or \"pinned\"")
    loads = raw.get("loads", [])
    if not isinstance(loads, list):
        p.add(f"base.loads: expected an array of tables [[base.loads]], got {describe(loads)}")
        loads = []
    out["loads"] = [_load(t, f"base.loads[{i}]", base_dir, p) for i, t in enumerate(loads)]
    return {k: v for k, v in out.items() if v is not None}


def _required() -> Any:
    from .errors import _MISSING

    return _MISSING


def _pair(table: Mapping[str, Any], key: str, path: str, p: Problems, unit: str,
          default: list[float]) -> list[float] | None:
    value = table.get(key, default)
    ok = (isinstance(value, list) and len(value) == 2
          and all(isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)
                  for v in value))
    if not ok:
        p.add(f"{path}.{key}: expected two numbers [x, y] ({unit}), got {describe(value)}")
        return None
    return [float(v) for v in value]


def _load(table: Any, path: str, base_dir: Path, p: Problems) -> dict[str, Any]:
    if not isinstance(table, Mapping):
        p.add(f"{path}: expected a table, got {describe(table)}")
        return {}
    p.unknown_keys(table, LOAD_KEYS, path)
    out: dict[str, Any] = {k: read_history(table[k], f"{path}.{k}", base_dir, p)
                           for k in ("force_x", "force_y", "moment") if k in table}
    if not out:
        p.add(f"{path}: give at least one of force_x, force_y (N) or moment (N·m), each an "
              "array of segments like [{ profile = \"bang_bang\", amplitude = 1.0, start = 0.0, "
              "duration = 10.0 }]")
    out["point"] = _pair(table, "point", path, p, "m, body frame", default=[0.0, 0.0])
    out["frame"] = p.string(table, "frame", path, choices=("inertial", "body"),
                            default="inertial")
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
        p.unknown_keys(seg, HISTORY_CSV_KEYS, path)
        csv = p.string(seg, "csv", path)
        out = {"csv": None if csv is None else str((base_dir / csv).resolve()),
               "time_column": p.string(seg, "time_column", path, default="t"),
               "column": p.string(seg, "column", path)}
        if out["csv"] is not None and not Path(out["csv"]).is_file():
            p.add(f"{path}.csv: file not found: {out['csv']} (paths are relative to the "
                  "scenario file's folder)")
        elif None not in out.values():
            try:
                _csv_table(out)
            except ValueError as exc:
                p.add(f"{path}.csv: {exc}")
        return {k: v for k, v in out.items() if v is not None}
    profile = p.string(seg, "profile", path, choices=HISTORY_PROFILES)
    if profile is None:
        return dict(seg)
    p.unknown_keys(seg, ("profile", *HISTORY_PROFILES[profile]), path)
    out = {"profile": profile}
    if profile == "table":
        for key in ("t", "values"):
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
    out["amplitude"] = p.number(seg, "amplitude", path)
    out["start"] = p.number(seg, "start", path, unit="s", ge=0, default=0.0)
    if profile == "bang_bang" or "duration" in seg:
        out["duration"] = p.number(seg, "duration", path, unit="s", gt=0)
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
    drive = p.string(table, "drive", path, choices=("torque", "servo"))
    out: dict[str, Any] = {"drive": drive}
    if drive == "torque":
        p.unknown_keys(table, TORQUE_KEYS, path)
        if "torque" not in table:
            p.add(f"{path}: drive = \"torque\" needs 'torque', an array of segments (N·m)")
        else:
            out["torque"] = read_history(table["torque"], f"{path}.torque", base_dir, p)
        out["initial_angle_deg"] = p.number(table, "initial_angle_deg", path, unit="deg",
                                            default=0.0)
        out["initial_rate_deg_s"] = p.number(table, "initial_rate_deg_s", path, unit="deg/s",
                                             default=0.0)
    elif drive == "servo":
        servo = p.string(table, "servo", path, choices=("velocity_pid", "position"))
        out["servo"] = servo
        if servo == "velocity_pid":
            p.unknown_keys(table, VELOCITY_PID_KEYS, path)
            out["P"] = p.number(table, "P", path, unit="V/rad", ge=0)
            out["I"] = p.number(table, "I", path, unit="V/(rad·s)", ge=0, default=0.0)
            out["D"] = p.number(table, "D", path, unit="V·s/rad", ge=0, default=0.0)
            out["saturation_V"] = p.number(table, "saturation_V", path, unit="V", gt=0,
                                           default=10.0)
            out["rate_per_volt_deg_s"] = p.number(table, "rate_per_volt_deg_s", path,
                                                  unit="deg/s per V", gt=0)
            default_gain = 50.0
        elif servo == "position":
            p.unknown_keys(table, POSITION_KEYS, path)
            out["bandwidth"] = p.number(table, "bandwidth", path, unit="rad/s", gt=0)
            out["rate_limit_deg_s"] = p.number(table, "rate_limit_deg_s", path, unit="deg/s",
                                               gt=0)
            default_gain = 5.0
        else:
            default_gain = 0.0
        out["loop_gain"] = p.number(table, "loop_gain", path, unit="N·m·s/rad", gt=0,
                                    default=default_gain)
        out["torque_limit"] = p.number(table, "torque_limit", path, unit="N·m", gt=0,
                                       default=None)
        if "reference" not in table:
            p.add(f"{path}: drive = \"servo\" needs 'reference', an array of motion profiles "
                  "like the prescribed 'motion'")
        else:
            out["reference"], _ = motion_reader(table["reference"], f"{path}.reference")
    else:
        p.unknown_keys(table, (*TORQUE_KEYS, *VELOCITY_PID_KEYS, *POSITION_KEYS), path)
    out["motor_inertia"] = p.number(table, "motor_inertia", path, unit="kg·m²", ge=0,
                                    default=0.0)
    if "base_point" in table:
        out["base_point"] = _pair(table, "base_point", path, p, "m, base frame", default=[])
    return {k: v for k, v in out.items() if v is not None}


def build_drive(entry: Mapping[str, Any], reference: JointMotion | None) -> model.Drive:
    if entry["drive"] == "torque":
        return model.TorqueDrive(build_history(entry["torque"]),
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


def build_base(entry: Mapping[str, Any] | None, joints: list[Mapping[str, Any]]
               ) -> model.Base | None:
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
                       math.radians(entry["rate_deg_s"]))


__all__ = ["build_base", "build_drive", "read_base", "read_driven_joint", "read_history"]
