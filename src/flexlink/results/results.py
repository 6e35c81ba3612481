"""The result of one simulation: channels on a common time grid (SI units, radians)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..channels import Channel, ChannelKind, kind_summary
from ..channels.shapes import LinkShape

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr
    from matplotlib.figure import Figure


@dataclass
class Results:
    """Channels sampled at ``time`` (s), in the order they were added.

    ``results[name]`` is a channel's values, ``results.channels[name]`` its record (kind,
    unit, description); ``metadata`` says what ran (model, integrator, version, wall time);
    ``created`` when (ISO 8601, UTC: the ``history`` of results.nc); ``shapes`` every link's
    deformed shape on a grid of points (`flexlink.channels.shapes`, what `animate` draws;
    empty for results that do not have them).
    """

    time: np.ndarray
    metadata: dict[str, Any] = field(default_factory=dict)
    channels: dict[str, Channel] = field(default_factory=dict)
    _values: dict[str, np.ndarray] = field(default_factory=dict, repr=False)
    created: str = field(default_factory=lambda: datetime.now(UTC).isoformat(timespec="seconds"),
                         compare=False)
    shapes: Sequence[LinkShape] = field(default_factory=list, compare=False, repr=False)
    # ∂channel/∂field (xarray DataArray, time × channel × field) of a run asked for them,
    # or what makes it when first read (`label_sensitivities`)
    _sensitivities: Any = field(default=None, compare=False, repr=False)

    @property
    def sensitivities(self) -> Any:
        """∂channel/∂field of a run with ``sensitivities`` (xarray DataArray, time × channel
        × field; docs/sensitivities.md), None for other runs."""
        if callable(self._sensitivities):  # labelled on first use: xarray only then
            self._sensitivities = self._sensitivities()
        return self._sensitivities

    @sensitivities.setter
    def sensitivities(self, value: Any) -> None:
        self._sensitivities = value

    def label_sensitivities(self, make: Callable[[], Any]) -> None:
        """Give the results sensitivities that ``make()`` labels when first read."""
        self._sensitivities = make

    def sensitivity(self, channel: str, field_path: str) -> Any:
        """∂channel/∂field over time (an xarray DataArray with its unit in ``attrs``) of a
        run with ``sensitivities`` (`flexlink.simulate`); KeyError naming what is missing."""
        if self.sensitivities is None:
            raise KeyError("these results have no sensitivities: run simulate(scenario, "
                           "sensitivities=[...])")
        s = self.sensitivities
        for what, name in (("channel", channel), ("field", field_path)):
            if name not in s.coords[what].values:
                known = ", ".join(map(str, s.coords[what].values))
                raise KeyError(f"no sensitivity for {what} {name!r}; {what}s: {known}")
        out = s.sel(channel=channel, field=field_path)
        out.attrs = {**s.attrs, "units": str(out.coords["unit"].values)}
        return out

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self._values[name]
        except KeyError:
            import difflib

            close = difflib.get_close_matches(str(name), list(self._values), n=1, cutoff=0.6)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise KeyError(f"no channel {name!r}{hint}; channels: "
                           f"{', '.join(self._values)}") from None

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

    def to_pandas(self) -> pd.DataFrame:
        """A DataFrame indexed by ``t`` (s), one column per channel."""
        import pandas as pd

        frame = pd.DataFrame(dict(self._values), index=self.time)
        frame.index.name = "t"
        return frame

    def to_xarray(self) -> xr.Dataset:
        """A Dataset over ``time`` with units, long names and kinds in the attributes: what
        results.nc reads back as (the layout is `flexlink.results.layout`)."""
        from .layout import run_layout

        return run_layout(self).to_xarray()

    def plot(self, kind: ChannelKind | str = ChannelKind.SENSOR) -> Figure:
        """A figure of the channels of one kind against time, as in the run folder: joint
        angles (and torques) for ``"joint"``, X–Y paths for ``"tip"``, else one panel per
        channel. ValueError if the results have no channel of that kind."""
        from . import plotting

        try:
            kind = ChannelKind(kind)
        except ValueError:
            known = ", ".join(repr(k.value) for k in ChannelKind)
            raise ValueError(f"unknown channel kind {kind!r}; kinds: {known}") from None
        return plotting.plot_kind(self, kind)

    def animate(self, path: str | Path, **options: Any) -> Path:
        """Write an animation of the moving, deforming arm to ``path`` (.gif or .mp4); options
        of `flexlink.results.animation.animate` (channels, magnification, fps, speed, trail).
        Returns the path."""
        from .animation import animate

        return animate(self, path, **options).path

    def __repr__(self) -> str:
        t = self.time
        span = f"t = {t[0]:g} … {t[-1]:g} s, {t.size} samples" if t.size else "no samples"
        what = kind_summary(self.channels.values()) or "no channels"
        name = " ".join(str(self.metadata[k]) if k == "model" else repr(self.metadata[k])
                        for k in ("scenario", "model") if k in self.metadata)
        return f"<Results {name + ': ' if name else ''}{span}; {what}>"

    def _repr_html_(self) -> str:
        """The repr above a table of the channels: name, kind, unit, peak |value|,
        description (notebooks)."""
        from html import escape

        def row(name: str, channel: Channel) -> str:
            peak = f"{np.abs(self._values[name]).max():.4g}" if self.time.size else ""
            cells = (name, channel.kind.value, channel.unit, peak, channel.description)
            return "<tr>" + "".join(f"<td>{escape(c)}</td>" for c in cells) + "</tr>"

        head = "".join(f"<th>{h}</th>" for h in
                       ("channel", "kind", "unit", "peak |value|", "description"))
        rows = "".join(row(n, c) for n, c in self.channels.items())
        return (f"<p><b>{escape(repr(self))}</b></p><table><thead><tr>{head}</tr></thead>"
                f"<tbody>{rows}</tbody></table>")
