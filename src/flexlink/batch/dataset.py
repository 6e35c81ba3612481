"""Collect case results into one labelled `xarray.Dataset` (case × time per channel).

Layout (`flexlink.results.layout.sweep_layout`, the same as a run's results.nc): one variable
per channel with dims (case, time), units, long name and kind in attrs; the parameter values
as coordinates on ``case``; ``status`` per case (``"ok"``, ``"failed"``, ``"not_run"``),
``error`` (the failure message, empty otherwise), ``wall_time`` and ``cpu_time`` (s); one
variable over ``case`` per summary metric (`flexlink.batch.summaries`), NaN where a case is
not ``ok``. A sweep that keeps no histories has no ``time`` axis.
The signals (and times) of cases that did not finish are NaN (``_FillValue``): select
finished cases with ``ds.sel(case=ds.status == "ok")``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from ..channels import Channel
from ..results.layout import parameter_variable, sweep_layout
from ..results.variables import Layout, Variable
from ..scenario.fields import ScenarioFile, Target, parse
from .parameters import CaseTable
from .summaries import Summary
from .worker import ChunkResult, SharedResults, labels

if TYPE_CHECKING:
    import xarray as xr

STATUSES = ("ok", "failed", "not_run")


def parameter_unit(path: str, base: ScenarioFile | None = None) -> str | None:
    """The UDUNITS unit of a swept field, from the schema (as a sensitivity's field unit);
    None where the schema spells none. ``base``: the swept scenario file, which says whether
    a ``joints[k]`` path is a slider's (gains per metre)."""
    from ..simulation.sensitivities import field_unit

    target = base.locate(path) if base is not None else Target(path, parse(path), None, False)
    return field_unit(target) or None


class SweepCollector:
    """Case results as they arrive, in preallocated arrays (channel × case × time): allocated
    at the first result, or given (``shared``, which forked workers write into directly)."""

    def __init__(self, table: CaseTable, time: np.ndarray | None, attrs: dict[str, Any],
                 shared: SharedResults | None = None, channels: tuple[Channel, ...] = (),
                 summaries: Sequence[tuple[Summary, Channel]] = (),
                 base: ScenarioFile | None = None) -> None:
        self.table = table
        self.base = base  # the swept scenario file: its parameters' units
        self.time = time  # None: the sweep keeps no histories
        self.summaries = list(summaries)
        self.summary_values = np.full((len(self.summaries), table.count), np.nan)
        self.attrs = attrs
        self.status = np.full(table.count, "not_run", dtype="<U7")
        self.error = np.full(table.count, "", dtype=object)
        self.wall_time = np.full(table.count, np.nan)
        self.cpu_time = np.full(table.count, np.nan)
        self.channels: tuple[Channel, ...] = channels if shared is not None else ()
        self._values: np.ndarray | None = None if shared is None else shared.array
        # while workers may write into the shared array, rows of cases that are not "ok"
        # can hold partial data: masked when read, set to NaN by `settle` once workers stopped
        self._unsettled = shared is not None

    def add(self, chunk: ChunkResult) -> None:
        """Store a finished chunk; a chunk whose channels differ from the first fails."""
        for index, message in chunk.failed.items():
            self.fail(index, message)
        if not chunk.done:
            return
        for index, metrics in zip(chunk.done, chunk.summaries):
            self.summary_values[:, index] = metrics
        if self._values is None and self.time is not None:
            self.channels = chunk.channels
            self._values = np.full((len(self.channels), self.table.count, self.time.size),
                                   np.nan)
        if self._values is not None and labels(chunk.channels) != labels(self.channels):
            for index in chunk.done:
                self.fail(index, "ValueError: channels differ from the first finished case's")
            return
        for index, block, wall, cpu in zip(chunk.done, chunk.values, chunk.wall_times,
                                           chunk.cpu_times):
            if block is not None and self._values is not None:  # else in the shared array
                self._values[:, index, :] = block
            self.status[index] = "ok"
            self.wall_time[index] = wall
            self.cpu_time[index] = cpu

    def fail(self, index: int, message: str) -> None:
        self.status[index] = "failed"
        self.error[index] = message

    def settle(self) -> None:
        """No worker writes any more: NaN in the rows of cases that did not finish."""
        if self._unsettled and self._values is not None:
            self._values[:, self.status != "ok", :] = np.nan
        self._unsettled = False

    @property
    def counts(self) -> dict[str, int]:
        return {s: int(np.count_nonzero(self.status == s)) for s in STATUSES}

    def dataset(self) -> xr.Dataset:
        """The Dataset of everything collected so far (see the module docstring)."""
        return self.layout().to_xarray()

    def _integer_field(self, path: str) -> bool:
        """Whether the swept field takes integers (``modes``); a real-valued field swept
        over integer literals is stored as float, which MATLAB would otherwise compute
        with in integer arithmetic."""
        return self.base is None or self.base.locate(path).integer

    def layout(self) -> Layout:
        """Everything collected so far in the one layout of flexlink's files."""
        parameters = {}
        for parameter in self.table.parameters:
            values = self.table.values[parameter.path]
            if values.dtype.kind == "i" and not self._integer_field(parameter.path):
                values = values.astype(np.float64)  # EI = 10, 20: not int32 in the files
            parameters[parameter.path] = parameter_variable(
                parameter.path, values, parameter.description,
                parameter_unit(parameter.path, self.base))
        values = self._values
        if self._unsettled and values is not None:  # a copy: workers may still write
            values = np.where((self.status == "ok")[None, :, None], values, np.nan)
        ok = self.status == "ok"
        summaries = {
            s.name: Variable(("case",), np.where(ok, self.summary_values[k], np.nan),
                             {"units": s.unit(c), "long_name": s.long_name(c),
                              "summary_of": c.name, "metric": s.metric}, missing=True)
            for k, (s, c) in enumerate(self.summaries)}
        counts = self.counts
        metadata = {**self.attrs, **{f"cases_{s}": counts[s] for s in STATUSES}}
        return sweep_layout(self.time, parameters, self.channels, values, self.status,
                            self.error, self.wall_time, self.cpu_time, metadata, summaries)
