"""The package's general errors (input errors of scenarios and sweeps live with their readers)."""

from __future__ import annotations

from typing import Any


class SimulationError(RuntimeError):
    """A run failed or produced a non-physical state (non-finite, exploding, or outside the
    model's validity); the message says where and what to change."""


class RunTooLarge(SimulationError, ValueError):
    """The run's arrays would not fit in memory: refused before anything runs (an input
    error, so also a ValueError); the message gives a coarser grid that fits."""


class UnstableLoop(SimulationError):
    """A closed loop blew up at time ``t`` (s); ``why`` says how. The Lawson closed loop
    (solvers/closed_loop.py) adds the grid ``index``, the ``states`` up to it and its
    ``work`` arrays, from which simulation/closed_loop.py tells the user which loop grew."""

    def __init__(self, t: float, why: str, index: int | None = None,
                 states: Any = None, work: Any = None) -> None:
        self.t, self.index, self.states, self.work = t, index, states, work
        super().__init__(f"closed loop unstable: {why} at t = {t:.4g} s; lower the gain or "
                         "retune")
