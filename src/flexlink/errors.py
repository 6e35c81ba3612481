"""The package's general errors (input errors of scenarios and sweeps live with their readers)."""

from __future__ import annotations


class SimulationError(RuntimeError):
    """A run failed or produced a non-physical state (non-finite, exploding, or outside the
    model's validity); the message says where and what to change."""
