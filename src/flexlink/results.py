"""The result of one simulation: labelled signals on a common time grid (SI units)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    import pandas as pd
    import xarray as xr


@dataclass
class Signal:
    """One output channel: its values on the result's time grid and how to read them."""

    values: np.ndarray
    unit: str
    description: str


@dataclass
class Results:
    """Signals sampled at ``time`` (s). Channel order is the order of insertion."""

    time: np.ndarray
    signals: dict[str, Signal] = field(default_factory=dict)
    metadata: dict[str, Any] = field(default_factory=dict)

    def __getitem__(self, name: str) -> np.ndarray:
        return self.signals[name].values

    @property
    def names(self) -> list[str]:
        return list(self.signals)

    def add(self, name: str, values: np.ndarray, unit: str, description: str) -> None:
        values = np.asarray(values, dtype=float)
        if values.shape != self.time.shape:
            raise ValueError(f"signal {name!r} has shape {values.shape}, time has {self.time.shape}")
        if not np.all(np.isfinite(values)):
            raise FloatingPointError(f"signal {name!r} contains non-finite values")
        self.signals[name] = Signal(values, unit, description)

    def to_pandas(self) -> pd.DataFrame:
        """A DataFrame indexed by ``t`` (s), one column per signal."""
        import pandas as pd

        frame = pd.DataFrame({n: s.values for n, s in self.signals.items()}, index=self.time)
        frame.index.name = "t"
        return frame

    def to_xarray(self) -> xr.Dataset:
        """A Dataset over ``time`` with units and long names in each variable's attrs."""
        import xarray as xr

        data_vars = {
            n: ("time", s.values, {"units": s.unit, "long_name": s.description})
            for n, s in self.signals.items()
        }
        attrs = {k: str(v) for k, v in self.metadata.items()}
        return xr.Dataset(
            data_vars, coords={"time": ("time", self.time, {"units": "s"})}, attrs=attrs
        )
