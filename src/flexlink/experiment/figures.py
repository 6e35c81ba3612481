"""The figures of ``flexlink compare`` and ``flexlink fit``: measured and simulated signals,
and their free-vibration spectra. They draw from `FigureData`, plain arrays taken from a
`Comparison`, so that a process that imports only matplotlib and this module can draw them
(`figure_worker`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..results.plotting import DPI, display_scale

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from .comparison import Comparison

SPECTRUM_DECADES = 1e-4  # the spectra's axis spans this ratio below the highest peak
FIGURES = ("overlay", "spectra")  # file stems under figures/


@dataclass(frozen=True)
class FigureData:
    """What the figures show of a comparison: the compared channels' names and storage units,
    the time grid (s), measured and simulated values on it (SI), the start of the free
    vibration (s, None: none found) and the estimated dominant frequencies (Hz, measured and
    simulated, None where none was found)."""

    names: list[str]
    units: dict[str, str]
    time: np.ndarray
    measured: dict[str, np.ndarray]
    simulated: dict[str, np.ndarray]
    free_start: float | None
    frequencies: dict[str, tuple[float | None, float | None]]

    @classmethod
    def of(cls, comparison: Comparison) -> FigureData:
        names = [m.name for m in comparison.metrics]
        results = comparison.results
        return cls(names=names, units={n: results.channels[n].unit for n in names},
                   time=np.asarray(results.time),
                   measured={n: np.asarray(comparison.measured[n]) for n in names},
                   simulated={n: np.asarray(results[n]) for n in names},
                   free_start=comparison.free_start,
                   frequencies={m.name: (m.frequency_measured, m.frequency_simulated)
                                for m in comparison.metrics})

    def stems(self) -> list[str]:
        """The figures there are: the spectra only with a free vibration."""
        return [s for s in FIGURES if s != "spectra" or self.free_start is not None]

    def write(self, folder: Path, stems: list[str] | None = None) -> None:
        """`write_figures` of these data (the figure worker's entry)."""
        write_figures(self, folder, stems)


def write_figures(data: FigureData, folder: Path, stems: list[str] | None = None) -> None:
    """Draw the figures ``stems`` (default: all there are) into ``folder`` as PNG."""
    drawers = {"overlay": overlay_figure, "spectra": spectra_figure}
    for stem in data.stems() if stems is None else stems:
        drawers[stem](data).savefig(folder / f"{stem}.png", dpi=DPI)


def overlay_figure(data: FigureData) -> Figure:
    """Measured and simulated signals, one panel per channel (like the paper's Figs. 8–9)."""
    names, t = data.names, data.time
    fig, axes = _frame(len(names), 2.0)
    for ax, name in zip(axes, names, strict=True):
        factor, unit = display_scale(data.units[name])
        ax.plot(t, data.measured[name] * factor, color="0.55", linewidth=0.8,
                label="measured")
        ax.plot(t, data.simulated[name] * factor, color="C3", linewidth=1.0,
                label="simulated")
        if data.free_start is not None:
            ax.axvline(data.free_start, color="k", linestyle=":", linewidth=0.8)
        ax.set_ylabel(f"{name} [{unit}]")
        ax.grid(True, linewidth=0.5, alpha=0.6)
    _legend(axes[0])
    axes[-1].set_xlabel("time t [s]  (dotted: start of free vibration)")
    axes[-1].set_xlim(t[0], t[-1])
    return fig


def spectra_figure(data: FigureData) -> Figure:
    """Amplitude spectra of the free vibration, measured and simulated."""
    names, t = data.names, data.time
    window = t >= (data.free_start or t[0])
    dt = float(t[1] - t[0])
    fig, axes = _frame(len(names), 1.8)
    n = 1 << 16
    freqs = np.fft.rfftfreq(n, dt)
    top = max([4 * f for name in names for f in data.frequencies[name] if f] or [1.0])
    shown = freqs <= min(top, freqs[-1])
    # the lines end one frequency past the axis: beyond it they would only be clipped away,
    # at most of the drawing's cost
    drawn = min(int(np.count_nonzero(shown)) + 1, freqs.size)
    for ax, name in zip(axes, names, strict=True):
        factor, unit = display_scale(data.units[name])
        highest = 0.0
        for values, label, style in ((data.measured[name], "measured", "0.55"),
                                     (data.simulated[name], "simulated", "C3")):
            y = values[window] - np.mean(values[window])
            taper = np.hanning(y.size)
            # a sinusoid's amplitude in the signal's unit at its peak (Hann window)
            amplitude = (2.0 * factor / max(taper.sum(), 1e-300)
                         * np.abs(np.fft.rfft(y * taper, n)) + 1e-300)
            highest = max(highest, float(amplitude[shown].max()))
            ax.semilogy(freqs[:drawn], amplitude[:drawn], color=style, linewidth=0.9,
                        label=label)
        for f in data.frequencies[name]:
            if f:
                ax.axvline(f, color="k", linestyle=":", linewidth=0.7)
        if highest > 0:  # four decades below the highest peak: the noise floor, not 1e-10
            ax.set_ylim(highest * SPECTRUM_DECADES, highest * 2.0)
        ax.yaxis.set_major_formatter(power_of_ten())
        ax.set_ylabel(f"{name}\namplitude [{unit}]")
        ax.grid(True, linewidth=0.5, alpha=0.6)
    _legend(axes[0], "amplitude spectra of the free vibration")
    axes[-1].set_xlim(0, min(top, freqs[-1]))
    axes[-1].set_xlabel("frequency [Hz]  (dotted: estimated dominant frequencies)")
    return fig


# Margins of the figures, in inches: room for the y axis' labels at the left, the time or
# frequency axis at the bottom; fixed, as `flexlink run`'s figures (results/plotting.py):
# matplotlib's constrained layout took two thirds of drawing them.
_LEFT, _RIGHT, _TOP, _BOTTOM, _GAP = 1.1, 0.25, 0.4, 0.55, 0.12
_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def _legend(ax: Any, title: str = "") -> None:
    """The legend of every panel above the top one (``title`` at its left): inside a panel it
    hid the data it happened to cover."""
    ax.legend(loc="lower right", bbox_to_anchor=(1.0, 1.0), ncols=2, fontsize="small",
              frameon=False, borderaxespad=0.1)
    if title:
        ax.set_title(title, loc="left", fontsize="medium")


def _frame(panels: int, panel_height: float) -> tuple[Figure, list[Any]]:
    """A figure of ``panels`` panels of ``panel_height`` inches, 7 in wide, sharing the
    horizontal axis."""
    from matplotlib.figure import Figure

    width, height = 7.0, _TOP + _BOTTOM + panels * panel_height
    fig = Figure(figsize=(width, height), dpi=DPI)
    fig.subplots_adjust(left=_LEFT / width, right=1 - _RIGHT / width, bottom=_BOTTOM / height,
                        top=1 - _TOP / height, hspace=_GAP / (panel_height - _GAP))
    return fig, list(fig.subplots(panels, 1, sharex=True, squeeze=False)[:, 0])


def power_of_ten() -> Any:
    """Log-axis labels 10⁻³ in plain text (matplotlib writes them in mathtext, whose parser
    costs as much as drawing the rest of the figure); minor ticks unlabelled, as there."""
    from matplotlib.ticker import FuncFormatter

    def label(value: float, _: int) -> str:
        exponent = round(math.log10(value)) if value > 0 else None
        if exponent is None or not math.isclose(value, 10.0 ** exponent, rel_tol=1e-9):
            return ""
        return "10" + str(exponent).translate(_SUPERSCRIPT)

    return FuncFormatter(label)
