"""Collect case results into one labelled `xarray.Dataset` (case × time per channel).

Layout: one variable per channel with dims (case, time), units and long names in attrs; the
parameter values as coordinates on ``case``; ``status`` per case (``"ok"``, ``"failed"``,
``"not_run"``), ``error`` (the failure message, empty otherwise), ``wall_time`` and
``cpu_time`` (s).
Cases that did not finish hold 0.0, never NaN: select finished cases with
``ds.sel(case=ds.status == "ok")``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .parameters import CaseTable
from ..channels import Channel
from .worker import ChunkResult, SharedResults, labels

if TYPE_CHECKING:
    import xarray as xr

STATUSES = ("ok", "failed", "not_run")
PARAMETER_UNITS = {
    "length": "m", "mass_per_length": "kg/m", "EI": "N·m²", "E": "Pa", "width": "m",
    "thickness": "m", "tip_mass": "kg", "tip_inertia": "kg·m²", "damping_ratio": "1",
    "modes": "1", "from_deg": "deg", "to_deg": "deg", "angle_deg": "deg",
    "to_rate_deg_s": "deg/s", "start": "s", "duration": "s", "lowpass_hz": "Hz", "x": "m",
    "x_start": "m", "x_end": "m", "E_p": "Pa", "d31": "m/V", "capacitance": "F",
    "rtol": "1", "atol": "1",
}


class SweepCollector:
    """Case results as they arrive, in preallocated arrays (channel × case × time): allocated
    at the first result, or given (``shared``, which forked workers write into directly)."""

    def __init__(self, table: CaseTable, time: np.ndarray, attrs: dict[str, str],
                 shared: SharedResults | None = None, channels: tuple[Channel, ...] = ()
                 ) -> None:
        self.table = table
        self.time = time
        self.attrs = attrs
        self.status = np.full(table.count, "not_run", dtype="<U7")
        self.error = np.full(table.count, "", dtype=object)
        self.wall_time = np.zeros(table.count)
        self.cpu_time = np.zeros(table.count)
        self.channels: tuple[Channel, ...] = channels if shared is not None else ()
        self._values: np.ndarray | None = None if shared is None else shared.array
        # while workers may write into the shared array, rows of cases that are not "ok"
        # can hold partial data: masked when read, zeroed by `settle` once workers stopped
        self._unsettled = shared is not None

    def add(self, chunk: ChunkResult) -> None:
        """Store a finished chunk; a chunk whose channels differ from the first fails."""
        for index, message in chunk.failed.items():
            self.fail(index, message)
        if not chunk.done:
            return
        if self._values is None:
            self.channels = chunk.channels
            self._values = np.zeros((len(self.channels), self.table.count, self.time.size))
        if labels(chunk.channels) != labels(self.channels):
            for index in chunk.done:
                self.fail(index, "ValueError: channels differ from the first finished case's")
            return
        for index, block, wall, cpu in zip(chunk.done, chunk.values, chunk.wall_times,
                                           chunk.cpu_times):
            if block is not None:  # else the worker wrote it into the shared array
                self._values[:, index, :] = block
            self.status[index] = "ok"
            self.wall_time[index] = wall
            self.cpu_time[index] = cpu

    def fail(self, index: int, message: str) -> None:
        self.status[index] = "failed"
        self.error[index] = message

    def settle(self) -> None:
        """No worker writes any more: clear the rows of cases that did not finish."""
        if self._unsettled and self._values is not None:
            self._values[:, self.status != "ok", :] = 0.0
        self._unsettled = False

    @property
    def counts(self) -> dict[str, int]:
        return {s: int(np.count_nonzero(self.status == s)) for s in STATUSES}

    def dataset(self) -> xr.Dataset:
        """The Dataset of everything collected so far (see the module docstring)."""
        import xarray as xr

        coords: dict[str, Any] = {
            "case": ("case", np.arange(self.table.count, dtype=np.int32),
                     {"long_name": "case number (0-based, in the order of the parameter table)"}),
            "time": ("time", self.time, {"units": "s", "long_name": "time"}),
        }
        for parameter in self.table.parameters:
            key = parameter.path.rsplit(".", 1)[-1]
            attrs = {"long_name": f"scenario field {parameter.path}",
                     "sweep": parameter.description}
            if key in PARAMETER_UNITS:
                attrs["units"] = PARAMETER_UNITS[key]
            coords[parameter.path] = ("case", self.table.values[parameter.path], attrs)
        data: dict[str, Any] = {}
        values = self._values
        if self._unsettled and values is not None:  # a copy: workers may still write
            values = np.where((self.status == "ok")[None, :, None], values, 0.0)
        for k, channel in enumerate(self.channels):
            assert values is not None
            data[channel.name] = (("case", "time"), values[k],
                                  {"units": channel.unit, "long_name": channel.description})
        data["status"] = ("case", self.status.astype(str),
                          {"long_name": "ok: finished; failed: see error; not_run: never ran "
                                        "(interrupted). Signals of cases not ok hold 0.0"})
        data["error"] = ("case", self.error.astype(str), {"long_name": "failure message"})
        data["wall_time"] = ("case", self.wall_time,
                             {"units": "s", "long_name": "wall time of the case's simulation"})
        data["cpu_time"] = ("case", self.cpu_time,
                            {"units": "s", "long_name": "CPU time of the case's simulation "
                                                        "(of the thread that ran it)"})
        counts = self.counts
        attrs = {**self.attrs, **{f"cases_{s}": counts[s] for s in STATUSES}}
        return xr.Dataset(data, coords=coords, attrs=attrs)
