"""The scenario of every case: the base scenario file with the case's parameter values set.

Parameters are paths into the scenario *as written in the file* (the parsed TOML), so a link
given by ``E``, ``width`` and ``thickness`` gets a new bending stiffness when any of the three
is swept. ``EI`` and ``E`` are alternatives: setting one removes the other from that link.
A key the file leaves at its default may be set too (``links[1].damping_ratio``). Every case
is validated before any case runs; problems name the path, the value and the case.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterator, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..scenario import ScenarioError
from ..scenario.fields import FieldPath, FieldPathError, ScenarioFile, is_time_grid
from .errors import SweepError
from .parameters import CaseTable, parse_path
from .worker import Case, LazyCase

MAX_PROBLEMS = 20  # a sweep of 10⁴ bad cases should not print 10⁴ lines
BaseScenario = ScenarioFile  # the parsed scenario file a sweep varies


def load_base(base: str | Path | Mapping[str, Any], base_dir: Path | None = None
              ) -> ScenarioFile:
    """A scenario file path or an already parsed dict (relative CSV paths from ``base_dir``);
    the base itself must be valid."""
    if isinstance(base, Mapping):
        raw = copy.deepcopy(dict(base))  # the caller may change theirs while cases run
        simulation = raw.get("simulation")
        name = "scenario"
        if isinstance(simulation, Mapping) and isinstance(simulation.get("name"), str):
            name = simulation["name"]
        file = ScenarioFile(raw, Path(base_dir or "."), name, "scenario dict")
    else:
        file = ScenarioFile.read(base)
    file.build()
    return file


def check_paths(base: ScenarioFile, table: CaseTable) -> dict[str, FieldPath]:
    """The path of every parameter with entry names replaced by indices, after checking each
    names a numeric field of the base scenario (or a key it leaves at its default) and no
    two name the same field; all problems at once."""
    problems, paths = [], {}
    for parameter in table.parameters:
        text = parameter.path
        path = parse_path(text)
        if is_time_grid(path):
            problems.append(f"{text} cannot be swept: all cases share one time axis (set it "
                            "in the base scenario instead)")
            continue
        try:
            paths[text] = base.locate(text).path
        except FieldPathError as exc:
            problems.append(str(exc))
    seen: dict[FieldPath, str] = {}
    for text, path in paths.items():
        if path in seen:
            problems.append(f"{seen[path]} and {text} name the same field")
        seen[path] = text
    if problems:
        raise SweepError(problems)
    return paths


def case_scenarios(base: ScenarioFile, table: CaseTable, lazy: bool = False) -> list[Case]:
    """The validated `Scenario` (``lazy``: `LazyCase`) of every case, or one SweepError
    listing every problem."""
    scenarios, invalid = valid_cases(base, table, lazy)
    if invalid:
        raise SweepError(case_problems(invalid, table))
    return [scenarios[i] for i in range(table.count)]


CaseChecks = Callable[[ScenarioFile, CaseTable, Mapping[str, FieldPath]],
                     dict[int, list[str]]]


def valid_cases(base: ScenarioFile, table: CaseTable, lazy: bool = False,
                checks: CaseChecks | None = None
                ) -> tuple[Mapping[int, Case], dict[int, list[str]]]:
    """The `Scenario` of every valid case (``lazy``: a `LazyCase`, built again where it
    runs, so that the built scenarios are never all held at once) and the problems of every
    invalid one, by case index; a SweepError if a parameter path itself is wrong (no case
    could run). ``checks``: where ``lazy`` cases are checked (default: here, `check_rows`;
    a pool's workers: `executors.PoolResults.check_cases`), the same checks in the same
    order of cases."""
    paths = check_paths(base, table)
    scenarios: dict[int, Case] = {}
    invalid: dict[int, list[str]] = {}
    if lazy:
        invalid = (checks or _check_here)(base, table, paths)
    for index in () if lazy else range(table.count):
        values = {paths[p]: v for p, v in table.case(index).items()}
        try:
            scenarios[index] = base.build(values)
        except ScenarioError as exc:
            invalid[index] = exc.problems
    if invalid and len(invalid) == table.count:  # nothing to run: refuse as a whole
        raise SweepError(_case_problems(_grouped(invalid), table))
    if lazy:
        valid = np.setdiff1d(np.arange(table.count), np.fromiter(invalid, int, len(invalid)))
        return LazyCases(base, table, paths, valid), invalid
    return scenarios, invalid


def check_rows(base: ScenarioFile, table: CaseTable, paths: Mapping[str, FieldPath],
               first: int = 0) -> dict[int, list[str]]:
    """The problems of every invalid case of ``table`` (numbered from ``first``), each case
    built as where it runs; the cases in order."""
    invalid = {}
    for row in range(table.count):
        try:
            base.build({paths[p]: v for p, v in table.case(row).items()})
        except ScenarioError as exc:
            invalid[first + row] = exc.problems
    return invalid


def _check_here(base: ScenarioFile, table: CaseTable, paths: Mapping[str, FieldPath]
                ) -> dict[int, list[str]]:
    return check_rows(base, table, paths)


class LazyCases(Mapping[int, LazyCase]):
    """The valid cases of a sweep by index, each `LazyCase` made when it is read: the sweep
    holds their indices only, so that 10⁵ cases cost the parameter table and no more."""

    def __init__(self, base: ScenarioFile, table: CaseTable, paths: Mapping[str, FieldPath],
                 indices: np.ndarray) -> None:
        self.base, self.table, self.paths = base, table, dict(paths)
        self.indices = indices
        self._valid = np.zeros(table.count, dtype=bool)
        self._valid[indices] = True

    def __getitem__(self, index: int) -> LazyCase:
        if not 0 <= index < self._valid.size or not self._valid[index]:
            raise KeyError(index)
        return LazyCase(self.base, {self.paths[p]: v for p, v in self.table.case(index).items()})

    def __iter__(self) -> Iterator[int]:
        return (int(i) for i in self.indices)

    def __len__(self) -> int:
        return int(self.indices.size)

    def indexed(self) -> Sequence[tuple[int, Case]]:
        """(index, case) of every valid case in order, made when read (sliceable)."""
        return _Indexed(self)


class _Indexed(Sequence[tuple[int, Case]]):
    def __init__(self, cases: LazyCases) -> None:
        self.cases = cases

    def __len__(self) -> int:
        return len(self.cases)

    def __getitem__(self, k: Any) -> Any:
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        index = int(self.cases.indices[k])
        return index, self.cases[index]


def case_problems(invalid: dict[int, list[str]], table: CaseTable) -> list[str]:
    """The lines of a SweepError for the ``invalid`` cases: one per kind of problem."""
    return _case_problems(_grouped(invalid), table)


def invalid_message(problems: list[str]) -> str:
    """The error recorded for an invalid case skipped by ``skip_invalid``."""
    return "invalid case, not run: " + "; ".join(problems)


def _grouped(invalid: dict[int, list[str]]) -> dict[str, list[tuple[int, str]]]:
    """Problems by kind ("x must be <= 1.37 m, got 1.4": one line per kind, not per value)."""
    grouped: dict[str, list[tuple[int, str]]] = {}
    for index, problems in invalid.items():
        for problem in problems:
            grouped.setdefault(problem.split(", got ")[0], []).append((index, problem))
    return grouped


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
