"""Scenario errors: every problem in a scenario is collected, then reported at once.

`Problems` is the collector the loader threads through its checks; its typed readers
(`number`, `integer`, `string`, `boolean`, `pair`) each check one key of one table and record
a message naming the field path, the value and what is allowed, e.g.
``links[1].EI must be > 0 N·m², got -3.0``. A reader's ``default`` is `REQUIRED` unless the
key is optional.
"""

from __future__ import annotations

import difflib
import math
import re
from collections.abc import Collection, Iterable, Mapping
from typing import Any


class ScenarioError(ValueError):
    """An invalid scenario. ``problems`` lists every problem found, one message each."""

    def __init__(self, problems: Iterable[str], source: str | None = None) -> None:
        self.problems = list(problems)
        self.source = source
        where = f"scenario {source}" if source else "scenario"
        count = len(self.problems)
        head = f"{where} has {count} problem{'s' if count != 1 else ''}:"
        super().__init__("\n".join([head, *(f"  - {p}" for p in self.problems)]))


class _Required:
    """The type of `REQUIRED`; its repr names it in signatures and error reports."""

    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()  # a reader's default for a key that must be given
NAME_PATTERN = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.\-]{0,63}")


def describe(value: Any) -> str:
    """A short human description of a TOML value, for 'expected …, got …' messages."""
    if isinstance(value, bool):
        return f"boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"string {value!r}"
    if isinstance(value, int | float):
        return f"number {value!r}"
    if isinstance(value, Mapping):
        return "a table"
    if isinstance(value, list):
        return "an array"
    return f"{type(value).__name__} {value!r}"


def range_text(
    gt: float | None = None,
    ge: float | None = None,
    lt: float | None = None,
    le: float | None = None,
) -> str:
    """'> 0', '>= 0', 'in [0, 1)', … for the given bounds."""
    if (gt is not None or ge is not None) and (lt is not None or le is not None):
        low = f"({gt:g}" if gt is not None else f"[{ge:g}"
        high = f"{lt:g})" if lt is not None else f"{le:g}]"
        return f"in {low}, {high}"
    for bound, sign in ((gt, ">"), (ge, ">="), (lt, "<"), (le, "<=")):
        if bound is not None:
            return f"{sign} {bound:g}"
    return ""


class Problems:
    """Collects problem messages; each reader returns the value, or None if it is unusable."""

    def __init__(self) -> None:
        self.messages: list[str] = []

    def __bool__(self) -> bool:
        return bool(self.messages)

    def add(self, message: str) -> None:
        self.messages.append(message)

    def unknown_keys(
        self, table: Mapping[str, Any], allowed: Iterable[str], path: str, noun: str = "key",
        meant: Mapping[str, str] | None = None,
    ) -> None:
        """Report every key of ``table`` not in ``allowed``, suggesting the closest one;
        ``meant``: the allowed key meant by a name spelled nothing like it (a synonym)."""
        allowed = list(dict.fromkeys(allowed))  # readers may pass a key twice
        for key in table:
            if key in allowed:
                continue
            close = ([meant[key]] if meant and key in meant
                     else difflib.get_close_matches(key, allowed, n=1, cutoff=0.6))
            hint = f"did you mean '{close[0]}'?" if close else "allowed: " + ", ".join(allowed)
            self.add(f"{path + ': ' if path else ''}unknown {noun} '{key}' ({hint})")

    def _get(
        self, table: Mapping[str, Any], key: str, path: str, default: Any, what: str
    ) -> tuple[bool, Any]:
        """(present, value); a missing required key is reported and read as None."""
        if key in table:
            return True, table[key]
        if default is REQUIRED:
            self.add(f"{path}: missing required key '{key}' ({what})")
            return False, None
        return False, default

    def number(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        unit: str = "",
        default: Any = REQUIRED,
        gt: float | None = None,
        ge: float | None = None,
        lt: float | None = None,
        le: float | None = None,
        nonzero: bool = False,
    ) -> float | None:
        """A finite real number (int or float, not bool) within the given bounds, as float."""

        def allowed() -> str:  # the message text, built only when a message is (sweeps
            # validate thousands of scenarios, almost all of them valid)
            return f"{'non-zero' if nonzero else range_text(gt, ge, lt, le)} {unit}".strip()

        if key not in table:
            if default is not REQUIRED:
                return default
            text = allowed()
            what = f"a number {text}" if text != unit else f"a number ({unit})" if unit else ""
            return self._get(table, key, path, default, what or "a number")[1]
        value = table[key]
        field = f"{path}.{key}"
        if isinstance(value, bool) or not isinstance(value, int | float):
            self.add(f"{field}: expected a number, got {describe(value)}")
            return None
        value = float(value)
        if not math.isfinite(value):
            self.add(f"{field} must be finite, got {value!r}")
            return None
        too_low = (gt is not None and value <= gt) or (ge is not None and value < ge)
        too_high = (lt is not None and value >= lt) or (le is not None and value > le)
        if too_low or too_high or (nonzero and value == 0.0):
            self.add(f"{field} must be {allowed()}, got {value!r}")
            return None
        return value

    def integer(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        default: Any = REQUIRED,
        ge: int,
        le: int,
    ) -> int | None:
        """An integer (not bool, not float) in [ge, le]."""
        present, value = self._get(table, key, path, default, f"an integer from {ge} to {le}")
        if not present:
            return value
        field = f"{path}.{key}"
        if isinstance(value, bool) or not isinstance(value, int):
            self.add(f"{field}: expected an integer, got {describe(value)}")
            return None
        if not ge <= value <= le:
            self.add(f"{field} must be an integer from {ge} to {le}, got {value!r}")
            return None
        return value

    def string(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        default: Any = REQUIRED,
        choices: Collection[str] | None = None,
    ) -> str | None:
        """A non-empty string, optionally one of ``choices``."""

        def what() -> str:  # built only for a message, like number's
            return "one of " + ", ".join(map(repr, choices)) if choices else "a string"

        if key not in table:
            return self._get(table, key, path, default, what())[1]
        value = table[key]
        field = f"{path}.{key}"
        if not isinstance(value, str):
            self.add(f"{field}: expected a string, got {describe(value)}")
            return None
        if choices is not None and value not in choices:
            close = difflib.get_close_matches(value, list(choices), n=1, cutoff=0.7)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            self.add(f"{field} must be {what()}, got {value!r}{hint}")
            return None
        if not value.strip():
            self.add(f"{field} must not be empty")
            return None
        return value

    def boolean(
        self, table: Mapping[str, Any], key: str, path: str, *, default: Any = REQUIRED
    ) -> bool | None:
        """true or false."""
        present, value = self._get(table, key, path, default, "true or false")
        if not present or isinstance(value, bool):
            return value
        self.add(f"{path}.{key}: expected true or false, got {describe(value)}")
        return None

    def pair(
        self, table: Mapping[str, Any], key: str, path: str, *, unit: str,
        default: Any = REQUIRED,
    ) -> list[float] | None:
        """Two finite numbers ``[x, y]`` in ``unit``, as a new list of floats."""
        if key not in table:  # the default: None, or a pair that needs no check
            if default is REQUIRED:
                self.add(f"{path}: missing required key '{key}' (two numbers [x, y], {unit})")
            return None if default is None or default is REQUIRED else [*map(float, default)]
        value = table[key]
        ok = (isinstance(value, list) and len(value) == 2
              and all(isinstance(v, int | float) and not isinstance(v, bool)
                      and math.isfinite(v) for v in value))
        if not ok:
            shown = (repr(value) if isinstance(value, list) and len(value) <= 4
                     else describe(value))  # the entries show a NaN or a third number
            self.add(f"{path}.{key}: expected two numbers [x, y] ({unit}), finite, got {shown}")
            return None
        return [float(v) for v in value]

    def table_array(
        self, raw: Mapping[str, Any], key: str, *, required: bool
    ) -> list[tuple[str, dict[str, Any]]]:
        """The tables of an array of tables ``[[key]]`` with their paths (copies)."""
        return [(path, table) for path, table, _ in self.given_tables(raw, key,
                                                                       required=required)]

    def given_tables(
        self, raw: Mapping[str, Any], key: str, *, required: bool
    ) -> list[tuple[str, dict[str, Any], Mapping[str, Any]]]:
        """`table_array`'s (path, copy) pairs, each with the table as given in ``raw``."""
        if key not in raw:
            if required:
                self.add(f"missing section [[{key}]] (at least one table)")
            return []
        value = raw[key]
        if not isinstance(value, list):
            self.add(f"{key}: expected an array of tables [[{key}]], got {describe(value)}")
            return []
        if required and not value:
            self.add(f"{key}: needs at least one table")
        out = []
        for i, table in enumerate(value):
            if isinstance(table, Mapping):
                out.append((f"{key}[{i}]", dict(table), table))
            else:
                self.add(f"{key}[{i}]: expected a table, got {describe(table)}")
        return out

    def check_names(self, names: list[str | None], section: str) -> None:
        """Names label output channels: unique, 1-64 of letters, digits, '_', '-', '.'."""
        seen: set[str] = set()
        for i, name in enumerate(names):
            if name is None:
                continue
            if not NAME_PATTERN.fullmatch(name):
                self.add(f"{section}[{i}].name must be 1-64 letters, digits, '_', '-' or '.' "
                         f"(it names output channels), got {name!r}")
            if name in seen:
                self.add(f"{section}[{i}].name: duplicate name {name!r} (names must be unique)")
            seen.add(name)
