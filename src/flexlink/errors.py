"""The package's general errors (input errors of scenarios and sweeps live with their readers)."""

from __future__ import annotations

from typing import Any


class SimulationError(RuntimeError):
    """A run failed or produced a non-physical state (non-finite, exploding, or outside the
    model's validity); the message says where and what to change."""


class RunTooLarge(SimulationError, ValueError):
    """The run's arrays would not fit in memory: refused before anything runs (an input
    error, so also a ValueError); the message gives a coarser grid that fits."""


class StoppedRun(SimulationError):
    """A run that stopped at ``t`` (s) before its end; ``states``: the output rows reached
    before it (NaN after), ``y``: the last state; ``left_travel``: the integrator stopped
    because a step ended with a cart or a slider outside its travel. simulation/forward.py
    reads them to tell a cart or slider that left its travel (the usual cause) from other
    blow-ups."""

    def __init__(self, message: str, t: float, states: Any = None, y: Any = None,
                 left_travel: bool = False) -> None:
        self.t, self.states, self.y, self.left_travel = t, states, y, left_travel
        super().__init__(message)


class UnstableLoop(SimulationError):
    """A closed loop blew up at time ``t`` (s); ``why`` says how. The Lawson closed loop
    (solvers/closed_loop.py) adds the grid ``index``, the ``states`` up to it and its
    ``work`` arrays, from which simulation/closed_loop.py tells the user which loop grew."""

    def __init__(self, t: float, why: str, index: int | None = None,
                 states: Any = None, work: Any = None) -> None:
        self.t, self.index, self.states, self.work = t, index, states, work
        super().__init__(f"closed loop unstable: {why} at t = {t:.4g} s; lower the gain or "
                         "retune")
