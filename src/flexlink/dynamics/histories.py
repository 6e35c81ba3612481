"""Where input histories are not smooth: the integrators end steps (or table blocks) there."""

from __future__ import annotations

from ..model import BangBang, Step, Sum, Table
from ..model.histories import History


def history_breakpoints(history: History) -> set[float]:
    """Times (s) where an input history jumps or kinks (its samples, for a table)."""
    if isinstance(history, BangBang):
        return {history.start, history.start + 0.5 * history.duration,
                history.start + history.duration}
    if isinstance(history, Step):
        return {history.start, history.start + history.duration}
    if isinstance(history, Table):
        return set(history.t)
    if isinstance(history, Sum):
        return set().union(*(history_breakpoints(p) for p in history.parts))
    return set(getattr(history, "breakpoints", ()))
