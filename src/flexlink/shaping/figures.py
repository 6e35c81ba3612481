"""The two figures of residual vibration (matplotlib, SI units, degrees only on angle axes).

* `residual_figure` — the last link's tip deflection (mm) of the unshaped, shaped and
  optimised manoeuvres side by side, the move shaded, each panel giving its residual peak;
* `robustness_figure` — residual peak after the move against the plant's frequency error
  (%), relative to the unshaped move's on the same plant: the curve shapers are judged by.

`OptimizeFigures` holds both figures' data of ``flexlink optimize`` as plain arrays, so that
a process that imports only matplotlib and this module draws them
(`flexlink.experiment.figure_worker`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..experiment.figures import power_of_ten

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..results import Results

# a manoeuvre's trace: time (s), tip deflection of the last link (m), residual peak (m)
Trace = tuple[np.ndarray, np.ndarray, float]

COLOURS = ("#444444", "#1f77b4", "#d62728", "#2ca02c", "#9467bd")


def residual_figure(runs: Mapping[str, tuple[Results, float]], move_start: float,
                    move_end: float, title: str = "") -> Figure:
    """One panel per manoeuvre: tip deflection (mm) against time (s); ``runs`` maps a label
    to (results with `compare.TIP_SENSOR`, residual peak in m)."""
    return trace_figure(tip_traces(runs), move_start, move_end, title)


def tip_traces(runs: Mapping[str, tuple[Results, float]]) -> dict[str, Trace]:
    """Each run's `Trace` (its `compare.TIP_SENSOR` channel)."""
    from .compare import TIP_SENSOR

    return {label: (np.asarray(results.time), np.asarray(results[TIP_SENSOR]), float(peak))
            for label, (results, peak) in runs.items()}


def trace_figure(traces: Mapping[str, Trace], move_start: float, move_end: float,
                 title: str = "") -> Figure:
    """`residual_figure` of the manoeuvres' `Trace`s."""
    from matplotlib.figure import Figure

    panels = len(traces)
    # the left margin holds the tick labels (−150) and the axis label: 0.65 in cut it off
    fig = _framed(Figure(figsize=(3.2 * panels, 3.0)), (0.85, 0.1, 0.9 if title else 0.72, 0.5),
                  wspace=0.12 * panels / (3.2 * panels - 0.95 - 0.12 * (panels - 1)))
    axes = fig.subplots(1, panels, sharey=True, squeeze=False)[0]
    for ax, (label, (time, tip, peak)), colour in zip(axes, traces.items(), COLOURS,
                                                       strict=False):
        ax.axvspan(move_start, move_end, color="0.92", lw=0)
        ax.plot(time, 1e3 * tip, color=colour, lw=0.9)
        ax.axhline(1e3 * peak, color=colour, ls=":", lw=0.8)
        ax.axhline(-1e3 * peak, color=colour, ls=":", lw=0.8)
        ax.set_title(f"{label}\nresidual peak {1e3 * peak:.3g} mm", fontsize=9)
        ax.set_xlabel("time (s)")
        ax.grid(True, lw=0.3)
    axes[0].set_ylabel("tip deflection of the last link (mm)")
    fig.suptitle(f"{title}{chr(10) if title else ''}grey: the move; dotted: ± the residual peak",
                 fontsize=10)
    return fig


def robustness_figure(errors: Sequence[float], residual: Mapping[str, np.ndarray],
                      reference: str, textbook: Mapping[str, np.ndarray] | None = None,
                      title: str = "") -> Figure:
    """Residual peak relative to ``reference``'s on the same plant (%) against frequency
    error (%); ``textbook``: curves to overlay dashed (e.g. V of a shaper at mode 1)."""
    from matplotlib.figure import Figure

    fig = _framed(Figure(figsize=(5.5, 3.6)), (0.7, 0.12, 0.3 if title else 0.12, 0.5))
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
    ax.yaxis.set_major_formatter(power_of_ten())
    ax.grid(True, which="both", lw=0.3)
    ax.legend(fontsize=8)
    if title:
        ax.set_title(title, fontsize=10)
    return fig


def _framed(fig: Figure, margins: tuple[float, float, float, float], wspace: float = 0.2
            ) -> Figure:
    """``fig`` with fixed margins (left, right, top, bottom; inches) around its axes: room
    for the labels and titles, as `flexlink run`'s and `flexlink fit`'s figures
    (matplotlib's constrained layout took half of drawing them)."""
    width, height = fig.get_size_inches()
    left, right, top, bottom = margins
    fig.subplots_adjust(left=left / width, right=1 - right / width, top=1 - top / height,
                        bottom=bottom / height, wspace=wspace)
    return fig


def save(fig: Figure, path: Path) -> Path:
    """Write ``fig`` as PNG (150 dpi)."""
    fig.savefig(path, dpi=150)
    return path


@dataclass(frozen=True)
class OptimizeFigures:
    """The figures of ``flexlink optimize``: ``residual`` (`trace_figure` of ``traces``, the
    move from ``move_start`` to ``move_end`` s, titled ``residual_title``) and ``robustness``
    (`robustness_figure` of ``curves``, residual peaks in m against the frequency errors
    ``errors``, relative to ``reference``'s, titled ``robustness_title``)."""

    traces: dict[str, Trace]
    move_start: float
    move_end: float
    residual_title: str
    errors: list[float]
    curves: dict[str, np.ndarray]
    reference: str
    robustness_title: str

    def stems(self) -> list[str]:
        """The figures' file stems."""
        return ["residual", "robustness"]

    def write(self, folder: Path, stems: list[str] | None = None) -> None:
        """Draw the figures ``stems`` (default: both) into ``folder`` as PNG."""
        for stem in self.stems() if stems is None else stems:
            if stem == "residual":
                fig = trace_figure(self.traces, self.move_start, self.move_end,
                                   self.residual_title)
            else:
                fig = robustness_figure(self.errors, self.curves, self.reference,
                                        title=self.robustness_title)
            save(fig, folder / f"{stem}.png")


__all__ = ["OptimizeFigures", "residual_figure", "robustness_figure", "save", "tip_traces",
           "trace_figure"]
