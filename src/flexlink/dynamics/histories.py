"""Where input histories are not smooth: the integrators end steps (or table blocks) there."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from ..model import BangBang, PositionServo, Step, Sum, Table, TorqueDrive, VelocityServo
from ..model.histories import History
from ..model.joints import drive_side


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


def input_breakpoints(joints: Sequence[Any], actuators: Sequence[Any] = (),
                      loads: Iterable[History] = ()) -> np.ndarray:
    """Sorted finite times (s) where an input is not smooth: a prescribed joint's motion, a
    servo's reference, a driven joint's torque, an actuator's voltage, the ``loads``."""
    times: set[float] = set()
    for joint in map(drive_side, joints):
        if isinstance(joint, TorqueDrive):
            times |= history_breakpoints(joint.torque)
        else:
            motion = joint.reference if isinstance(joint, VelocityServo | PositionServo) else joint
            times |= set(getattr(motion, "breakpoints", ()))
    for actuator in actuators:
        times |= history_breakpoints(actuator.voltage)
    for load in loads:
        times |= history_breakpoints(load)
    return np.array(sorted(b for b in times if np.isfinite(b)), dtype=float)
