"""The package's general errors (input errors of scenarios and sweeps live with their readers)."""

from __future__ import annotations


class SimulationError(RuntimeError):
    """A run failed or produced a non-physical state (non-finite, exploding, or outside the
    model's validity); the message says where and what to change."""


class RunTooLarge(SimulationError, ValueError):
    """The run's arrays would not fit in memory: refused before anything runs (an input
    error, so also a ValueError); the message gives a coarser grid that fits."""
