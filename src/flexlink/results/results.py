"""The result of one simulation: channels on a common time grid (SI units, radians)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..channels import Channel, ChannelKind

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr
    from matplotlib.figure import Figure


@dataclass
class Results:
    """Channels sampled at ``time`` (s), in the order they were added.

    ``results[name]`` is a channel's values, ``results.channels[name]`` its record (kind,
    unit, description); ``metadata`` says what ran (model, integrator, version, wall time).
    """

    time: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)
    channels: dict[str, Channel] = field(default_factory=dict)
    _values: dict[str, np.ndarray] = field(default_factory=dict, repr=False)

    def __getitem__(self, name: str) -> np.ndarray:
        return self._values[name]

    def __contains__(self, name: object) -> bool:
        return name in self._values

    @property
    def names(self) -> list[str]:
        return list(self.channels)

    def names_of(self, *kinds: ChannelKind) -> list[str]:
        """Names of the channels of the given kinds, in order."""
        return [n for n, c in self.channels.items() if c.kind in kinds]

    def add(self, channel: Channel, values: np.ndarray) -> None:
        """Add a channel; its values must be finite and on the time grid."""
        values = np.asarray(values, dtype=float)
        if values.shape != self.time.shape:
            raise ValueError(f"channel {channel.name!r} has shape {values.shape}, "
                             f"time has {self.time.shape}")
        if not np.all(np.isfinite(values)):
            raise FloatingPointError(f"channel {channel.name!r} contains non-finite values")
        self.channels[channel.name] = channel
        self._values[channel.name] = values

    def extend(self, items: Iterable[tuple[Channel, np.ndarray]]) -> None:
        for channel, values in items:
            self.add(channel, values)

    def to_pandas(self) -> pd.DataFrame:
        """A DataFrame indexed by ``t`` (s), one column per channel."""
        import pandas as pd

        frame = pd.DataFrame(dict(self._values), index=self.time)
        frame.index.name = "t"
        return frame

    def to_xarray(self) -> xr.Dataset:
        """A Dataset over ``time``: the layout of results.nc (``results.layout``)."""
        from .layout import run_dataset

        return run_dataset(self)

    def plot(self, kind: ChannelKind | str = ChannelKind.SENSOR) -> Figure:
        """A figure of the channels of one kind against time (joint angles with ``"joint"``,
        tip paths with ``"tip"``), as in the run folder's figures."""
        from . import plotting

        return plotting.plot_kind(self, ChannelKind(kind))

    def __repr__(self) -> str:
        t = self.time
        span = f"t = {t[0]:g} … {t[-1]:g} s, {t.size} samples" if t.size else "no samples"
        kinds = {}
        for c in self.channels.values():
            kinds[c.kind.value] = kinds.get(c.kind.value, 0) + 1
        what = ", ".join(f"{k}: {v}" for k, v in kinds.items()) or "no channels"
        model = self.metadata.get("model", "")
        return f"<Results {self.metadata.get('scenario', '')!r} {model} ({span}; {what})>"

    def _repr_html_(self) -> str:
        """A table of channels with their kind, unit, peak and description (notebooks)."""
        from html import escape

        rows = "".join(
            f"<tr><td>{escape(n)}</td><td>{c.kind.value}</td><td>{escape(c.unit)}</td>"
            f"<td>{np.abs(self._values[n]).max() if self.time.size else 0.0:.4g}</td>"
            f"<td>{escape(c.description)}</td></tr>"
            for n, c in self.channels.items())
        head = escape(repr(self))
        return (f"<p><b>{head}</b></p><table><thead><tr><th>channel</th><th>kind</th>"
                f"<th>unit</th><th>peak |value|</th><th>description</th></tr></thead>"
                f"<tbody>{rows}</tbody></table>")
