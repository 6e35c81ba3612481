"""The scenario of every case: the base scenario file with the case's parameter values set.

Parameters are paths into the scenario *as written in the file* (the parsed TOML), so a link
given by ``E``, ``width`` and ``thickness`` gets a new bending stiffness when any of the three
is swept. ``EI`` and ``E`` are alternatives: setting one removes the other from that link.
A key the file leaves at its default may be set too (``links[1].damping_ratio``). Every case
is validated before any case runs; problems name the path, the value and the case.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..model import Scenario
from ..scenario import ScenarioError, resolve_scenario_dict, scenario_from_dict
from ..scenario.errors import describe
from ..scenario.load import PROFILES, read_toml
from .errors import SweepError
from .parameters import CaseTable, PathTokens, parse_path

MAX_PROBLEMS = 20  # a sweep of 10⁴ bad cases should not print 10⁴ lines
TIME_GRID_KEYS = ("t_end", "dt_out")  # every case must share one time axis
PROFILE_KEYS = sorted({key for keys in PROFILES.values() for key in keys})


@dataclass(frozen=True)
class BaseScenario:
    """The parsed scenario file a sweep varies, with where its relative paths start."""

    raw: Mapping[str, Any]
    base_dir: Path
    name: str
    source: str

    def resolved(self) -> dict[str, Any]:
        """The base scenario with every default filled in (what ``flexlink run`` saves)."""
        return resolve_scenario_dict(self.raw, self.base_dir)


def load_base(base: str | Path | Mapping[str, Any], base_dir: Path | None = None) -> BaseScenario:
    """A scenario file path or an already parsed dict (relative CSV paths from ``base_dir``)."""
    if isinstance(base, Mapping):
        raw = copy.deepcopy(dict(base))
        folder, source = Path(base_dir or "."), "scenario dict"
        name = "scenario"
    else:
        path = Path(base)
        raw, folder, source, name = read_toml(path), path.parent, str(path), path.stem
    simulation = raw.get("simulation")
    if isinstance(simulation, dict):
        simulation.setdefault("name", name)
        name = simulation["name"] if isinstance(simulation["name"], str) else name
    scenario_from_dict(raw, folder, name=name, source=source)  # the base itself must be valid
    return BaseScenario(raw, folder, name, source)


def check_paths(base: BaseScenario, table: CaseTable) -> dict[str, PathTokens]:
    """Tokens of every parameter path, after checking each names a numeric field of the base
    scenario (or a key it leaves at its default); all problems at once."""
    problems, tokens = [], {}
    for parameter in table.parameters:
        tokens[parameter.path] = parse_path(parameter.path)
        message = _path_problem(base.raw, tokens[parameter.path], parameter.path)
        if message:
            problems.append(message)
    if problems:
        raise SweepError(problems)
    return tokens


def _path_problem(raw: Mapping[str, Any], tokens: PathTokens, path: str) -> str | None:
    if tokens[0] == "simulation" and len(tokens) == 2 and tokens[1] in TIME_GRID_KEYS:
        return (f"{path} cannot be swept: all cases share one time axis (set it in the base "
                "scenario instead)")
    node: Any = raw
    for depth, token in enumerate(tokens[:-1]):
        here = _join(tokens[:depth])
        if isinstance(token, int):
            if not isinstance(node, list):
                return f"{path}: {here} is not an array ({describe(node)})"
            if token >= len(node):
                entries = "entry" if len(node) == 1 else "entries"
                return (f"{path}: the scenario has {len(node)} {entries} in {here} "
                        f"(indices 0 to {len(node) - 1})")
        elif not isinstance(node, Mapping) or token not in node:
            return f"{path}: the scenario has no {_join(tokens[:depth + 1])}"
        node = node[token]
    last = tokens[-1]
    if isinstance(last, int) or not isinstance(node, Mapping):
        return f"{path} is not a key of a table; give a numeric field such as links[0].EI"
    if last in node:
        value = node[last]
        if isinstance(value, bool) or not isinstance(value, int | float):
            return f"{path} is {describe(value)}; only numeric fields can be swept"
    elif tokens[0] == "joints" and len(tokens) == 3 and last in PROFILE_KEYS:
        return (f"{path}: a joint has no key {last!r}; profile keys sit in its motion array, "
                f"e.g. {_join(tokens[:2])}.motion[0].{last}")
    return None


def _join(tokens: PathTokens) -> str:
    text = ""
    for token in tokens:
        text += f"[{token}]" if isinstance(token, int) else (f".{token}" if text else token)
    return text or "the scenario"


def with_values(raw: Mapping[str, Any], values: Mapping[PathTokens, float | int]
                ) -> dict[str, Any]:
    """A copy of ``raw`` with each path set to its value (paths checked by `check_paths`).

    Only the tables and arrays on the paths are copied; the rest is shared with ``raw``,
    which is never modified (a deep copy per case would cost more than validating it)."""
    out = dict(raw)
    for tokens, value in values.items():
        node: Any = out
        for token in tokens[:-1]:
            child = node[token]
            child = list(child) if isinstance(child, list) else dict(child)
            node[token] = child
            node = child
        key = tokens[-1]
        node[key] = value
        alternative = {"EI": "E", "E": "EI"}.get(str(key))
        if alternative and tokens[0] == "links":
            node.pop(alternative, None)
    return out


def case_scenarios(base: BaseScenario, table: CaseTable) -> list[Scenario]:
    """The validated `Scenario` of every case, or one SweepError listing every problem."""
    tokens = check_paths(base, table)
    scenarios: list[Scenario] = []
    grouped: dict[str, list[tuple[int, str]]] = {}
    for index in range(table.count):
        raw = with_values(base.raw, {tokens[p]: v for p, v in table.case(index).items()})
        try:
            scenarios.append(scenario_from_dict(raw, base.base_dir, name=base.name,
                                                source=base.source))
        except ScenarioError as exc:
            for problem in exc.problems:
                # "x must be <= 1.37 m, got 1.4": one line per kind of problem, not per value
                grouped.setdefault(problem.split(", got ")[0], []).append((index, problem))
    if grouped:
        raise SweepError(_case_problems(grouped, table))
    return scenarios


def _case_problems(grouped: dict[str, list[tuple[int, str]]], table: CaseTable) -> list[str]:
    lines = []
    for cases in list(grouped.values())[:MAX_PROBLEMS]:
        first, problem = cases[0]
        values = ", ".join(f"{p} = {v:g}" for p, v in table.case(first).items())
        more = f"; {len(cases) - 1} more case{'s' if len(cases) > 2 else ''} like it" \
            if len(cases) > 1 else ""
        lines.append(f"{problem} (case {first}: {values}{more})")
    if len(grouped) > MAX_PROBLEMS:
        lines.append(f"… and {len(grouped) - MAX_PROBLEMS} more kinds of problem")
    return lines
