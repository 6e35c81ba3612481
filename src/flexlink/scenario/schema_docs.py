"""docs/scenario.md's key tables, generated from the schema (scenario/schema.py).

Each generated table sits between ``<!-- generated: NAME -->`` and ``<!-- end generated -->``
in the Markdown file; `regenerate` rewrites every such block, `markdown_table` gives one.
``scripts/generate_scenario_docs.py`` applies it to the file, and a unit test checks that the
file is up to date.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping
from typing import Any

from .errors import REQUIRED, range_text
from .schema import (
    ACTUATORS,
    BASE,
    BODIES,
    CART,
    CART_PROFILES,
    CLOSURES,
    CONTROLLER_SISO,
    CONTROLLERS,
    ELASTIC,
    HISTORIES,
    HISTORY_CSV,
    JOINTS,
    LINKS,
    LOADS,
    LTI,
    MEASURED_ANGLES,
    PIEZO,
    POINT_SENSORS,
    POSITION,
    PPF,
    PRISMATIC,
    PROFILES,
    SENSORS,
    SIMULATION,
    TORQUE,
    VELOCITY_PID,
    Field,
    Section,
)

BLOCK = re.compile(r"(<!-- generated: (?P<name>[\w.]+) -->\n)(?P<body>.*?)"
                   r"(<!-- end generated -->)", re.DOTALL)
_KIND_TEXT = {"boolean": "`true` or `false`", "pair": "`[x, y]`",
              "numbers": "array of ≥ 2 numbers", "profiles": "array of profiles",
              "history": "array of segments", "table": "table", "tables": "array of tables",
              "strings": "array of names", "vector": "array of numbers",
              "matrix": "array of rows (arrays of numbers)"}


def markdown_table(name: str) -> str:
    """The Markdown table of the generated block ``name`` (see `BLOCKS`), ending in a newline."""
    return BLOCKS[name]()


def regenerate(text: str) -> str:
    """``text`` with every generated block replaced by the schema's current table."""
    def body(match: re.Match[str]) -> str:
        return match.group(1) + markdown_table(match.group("name")) + match.group(4)

    return BLOCK.sub(body, text)


def key_table(fields: Iterable[Field], defaults: Mapping[str, str] | None = None) -> str:
    """One row per key: unit, required or default, allowed values, meaning. ``defaults``
    replaces the default text of some keys."""
    rows = ["| key | unit | required / default | allowed | meaning |", "|---|---|---|---|---|"]
    for f in fields:
        default = (defaults or {}).get(f.key) or default_text(f)
        cells = [f"`{f.key}`", f.unit or "—", default, allowed_text(f), meaning_text(f)]
        rows.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells) + " |")
    return "\n".join(rows) + "\n"


def segment_table(sections: Iterable[Section], head: str, meaning: str) -> str:
    """One row per segment kind (a motion profile, a history segment): its keys, briefly."""
    rows = [f"| {head} | keys | {meaning} |", "|---|---|---|"]
    for s in sections:
        keys = ", ".join(_brief(f) for f in s.fields)
        rows.append(f"| {s.label} | {keys} | {s.doc} |")
    return "\n".join(rows) + "\n"


def default_text(f: Field) -> str:
    if f.default_doc:
        return f.default_doc
    if f.default is REQUIRED:
        return "required"
    return "none" if f.default is None else f"`{toml_text(f.default)}`"


def allowed_text(f: Field) -> str:
    if f.kind == "number":
        text = "non-zero" if f.nonzero else _bounds(f) or "number"
    elif f.kind == "integer":
        text = f"integer {f.ge:g} … {f.le:g}"
    elif f.kind == "string":
        choices = f.choices or ()
        text = ", ".join(f"`{toml_text(c)}`" for c in choices) or "non-empty string"
    else:
        text = _KIND_TEXT[f.kind]
    return f"{text}; {f.rule}" if f.rule else text


def meaning_text(f: Field) -> str:
    quote = '"' if f.kind == "string" else ""
    notes = [f"`{quote}{value}{quote}`: {note}" for value, note in f.notes.items()]
    return "; ".join([*notes, f.doc] if f.doc else notes)


def toml_text(value: Any) -> str:
    """A default as it is written in TOML: 1e-6, 0, "lawson", [0, 0], false."""
    if isinstance(value, bool):
        return str(value).lower()
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, tuple | list):
        return "[" + ", ".join(toml_text(v) for v in value) + "]"
    return re.sub(r"e([+-])0*(\d)", lambda m: f"e{m[1].lstrip('+')}{m[2]}", f"{value:g}")


def _bounds(f: Field) -> str:
    return range_text(f.gt, f.ge, f.lt, f.le).replace(">=", "≥").replace("<=", "≤")


def _brief(f: Field) -> str:
    """``key (unit, bounds, default)`` for a segment table."""
    parts = [f.unit, _bounds(f) if f.kind == "number" else "", f.rule]
    if f.kind in ("numbers", "vector"):
        parts.append(_KIND_TEXT[f.kind])
    if f.default is not REQUIRED:
        parts.append(f"default {f.default_doc or f'`{toml_text(f.default)}`'}")
    text = ", ".join(p for p in parts if p)
    return f"`{f.key}` ({text})" if text else f"`{f.key}`"


def _own(section: Section, other: Section) -> tuple[Field, ...]:
    return tuple(f for f in section.fields if f.key not in other.keys)


def _servo_common() -> str:
    """The keys both servos take; a default that differs is given per servo."""
    common = [f for f in VELOCITY_PID.fields if f.key in POSITION.keys]
    defaults = {f.key: ", ".join(f"{default_text(s[f.key])} (`{s.name}`)"
                                 for s in (VELOCITY_PID, POSITION))
                for f in common if f != POSITION[f.key]}
    return key_table(common, defaults)


BLOCKS: dict[str, Callable[[], str]] = {
    "simulation": lambda: key_table(SIMULATION.fields),
    "links": lambda: key_table(LINKS.fields),
    "links.bodies": lambda: key_table(BODIES.fields),
    "joints": lambda: key_table(JOINTS.fields),
    "profiles": lambda: segment_table(PROFILES.values(), "`profile`", "motion"),
    "measured_angles": lambda: key_table(MEASURED_ANGLES.fields),
    "sensors": lambda: key_table(SENSORS.fields),
    "point_sensors": lambda: key_table(POINT_SENSORS.fields),
    "piezo": lambda: key_table(PIEZO.fields),
    "base": lambda: key_table(BASE.fields),
    "base.loads": lambda: key_table(LOADS.fields),
    "base.cart": lambda: key_table(CART.fields),
    "cart_profiles": lambda: segment_table(CART_PROFILES.values(), "`profile`", "travel"),
    "histories": lambda: segment_table([*HISTORIES.values(), HISTORY_CSV], "segment", "value"),
    "torque": lambda: key_table(TORQUE.fields),
    "servo": _servo_common,
    "velocity_pid": lambda: key_table(_own(VELOCITY_PID, POSITION)),
    "position": lambda: key_table(_own(POSITION, VELOCITY_PID)),
    "elastic": lambda: key_table(ELASTIC.fields),
    "prismatic": lambda: key_table(PRISMATIC.fields),
    "actuators": lambda: key_table(ACTUATORS.fields),
    "controllers": lambda: key_table(CONTROLLERS.fields),
    "controller_siso": lambda: key_table(CONTROLLER_SISO.fields),
    "ppf": lambda: key_table(PPF.fields),
    "lti": lambda: key_table(LTI.fields),
    "closures": lambda: key_table(CLOSURES.fields),
}
