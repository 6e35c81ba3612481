"""Scenario errors: every problem in a scenario is collected, then reported at once.

`Problems` is the collector the loader threads through its checks; its typed readers
(`number`, `integer`, `string`, `boolean`) each check one key of one table and record a
message naming the field path, the value and what is allowed, e.g.
``links[1].EI must be > 0 N·m², got -3.0``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterable, Mapping
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


_MISSING = object()


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
    return "any finite number"


class Problems:
    """Collects problem messages; each reader returns the value, or None if it is unusable."""

    def __init__(self) -> None:
        self.messages: list[str] = []

    def __bool__(self) -> bool:
        return bool(self.messages)

    def add(self, message: str) -> None:
        self.messages.append(message)

    def unknown_keys(self, table: Mapping[str, Any], allowed: Iterable[str], path: str) -> None:
        """Report every key of ``table`` not in ``allowed``, suggesting the closest one."""
        allowed = list(allowed)
        for key in table:
            if key in allowed:
                continue
            close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
            hint = f"did you mean '{close[0]}'?" if close else "allowed: " + ", ".join(allowed)
            self.add(f"{path}: unknown key '{key}' ({hint})")

    def _get(
        self, table: Mapping[str, Any], key: str, path: str, default: Any, what: str
    ) -> tuple[bool, Any]:
        """(present, value); a missing required key is reported and read as None."""
        if key in table:
            return True, table[key]
        if default is _MISSING:
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
        default: Any = _MISSING,
        gt: float | None = None,
        ge: float | None = None,
        lt: float | None = None,
        le: float | None = None,
        nonzero: bool = False,
    ) -> float | None:
        """A finite real number (int or float, not bool) within the given bounds, as float."""
        allowed = range_text(gt, ge, lt, le) + (f" {unit}" if unit else "")
        if nonzero:
            allowed = "non-zero" + (f" {unit}" if unit else "")
        present, value = self._get(table, key, path, default, f"a number, {allowed}")
        if not present:
            return value
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
            self.add(f"{field} must be {allowed}, got {value!r}")
            return None
        return value

    def integer(
        self,
        table: Mapping[str, Any],
        key: str,
        path: str,
        *,
        default: Any = _MISSING,
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
        default: Any = _MISSING,
        choices: Iterable[str] | None = None,
    ) -> str | None:
        """A non-empty string, optionally one of ``choices``."""
        options = list(choices) if choices is not None else None
        what = "one of " + ", ".join(repr(c) for c in options) if options else "a string"
        present, value = self._get(table, key, path, default, what)
        if not present:
            return value
        field = f"{path}.{key}"
        if not isinstance(value, str):
            self.add(f"{field}: expected a string, got {describe(value)}")
            return None
        if options is not None and value not in options:
            close = difflib.get_close_matches(value, options, n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            self.add(f"{field} must be {what}, got {value!r}{hint}")
            return None
        if not value.strip():
            self.add(f"{field} must not be empty")
            return None
        return value

    def boolean(
        self, table: Mapping[str, Any], key: str, path: str, *, default: Any = _MISSING
    ) -> bool | None:
        """true or false."""
        present, value = self._get(table, key, path, default, "true or false")
        if not present or isinstance(value, bool):
            return value
        self.add(f"{path}.{key}: expected true or false, got {describe(value)}")
        return None
