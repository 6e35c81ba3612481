"""Field paths: one grammar naming any numeric field of a scenario file (sweeps and fits).

A path is keys joined by dots, with array entries in brackets, as the scenario checks write
them in their messages: ``links[0].EI``, ``joints[0].motion[0].duration``,
``base.loads[0].moment[0].amplitude``, ``joints[1].P``, ``simulation.rtol``, and a number of
a pair, ``joints[0].base_point[1]``. An entry is a 0-based index or, in an array of named
tables (links, sensors), the entry's ``name``: ``links[link1].E``,
``sensors[pzt].capacitance``. Digits always mean an index.

Paths address the file **as written** (the parsed TOML), not the resolved scenario: a link
given by ``E``, ``width`` and ``thickness`` gets its bending stiffness recomputed when any of
the three changes, and a sensor whose thickness defaults to its link's follows the link. A
key the file leaves at its default may be set (its value is then the default). ``EI`` and
``E`` are alternatives: setting one removes the other from that link.
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Mapping
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

from ..model import Scenario
from .errors import NAME_PATTERN, describe
from .load import PROFILES, read_toml, resolve_scenario_dict, scenario_from_dict


class FieldPathError(ValueError):
    """A path that is malformed, or that names no numeric field of the scenario."""


@dataclass(frozen=True)
class Name:
    """An array entry given by its ``name`` key: the ``link1`` of ``links[link1]``."""

    name: str

    def __str__(self) -> str:
        return self.name


Step = str | int | Name  # a key, a 0-based index, or an entry's name
FieldPath = tuple[Step, ...]

EXAMPLES = "links[0].EI, links[link1].E or joints[0].motion[0].duration"
# a link's bending stiffness is EI, or E with width and thickness: never both in one link
ALTERNATIVES = {"EI": "E", "E": "EI"}
TIME_GRID_KEYS = ("t_end", "dt_out")  # simulation keys that fix the output time grid
PROFILE_KEYS = frozenset(key for keys in PROFILES.values() for key in keys)

_KEY = r"[A-Za-z_][A-Za-z0-9_]*"
_SEGMENT = rf"{_KEY}(?:\[[^\[\]]+\])*"
_PATH = re.compile(rf"{_SEGMENT}(?:\.{_SEGMENT})*")
_TOKEN = re.compile(rf"\[([^\[\]]+)\]|({_KEY})")


def parse(text: str) -> FieldPath:
    """``links[link1].EI`` → ('links', Name('link1'), 'EI'); a malformed path raises."""
    if not isinstance(text, str) or not _PATH.fullmatch(text):
        raise FieldPathError(_malformed(text))
    steps: list[Step] = []
    for entry, key in _TOKEN.findall(text):
        if key:
            steps.append(key)
        elif entry.isdigit():
            steps.append(int(entry))
        elif NAME_PATTERN.fullmatch(entry):
            steps.append(Name(entry))
        else:
            raise FieldPathError(_malformed(text))
    return tuple(steps)


def _malformed(text: Any) -> str:
    return (f"bad parameter path {text!r}: expected keys and [indices or names] joined by "
            f"dots, e.g. {EXAMPLES}")


def format_path(path: FieldPath) -> str:
    """The text of a path: ('links', 0, 'EI') → ``links[0].EI``."""
    text = ""
    for step in path:
        text += f"[{step}]" if isinstance(step, int | Name) else (f".{step}" if text else step)
    return text or "the scenario"


def is_time_grid(path: FieldPath) -> bool:
    """True for ``simulation.t_end`` and ``simulation.dt_out`` (the output time grid)."""
    return len(path) == 2 and path[0] == "simulation" and path[1] in TIME_GRID_KEYS


def resolve(raw: Mapping[str, Any], path: FieldPath, text: str | None = None,
            defaults: Mapping[str, Any] | None = None) -> FieldPath:
    """``path`` with every entry name replaced by its index, after checking that every table
    and array on the way exists in ``raw``, or in ``defaults`` (the resolved scenario: a pair
    the file leaves at its default); the last key may be absent too (a default)."""
    text = text or format_path(path)
    if len(path) == 1:
        raise FieldPathError(f"{text}: the top level holds sections, not numeric fields; give "
                             f"a path into one, e.g. {EXAMPLES}")
    node: Any = raw
    out: list[Step] = []
    for depth, step in enumerate(path[:-1]):
        if isinstance(step, str) and isinstance(node, Mapping) and step not in node:
            node = find(defaults, (*out, step)) if defaults is not None else None
            if node is None:
                raise FieldPathError(f"{text}: the scenario has no "
                                     f"{format_path(path[:depth + 1])}{_close(step, raw, out)}")
        elif isinstance(step, str):
            node = node[step] if isinstance(node, Mapping) else None
            if node is None:
                raise FieldPathError(f"{text}: the scenario has no "
                                     f"{format_path(path[:depth + 1])}")
        else:
            here = format_path(path[:depth])
            if not isinstance(node, list):
                raise FieldPathError(f"{text}: {here} is not an array ({describe(node)})")
            step = _index(node, step, here, text)
            node = node[step]
        out.append(step)
    return (*out, _last(node, path, text))


def _last(node: Any, path: FieldPath, text: str) -> str | int:
    """The last step of ``path``: a key of the table ``node``, or an index into the array of
    numbers ``node`` (a pair)."""
    last = path[-1]
    if isinstance(node, list) and not isinstance(last, str):
        last = _index(node, last, format_path(path[:-1]), text)
        if not isinstance(node[last], Mapping):
            return last
    if not isinstance(last, str) or not isinstance(node, Mapping):
        raise FieldPathError(f"{text} is not a key of a table; give a numeric field such as "
                             "links[0].EI")
    if path[0] == "joints" and len(path) == 3 and last in PROFILE_KEYS and last not in node:
        raise FieldPathError(f"{text}: a joint has no key {last!r}; profile keys sit in its "
                             f"motion array, e.g. {format_path(path[:2])}.motion[0].{last}")
    return last


def _index(items: list[Any], step: int | Name, here: str, text: str) -> int:
    """The index of an entry given by number or by name."""
    count = len(items)
    if isinstance(step, int):
        if step >= count:
            entries = "entry" if count == 1 else "entries"
            raise FieldPathError(f"{text}: the scenario has {count} {entries} in {here} "
                                 f"(indices 0 to {count - 1})")
        return step
    names = [item.get("name") if isinstance(item, Mapping) else None for item in items]
    if step.name in names:
        return names.index(step.name)
    known = [n for n in names if isinstance(n, str)]
    if not known:
        raise FieldPathError(f"{text}: the entries of {here} have no names; give an index "
                             f"from 0 to {count - 1}")
    close = difflib.get_close_matches(step.name, known, n=1, cutoff=0.6)
    hint = f"did you mean {close[0]!r}? " if close else ""
    raise FieldPathError(f"{text}: {here} has no entry named {step.name!r} ({hint}known "
                         f"names: {', '.join(repr(n) for n in known)})")


def _close(key: str, raw: Mapping[str, Any], parent: list[Step]) -> str:
    """' (did you mean 'links'?)' when a key of the table at ``parent`` is close to ``key``."""
    node = find(raw, tuple(parent))
    keys = [str(k) for k in node] if isinstance(node, Mapping) else []
    close = difflib.get_close_matches(key, keys, n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def get(d: Mapping[str, Any], path: FieldPath) -> Any:
    """The value at a resolved ``path`` (indices only); KeyError or IndexError if absent."""
    node: Any = d
    for step in path:
        node = node[step]
    return node


def find(d: Mapping[str, Any] | None, path: FieldPath) -> Any:
    """The value at a resolved ``path``, or None where the dict has none."""
    try:
        return get(d, path)  # type: ignore[arg-type]
    except (KeyError, IndexError, TypeError):
        return None


def with_values(d: Mapping[str, Any], values: Mapping[FieldPath, float | int],
                defaults: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """A copy of ``d`` with each resolved path set to its value; a table or array on the path
    that ``d`` lacks is copied from ``defaults`` (KeyError without). Setting a link's ``EI``
    or ``E`` removes the other. Only the tables and arrays on the paths are copied; the rest
    is shared with ``d``, which is never modified (a deep copy per sweep case would cost more
    than validating it)."""
    out = dict(d)
    for path, value in values.items():
        node: Any = out
        for depth, step in enumerate(path[:-1]):
            if isinstance(node, dict) and step not in node:
                if defaults is None:
                    raise KeyError(format_path(path[:depth + 1]))
                child = get(defaults, path[:depth + 1])
            else:
                child = node[step]
            child = list(child) if isinstance(child, list) else dict(child)
            node[step] = child
            node = child
        key = path[-1]
        node[key] = value
        if path[0] == "links" and key in ALTERNATIVES:
            node.pop(ALTERNATIVES[key], None)  # type: ignore[arg-type]
    return out


def is_number(value: Any) -> bool:
    """An int or float, not a bool (TOML's true/false)."""
    return isinstance(value, int | float) and not isinstance(value, bool)


@dataclass(frozen=True)
class Target:
    """A path checked against a scenario file: ``path`` with indices only, the value the
    file gives (else its default, else None), whether the field takes integers, and whether
    it is a key of a slider's table (``joints[k]`` with type = "prismatic": its servo gains
    are per metre, a revolute joint's of the same names per radian)."""

    text: str
    path: FieldPath
    value: float | int | None
    integer: bool
    slider: bool = False

    @property
    def key(self) -> str:
        """The last key on the path: ``EI`` of ``links[0].EI``, ``base_point`` of
        ``joints[0].base_point[1]``."""
        return next(str(step) for step in reversed(self.path) if isinstance(step, str))


def locate(text: str, raw: Mapping[str, Any],
           resolved: Mapping[str, Any] | None = None) -> Target:
    """Parse ``text`` and check it names a numeric field of ``raw`` (the parsed file), or a
    key the file may leave at its default; ``resolved`` (the same scenario with every default
    filled in) supplies the defaults' values."""
    path = resolve(raw, parse(text), text, resolved)
    written, default = find(raw, path), find(resolved, path) if resolved else None
    value = written if written is not None else default
    if value is not None and not is_number(value):
        raise FieldPathError(f"{text} is {describe(value)}; only numeric fields can be swept "
                             "or fitted")
    # the resolved scenario holds numbers as float and integer fields (modes) as int
    return Target(text, path, value, isinstance(default, int) and is_number(default),
                  _in_slider(raw, path))


def _in_slider(raw: Mapping[str, Any], path: FieldPath) -> bool:
    """Whether ``path`` (indices only) lies in a ``[[joints]]`` table of type "prismatic"."""
    if len(path) < 2 or path[0] != "joints" or not isinstance(path[1], int):
        return False
    joint = find(raw, path[:2])
    return isinstance(joint, Mapping) and joint.get("type") == "prismatic"


@dataclass(frozen=True)
class ScenarioFile:
    """A parsed scenario file (as tomllib returns it) and the folder its relative CSV paths
    start from: what field paths address. ``raw`` is never modified."""

    raw: Mapping[str, Any]
    base_dir: Path = Path(".")
    name: str = "scenario"
    source: str | None = None

    @classmethod
    def read(cls, path: str | Path) -> ScenarioFile:
        """The file at ``path``; its name defaults to the file's stem."""
        path = Path(path)
        raw = read_toml(path)
        simulation = raw.get("simulation")
        name = path.stem
        if isinstance(simulation, dict):
            simulation.setdefault("name", name)
            name = simulation["name"] if isinstance(simulation["name"], str) else name
        return cls(raw, path.parent, name, str(path))

    @cached_property
    def defaults(self) -> dict[str, Any]:
        """The scenario with every default filled in (resolved once)."""
        return resolve_scenario_dict(self.raw, self.base_dir)

    def with_values(self, values: Mapping[FieldPath, float | int]) -> dict[str, Any]:
        """The parsed file with each resolved path set (see `with_values`)."""
        try:
            return with_values(self.raw, values)
        except KeyError:  # a pair the file leaves at its default
            return with_values(self.raw, values, self.defaults)

    def build(self, values: Mapping[FieldPath, float | int] | None = None) -> Scenario:
        """The validated `Scenario` with ``values`` set; ScenarioError lists any problem."""
        return scenario_from_dict(self.with_values(values or {}), self.base_dir,
                                  name=self.name, source=self.source)

    def resolved(self, values: Mapping[FieldPath, float | int] | None = None
                 ) -> dict[str, Any]:
        """The scenario with ``values`` set and every default filled in (a run's
        ``scenario.resolved.toml``)."""
        out = resolve_scenario_dict(self.with_values(values or {}), self.base_dir)
        simulation = self.raw.get("simulation")
        if isinstance(simulation, Mapping) and "name" not in simulation:
            out["simulation"]["name"] = self.name  # the dict has no file name to default to
        return out

    def locate(self, text: str) -> Target:
        """`locate` against this file, defaults included."""
        return locate(text, self.raw, self.defaults)
