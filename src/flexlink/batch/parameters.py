"""Sweep parameters: field paths, grid values and random distributions → the table of cases.

A parameter names one numeric field of the scenario file by its path
(`flexlink.scenario.fields`), e.g. ``links[0].EI``, ``links[link1].E`` or
``joints[0].motion[0].duration``. Grid parameters give a list of values (or a
``linspace:a:b:n`` / ``geomspace:a:b:n`` rule); random parameters give a distribution
(``uniform:low:high``, ``loguniform:low:high``, ``normal:mean:std``). The cases are the
cartesian product of the grid values, each combined with the same ``samples`` random draws
(common random numbers: grid points are compared on identical samples). docs/sweep.md.
"""

from __future__ import annotations

import itertools
import math
import re
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..scenario.fields import FieldPath, FieldPathError, parse
from .errors import SweepError

_INTEGER = re.compile(r"[+-]?\d+")
DISTRIBUTIONS = {"uniform": ("low", "high"), "loguniform": ("low", "high"),
                 "normal": ("mean", "std")}
SAMPLERS = ("random", "lhs")
RULES = ("linspace", "geomspace")


def parse_path(path: str) -> FieldPath:
    """`flexlink.scenario.fields.parse`, a malformed path raised as a SweepError."""
    try:
        return parse(path)
    except FieldPathError as exc:
        raise SweepError([str(exc)]) from None


@dataclass(frozen=True)
class GridParameter:
    """A field taking each of ``values`` in turn (SI units, degrees for *_deg keys)."""

    path: str
    values: tuple[float | int, ...]

    @property
    def description(self) -> str:
        return "grid: " + ", ".join(f"{v:g}" for v in self.values)


@dataclass(frozen=True)
class RandomParameter:
    """A field drawn from ``distribution`` with parameters ``a``, ``b`` (see DISTRIBUTIONS)."""

    path: str
    distribution: str
    a: float
    b: float

    @property
    def description(self) -> str:
        first, second = DISTRIBUTIONS[self.distribution]
        return f"random: {self.distribution}({first}={self.a:g}, {second}={self.b:g})"

    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Map numbers u in (0, 1) through the inverse distribution function."""
        if self.distribution == "uniform":
            return self.a + u * (self.b - self.a)
        if self.distribution == "loguniform":
            return np.exp(np.log(self.a) + u * (np.log(self.b) - np.log(self.a)))
        from scipy.special import ndtri  # inverse of the standard normal distribution

        return self.a + self.b * ndtri(u)


def _number(text: str, where: str) -> float | int:
    """A finite number; integer literals stay int (integer fields such as ``modes``)."""
    text = text.strip()
    if _INTEGER.fullmatch(text):
        return int(text)
    try:
        value = float(text)
    except ValueError:
        raise SweepError([f"{where}: expected a number, got {text!r}"]) from None
    if not math.isfinite(value):
        raise SweepError([f"{where}: expected a finite number, got {text!r}"])
    return value


def _split_assignment(text: str, option: str, example: str) -> tuple[str, str]:
    path, sep, rest = text.partition("=")
    if not sep or not rest.strip():
        raise SweepError([f"{option} {text!r}: expected PATH=..., e.g. {option} {example}"])
    path = path.strip()
    parse_path(path)
    return path, rest.strip()


def grid_values(path: str, spec: str | Sequence[float | int]) -> GridParameter:
    """Grid values from a list of numbers, ``'1,2,3'``, ``'linspace:a:b:n'`` or
    ``'geomspace:a:b:n'`` (n values from a to b, evenly or geometrically spaced)."""
    where = f"grid {path}"
    parse_path(path)
    if isinstance(spec, str):
        head, colon, tail = spec.partition(":")
        if colon and head in RULES:
            parts = tail.split(":")
            if len(parts) != 3:
                raise SweepError([f"{where}: expected {head}:start:stop:count, got {spec!r}"])
            start, stop = (float(_number(p, where)) for p in parts[:2])
            count = _number(parts[2], where)
            if not isinstance(count, int) or count < 1:
                raise SweepError([f"{where}: the count of {spec!r} must be an integer >= 1"])
            if head == "geomspace" and (start <= 0 or stop <= 0):
                raise SweepError([f"{where}: geomspace needs start and stop > 0, got {spec!r}"])
            rule = np.linspace if head == "linspace" else np.geomspace
            values: list[float | int] = [float(v) for v in rule(start, stop, count)]
        elif colon:
            raise SweepError([(f"{where}: unknown rule {head!r} in {spec!r}; give numbers "
                               "separated by commas, linspace:start:stop:count or "
                               "geomspace:start:stop:count")])
        else:
            values = [_number(v, where) for v in spec.split(",")]
    elif not isinstance(spec, Sequence | np.ndarray):  # a lone number, a table
        raise SweepError([f"{where}: expected a list of numbers or a rule, e.g. [{spec!r}] "
                          "or 'linspace:200:400:5', got " + repr(spec)])
    else:
        values = []
        for v in spec:
            if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
                raise SweepError([f"{where}: expected finite numbers, got {v!r}"])
            values.append(v)
    if not values:
        raise SweepError([f"{where}: needs at least one value"])
    return GridParameter(path, tuple(values))


def random_distribution(path: str, spec: str | Sequence[Any]) -> RandomParameter:
    """A distribution from ``'uniform:low:high'``, ``'loguniform:low:high'`` (low > 0) or
    ``'normal:mean:std'``, or the same as a tuple ``('uniform', low, high)``."""
    where = f"random {path}"
    parse_path(path)
    parts = (spec.split(":") if isinstance(spec, str)
             else list(spec) if isinstance(spec, Sequence) else [])  # a lone number: refused
    name = parts[0] if parts else None
    if name not in DISTRIBUTIONS or len(parts) != 3:
        raise SweepError([(f"{where}: expected uniform:low:high, loguniform:low:high or "
                           f"normal:mean:std, got {spec!r}")])
    a, b = (_number(str(p), where) if isinstance(p, str) else p for p in parts[1:])
    for value in (a, b):
        if isinstance(value, bool) or not isinstance(value, int | float) \
                or not math.isfinite(value):
            raise SweepError([f"{where}: expected finite numbers, got {spec!r}"])
    a, b = float(a), float(b)
    if name in ("uniform", "loguniform") and not a < b:
        raise SweepError([f"{where}: needs low < high, got {spec!r}"])
    if name == "loguniform" and a <= 0:
        raise SweepError([f"{where}: loguniform needs low > 0, got {spec!r}"])
    if name == "normal" and b <= 0:
        raise SweepError([f"{where}: normal needs std > 0, got {spec!r}"])
    return RandomParameter(path, str(name), a, b)


def parse_grid_option(text: str) -> GridParameter:
    """The command-line form ``PATH=VALUES`` of `grid_values`."""
    path, spec = _split_assignment(text, "--grid", "links[0].EI=300,310,320")
    return grid_values(path, spec)


def parse_random_option(text: str) -> RandomParameter:
    """The command-line form ``PATH=DISTRIBUTION:A:B`` of `random_distribution`."""
    path, spec = _split_assignment(text, "--random",
                                   "joints[0].motion[0].duration=uniform:0.8:1.2")
    return random_distribution(path, spec)


@dataclass(frozen=True)
class CaseTable:
    """Parameter values of every case: ``values[path]`` is an array over cases."""

    parameters: tuple[GridParameter | RandomParameter, ...]
    values: dict[str, np.ndarray]
    seed: int | None
    sampler: str

    @property
    def count(self) -> int:
        return next(iter(self.values.values())).size

    def case(self, index: int) -> dict[str, float | int]:
        """{path: value} of one case, as Python numbers."""
        return {path: column[index].item() for path, column in self.values.items()}

    def rows(self, start: int, stop: int) -> CaseTable:
        """The table of cases ``start`` … ``stop`` − 1 (numbered from 0 again)."""
        return CaseTable(self.parameters, {p: v[start:stop] for p, v in self.values.items()},
                         self.seed, self.sampler)


def case_table(grid: Iterable[GridParameter], random: Iterable[RandomParameter] = (),
               samples: int | None = None, seed: int | None = None,
               sampler: str = "random") -> CaseTable:
    """All cases: the grid's cartesian product (last parameter fastest), each point run with
    the same ``samples`` random draws. With random parameters and no seed, a seed is drawn
    and recorded so the sweep can be repeated."""
    grid, random = list(grid), list(random)
    paths = [p.path for p in grid + random]
    problems = [f"parameter {p} is given twice" for p in sorted(set(paths)) if paths.count(p) > 1]
    if not paths:
        problems.append("nothing to sweep: give at least one grid or random parameter")
    if random and (samples is None or isinstance(samples, bool) or not isinstance(samples, int)
                   or samples < 1):
        problems.append(f"random parameters need samples = an integer >= 1, got {samples!r}")
    if samples is not None and not random:
        problems.append("samples is given but there is no random parameter to draw")
    if sampler not in SAMPLERS:
        problems.append(f"sampler must be one of {', '.join(SAMPLERS)}, got {sampler!r}")
    if problems:
        raise SweepError(problems)

    points = list(itertools.product(*(p.values for p in grid))) or [()]
    draws = 1
    columns: dict[str, np.ndarray] = {}
    if random:
        draws = int(samples)  # type: ignore[arg-type]
        if seed is None:
            seed = int(np.random.SeedSequence().entropy % 2**63)
        unit = _unit_samples(draws, len(random), seed, sampler)
        for j, parameter in enumerate(random):
            columns[parameter.path] = np.tile(parameter.from_unit(unit[:, j]), len(points))
    for j, parameter in enumerate(grid):
        column = [point[j] for point in points]
        dtype = np.int64 if all(isinstance(v, int) for v in column) else np.float64
        columns[parameter.path] = np.repeat(np.asarray(column, dtype=dtype), draws)
    ordered = {p.path: columns[p.path] for p in grid + random}
    return CaseTable(tuple(grid + random), ordered, seed if random else None, sampler)


def _unit_samples(count: int, dimensions: int, seed: int, sampler: str) -> np.ndarray:
    """(count, dimensions) numbers strictly inside (0, 1): independent, or a Latin hypercube."""
    if sampler == "lhs":
        from scipy.stats import qmc

        u = qmc.LatinHypercube(d=dimensions, seed=np.random.default_rng(seed)).random(count)
    else:
        u = np.random.default_rng(seed).random((count, dimensions))
    # keep the normal's inverse distribution finite (u = 0 has probability 2**-53)
    return np.clip(u, np.finfo(float).tiny, 1.0 - np.finfo(float).epsneg)


def from_mappings(grid: Mapping[str, Any] | None, random: Mapping[str, Any] | None
                  ) -> tuple[list[GridParameter], list[RandomParameter]]:
    """Python-API form: ``grid={'links[0].EI': [300, 310]}``,
    ``random={'joints[0].motion[0].duration': 'uniform:0.8:1.2'}``; all problems at once."""
    problems: list[str] = []
    grids: list[GridParameter] = []
    randoms: list[RandomParameter] = []
    for path, spec in (grid or {}).items():
        try:
            grids.append(grid_values(path, spec))
        except SweepError as exc:
            problems += exc.problems
    for path, spec in (random or {}).items():
        try:
            randoms.append(random_distribution(path, spec))
        except SweepError as exc:
            problems += exc.problems
    if problems:
        raise SweepError(problems)
    return grids, randoms
