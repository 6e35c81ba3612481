"""The two figures of residual vibration (matplotlib, SI units, degrees only on angle axes).

* `residual_figure` — the last link's tip deflection (mm) of the unshaped, shaped and
  optimised manoeuvres side by side, the move shaded, each panel giving its residual peak;
* `robustness_figure` — residual peak after the move against the plant's frequency error
  (%), relative to the unshaped move's on the same plant: the curve shapers are judged by.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..results import Results
from .compare import TIP_SENSOR

if TYPE_CHECKING:
    from matplotlib.figure import Figure

COLOURS = ("#444444", "#1f77b4", "#d62728", "#2ca02c", "#9467bd")


def residual_figure(runs: Mapping[str, tuple[Results, float]], move_start: float,
                    move_end: float, title: str = "") -> Figure:
    """One panel per manoeuvre: tip deflection (mm) against time (s); ``runs`` maps a label
    to (results with TIP_SENSOR, residual peak in m)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.2 * len(runs), 3.0), layout="constrained")
    axes = fig.subplots(1, len(runs), sharey=True, squeeze=False)[0]
    for ax, (label, (results, peak)), colour in zip(axes, runs.items(), COLOURS, strict=False):
        ax.axvspan(move_start, move_end, color="0.92", lw=0)
        ax.plot(results.time, 1e3 * results[TIP_SENSOR], color=colour, lw=0.9)
        ax.axhline(1e3 * peak, color=colour, ls=":", lw=0.8)
        ax.axhline(-1e3 * peak, color=colour, ls=":", lw=0.8)
        ax.set_title(f"{label}\nresidual peak {1e3 * peak:.3g} mm", fontsize=9)
        ax.set_xlabel("time (s)")
        ax.grid(True, lw=0.3)
    axes[0].set_ylabel("tip deflection of the last link (mm)")
    if title:
        fig.suptitle(title, fontsize=10)
    return fig


def robustness_figure(errors: Sequence[float], residual: Mapping[str, np.ndarray],
                      reference: str, textbook: Mapping[str, np.ndarray] | None = None,
                      title: str = "") -> Figure:
    """Residual peak relative to ``reference``'s on the same plant (%) against frequency
    error (%); ``textbook``: curves to overlay dashed (e.g. V of a shaper at mode 1)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.5, 3.6), layout="constrained")
    ax = fig.subplots()
    e = 100.0 * np.asarray(errors)
    base = residual[reference]
    for (label, values), colour in zip(residual.items(), COLOURS, strict=False):
        ax.plot(e, 100.0 * values / base, "o-", ms=3, color=colour, label=label)
    for (label, values), colour in zip((textbook or {}).items(), COLOURS[1:], strict=False):
        ax.plot(e, 100.0 * values, "--", color=colour, lw=0.9, label=label)
    ax.set_xlabel("frequency error of the plant (%)")
    ax.set_ylabel(f"residual vibration (% of {reference})")
    ax.set_yscale("log")
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    return fig


def save(fig: Figure, path: Path) -> Path:
    """Write ``fig`` as PNG (150 dpi)."""
    fig.savefig(path, dpi=150)
    return path


__all__ = ["residual_figure", "robustness_figure", "save"]
