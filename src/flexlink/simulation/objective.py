"""A scalar objective over a run's channels with its exact gradient, for scipy.optimize.

``Objective(scenario, fields, metric)(x)`` sets the fields to x, runs the scenario and returns
the metric and its gradient in x, as ``scipy.optimize.minimize(objective, objective.x0,
jac=True)`` calls it: the gradient of what the run computed, by one reverse pass of its steps
or from the fields' tangents (`simulation.adjoint`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from ..model import Scenario
from ..results import Results
from ..scenario.fields import ScenarioFile
from .sensitivities import SensitivityError, prepare_fields, scenario_file

# (results) → (value, {channel: ∂value/∂channel values, (nt,)})
Metric = Callable[[Results], tuple[float, Mapping[str, np.ndarray]]]


@dataclass(frozen=True)
class MeanSquare:
    """The mean over the output times t ≥ ``after`` (s) of (channel − target)², in the
    channel's unit squared: a residual vibration (target 0) or a tracking error."""

    channel: str
    after: float = 0.0
    target: float = 0.0

    def __post_init__(self) -> None:
        for name in ("after", "target"):  # NaN would make the objective NaN for every x
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float) \
                    or not math.isfinite(value):
                raise ValueError(f"MeanSquare.{name} must be a finite number "
                                 f"({'s' if name == 'after' else 'the channel unit'}), "
                                 f"got {value!r}")

    def __call__(self, results: Results) -> tuple[float, dict[str, np.ndarray]]:
        if self.channel not in results:
            raise SensitivityError(f"the metric's channel {self.channel!r} is not a channel "
                                   f"of this run; channels: {', '.join(results.names)}")
        keep = results.time >= self.after
        count = int(keep.sum())
        if count == 0:
            raise SensitivityError(f"the metric's after = {self.after:g} s leaves no output "
                                   "time")
        error = np.where(keep, results[self.channel] - self.target, 0.0)
        return float(np.sum(error ** 2) / count), {self.channel: 2.0 * error / count}


class Objective:
    """f(x) and ∇f(x) of ``metric`` over a run with the ``fields`` (field paths) set to x.

    ``metric``: a callable (results) → (value, {channel: ∂value/∂channel over time}), e.g.
    `MeanSquare`. Calls with the same x reuse the last run. Every field is checked when the
    objective is made, before anything runs."""

    def __init__(self, scenario: Scenario | ScenarioFile, fields: Sequence[str],
                 metric: Metric) -> None:
        self.file = scenario_file(scenario)
        self.fields = list(fields)
        self.metric = metric
        built = self.file.build()
        self._targets = [f.target for f in prepare_fields(self.file, built, self.fields)]
        paths = [t.path for t in self._targets]
        for i, path in enumerate(paths):  # x would set one field twice
            if path in paths[:i]:
                first = self.fields[paths.index(path)]
                raise SensitivityError(f"fields {first!r} and {self.fields[i]!r} are the same "
                                       "field of the scenario; give it once")
        self._channels = _channel_names(built)
        self.x0 = np.array([float(t.value) for t in self._targets])
        self._last: tuple[np.ndarray, float, np.ndarray] | None = None
        self.runs = 0
        self.method = ""  # how the last gradient was computed: "adjoint" or "tangents"

    def results(self, x: np.ndarray) -> Results:
        """The run (with sensitivities) at x."""
        from .sensitivities import simulate_with_sensitivities

        self.runs += 1
        return simulate_with_sensitivities(self._file_at(x), self.fields, shapes=False)

    def _file_at(self, x: np.ndarray) -> ScenarioFile:
        x = np.asarray(x, dtype=float)
        if x.shape != self.x0.shape:
            raise ValueError(f"x has shape {x.shape}; the objective has {self.x0.size} fields")
        values = {t.path: float(v) for t, v in zip(self._targets, x, strict=True)}
        return ScenarioFile(self.file.with_values(values), self.file.base_dir, self.file.name,
                            self.file.source)

    def __call__(self, x: np.ndarray) -> tuple[float, np.ndarray]:
        """(f(x), ∇f(x)): the metric and its derivative in each field, in field order. The
        gradient comes from one reverse pass of the run's steps (the prescribed path's
        Lawson steps, the forward path's Radau IIA steps) when the metric's channels are
        sensors on the modes, else from the fields' tangents (simulation/adjoint.py,
        simulation/forward_adjoint.py); ``method`` says which the last call took."""
        from .adjoint import adjoint_run, objective_gradient
        from .sensitivities import sensitivity_run

        x = np.array(x, dtype=float)
        if self._last is not None and np.array_equal(self._last[0], x):
            return self._last[1], self._last[2].copy()
        _check_channels(self._channels, self.metric)
        file = self._file_at(x)
        self.runs += 1
        results, prepared, settled = sensitivity_run(file, self.fields, False, False,
                                                     adjoint_run)
        value, slopes = self.metric(results)
        gradient, self.method = objective_gradient(settled, prepared, results.time, slopes)
        self._last = (x, float(value), gradient)
        return float(value), gradient.copy()


def _channel_names(scenario: Scenario) -> list[str]:
    """The channels runs of ``scenario`` produce (`channels.catalogue`)."""
    from ..channels.catalogue import catalogue

    return [c.name for c in catalogue(scenario)]


def _check_channels(names: list[str], metric: Metric) -> None:
    """SensitivityError, before the run, if the metric names (``channel`` or ``channels``)
    a channel not among ``names``."""
    named = getattr(metric, "channels", None) or [getattr(metric, "channel", None)]
    for name in named:
        if isinstance(name, str) and name not in names:
            raise SensitivityError(f"the metric's channel {name!r} is not a channel of this "
                                   f"run; channels: {', '.join(names)}")


def warm_up(scenario: Scenario, fields: Sequence[str], channel: str) -> None:
    """One gradient by the reverse pass (the mean square of ``channel``, a sensor on the
    modes): loads or compiles its loop (`flexlink warmup`)."""
    objective = Objective(scenario, fields, MeanSquare(channel))
    objective(objective.x0)
