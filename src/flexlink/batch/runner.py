"""One case of a sweep where it runs: `flexlink.simulate` up to its channel values, without
building its `Results`, and one integration for consecutive cases that differ only in their
sensors.

A sensor reads the motion and changes none of it (a sensor that feeds a controller makes
the case a closed loop, whose path offers no re-reading). So two cases whose scenarios are
equal but for their sensors have the same system, frames and solution, and the second
case's channels are the first one's with its own sensors read from that motion: the same
operations on the same numbers as its own run, so the same values bit for bit
(tests/unit/test_sweep_runner.py). Every other case is its own `run_scenario` call, which
computes only the channels the sweep keeps (its histories' and its summaries').
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..channels import Channel
from ..model import Scenario
from ..simulation.common import PathRun, catalogue_values

if TYPE_CHECKING:
    from ..dynamics.prescribed_kernel import CompiledFirstOrderSystem
    from ..solvers import Solution


@dataclass(frozen=True)
class CaseRun:
    """A case's output times (s), its channels in the catalogue's order and their values,
    each checked finite as a single run checks them."""

    time: np.ndarray
    channels: Mapping[str, Channel]
    values: Mapping[str, np.ndarray]
    shared: bool  # read from the previous case's run (only its sensors differ)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.values[name]

    def __contains__(self, name: object) -> bool:
        return name in self.values

    @property
    def names(self) -> list[str]:
        return list(self.channels)


@dataclass(frozen=True)
class Integrated:
    """A case's system and its solution (in the integrated coordinates, before the
    system's `shift_solution`), and its share of the time it took (s)."""

    system: CompiledFirstOrderSystem
    solution: Solution
    wall: float
    cpu: float

    def arguments(self) -> dict[str, object]:
        """`run_prescribed`'s arguments that hand it this system and solution."""
        solution = self.solution
        return {"system": self.system, "integrate": lambda *_: solution}


class CaseRunner:
    """Runs a worker's cases one after the other, keeping the last case's run for the next
    case if that one differs from it only in its sensors."""

    def __init__(self) -> None:
        self._last: tuple[Scenario, PathRun, frozenset[str] | None] | None = None

    def run(self, scenario: Scenario, kept: Collection[str] | None = None,
            integrated: Integrated | None = None) -> CaseRun:
        """The case's channel values (``kept``: of these channels only, the only ones its run
        computes where its path can leave the others out; None: all); a failure raises as
        `flexlink.simulate` would. The run is `flexlink.simulation.run_scenario`, looked up
        when called (what a test replaces to make a case fail); ``integrated``: its system
        and solution, integrated with other cases' (grouped.py)."""
        from .. import simulation  # a worker imports the simulation on first use

        names = None if kept is None else frozenset(kept)
        last, self._last = self._last, None  # a failing case keeps nothing
        shared = last is not None and last[1].read_sensors is not None \
            and last[2] == names and equal_but_sensors(last[0], scenario)
        if shared:
            assert last is not None and last[1].read_sensors is not None
            previous = last[1]
            read = previous.read_sensors(scenario.sensors if names is None else tuple(
                s for s in scenario.sensors if s.name in names))
            run = dataclasses.replace(previous, values={**previous.values, **read})
        else:  # a sweep keeps no shapes
            more = {} if integrated is None else {"prescribed": integrated.arguments()}
            run = simulation.run_scenario(scenario, shapes=False, channels=names, **more)[0]
        checked = catalogue_values(scenario, run, names)
        self._last = (scenario, run, names)
        return CaseRun(run.solution.t, {c.name: c for c, _ in checked},
                       {c.name: v for c, v in checked}, shared)

    def clear(self) -> None:
        """Forget the last run (its arrays)."""
        self._last = None


def equal_but_sensors(a: Scenario, b: Scenario) -> bool:
    """Whether ``a`` and ``b`` are equal in everything but their sensors (False where a
    field cannot be compared, such as a measured motion's arrays)."""
    if a is b:
        return True
    try:  # field by field as the dataclass's == compares them, without building two copies
        return type(a) is type(b) and all(
            x is y or bool(x == y) for x, y in ((getattr(a, name), getattr(b, name))
                                               for name in _ALL_BUT_SENSORS))
    except (ValueError, TypeError):  # numpy arrays compare element-wise
        return False


# the chain first: what differs between most cases of a sweep that vary the model
_ALL_BUT_SENSORS = ("chain", *(f.name for f in dataclasses.fields(Scenario)
                               if f.name not in ("chain", "sensors")))

