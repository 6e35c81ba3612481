"""Some channels of a prescribed run's solution, computing the frames only if one of them
needs them: what a metric over a few channels reads when it is differentiated
(simulation/adjoint.py, the tangents of `sensitivities.forward_derivatives`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import Scenario
from ..solvers import Solution


@dataclass(frozen=True)
class State:
    """What the channel readings read of a Solution, without its checks: a state next to
    the run's."""

    t: np.ndarray
    q: np.ndarray
    q_dot: np.ndarray
    q_ddot: np.ndarray


class _Frames:
    """The frames along a solution (`prescribed_kernel.solved_frames`), made when first read;
    ``used`` tells whether a reading needed them."""

    def __init__(self, system: Any, solution: Solution) -> None:
        self._system, self._solution = system, solution
        self._frames: Any = None
        self.used = False

    def __getattr__(self, name: str) -> Any:
        if name.startswith("_"):
            raise AttributeError(name)
        if self._frames is None:
            from ..dynamics.prescribed_kernel import solved_frames

            s = self._solution
            self._frames = solved_frames(self._system, s.t, s.q, s.q_dot, s.q_ddot)
            self.used = True
        return getattr(self._frames, name)


def channel_values(scenario: Scenario, system: Any, solution: Solution,
                   names: Sequence[str]) -> tuple[dict[str, np.ndarray], bool]:
    """The channels ``names`` of a prescribed run's solution, and whether they needed the
    frames: sensors read alone (`channels.first_order.sensor_values`), any other channel
    from the channel map reading only those (`prescribed.prescribed_readings`' ``kept``)."""
    from ..channels.first_order import sensor_values
    from .prescribed import prescribed_readings

    frames = _Frames(system, solution)
    sensors = tuple(s for s in scenario.sensors if s.name in names)
    out = sensor_values(system, frames, solution, sensors)  # type: ignore[arg-type]
    rest = [name for name in names if name not in out]
    if rest:
        values = prescribed_readings(scenario, system, solution, False, checked=False,
                                     kept=rest)[0]
        out.update({name: np.asarray(values[name], dtype=float) for name in rest})
        return out, True
    return out, frames.used
