"""Figures of a run, in the style of the paper's Figs. 7–9.

Figures are built on `matplotlib.figure.Figure` directly (no pyplot, no global state), so
they render with the Agg backend whatever backend is active. Signals are stored in SI and
radians; the axes show degrees for angles and convenient multiples (mm, µstrain) elsewhere.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from .results import Results

DPI = 150
_JOINT = re.compile(r"joint(\d+)_angle")
# stored unit → (display factor, display unit)
_DISPLAY: dict[str, tuple[float, str]] = {
    "rad": (180.0 / math.pi, "deg"),
    "m": (1e3, "mm"),
    "1": (1e6, "µstrain"),
    "-": (1e6, "µstrain"),
    "m/s^2": (1.0, "m/s²"),
}

_QUANTITY = {"mm": "deflection", "deg": "slope", "µstrain": "strain", "m/s²": "acceleration",
             "V": "voltage"}  # axis label for a display unit


def display_scale(unit: str) -> tuple[float, str]:
    """(factor, unit) to show a signal stored in ``unit``: values × factor in that unit."""
    return _DISPLAY.get(unit, (1.0, unit))


def joint_channels(results: Results) -> list[str]:
    """``joint{k}_angle`` channels, ordered by k."""
    found = [(int(m.group(1)), n) for n in results.names if (m := _JOINT.fullmatch(n))]
    return [name for _, name in sorted(found)]


def tip_links(results: Results) -> list[str]:
    """Names of the links whose tip position (``{link}_tip_X``, ``{link}_tip_Y``) was saved."""
    names = set(results.names)
    return [n[: -len("_tip_X")] for n in results.names
            if n.endswith("_tip_X") and n[: -len("_tip_X")] + "_tip_Y" in names]


def sensor_channels(results: Results) -> list[str]:
    """Channels that are neither joint angles nor tip positions: the user's sensors."""
    automatic = set(joint_channels(results))
    automatic |= {n.replace("_angle", "_torque") for n in automatic}
    automatic |= {f"{link}_tip_{axis}" for link in tip_links(results) for axis in "XY"}
    return [n for n in results.names if n not in automatic]


def _figure(width: float, height: float, top: float = 0.15) -> Figure:
    """A figure with fixed margins in inches (room for the y labels and the time axis).

    Fixed margins instead of matplotlib's constrained layout: the layout solver took half of a
    command-line run's plotting time, and these figures all share one simple structure."""
    fig = Figure(figsize=(width, height), dpi=DPI)
    fig.subplots_adjust(left=0.85 / width, right=1 - 0.12 / width, bottom=0.5 / height,
                        top=1 - top / height, hspace=0.35 / max(height / 3.0, 1.0))
    return fig


def _style(ax: Axes) -> None:
    ax.grid(True, linewidth=0.5, alpha=0.6)
    ax.tick_params(direction="in", top=True, right=True)


def plot_joint_angles(results: Results) -> Figure:
    """Joint angles β_k in degrees against time (s), like the paper's Fig. 7."""
    names = joint_channels(results)
    if not names:
        raise ValueError("no joint angle channels (joint<k>_angle) in the results")
    torques = [n.replace("_angle", "_torque") for n in names
               if n.replace("_angle", "_torque") in results.signals]
    fig = _figure(6.4, 3.6 if not torques else 5.6)
    axes = fig.subplots(2 if torques else 1, 1, sharex=True, squeeze=False)[:, 0]
    ax = axes[0]
    for name in names:
        k = _JOINT.fullmatch(name).group(1)  # type: ignore[union-attr]
        ax.plot(results.time, np.degrees(results[name]), label=rf"$\beta_{{{k}}}$")
    ax.set_ylabel("joint angle [deg]")
    ax.legend(loc="lower right")  # "best" scans every vertex: ~0.1 s a legend
    for name in torques:
        k = name[len("joint"):-len("_torque")]
        axes[1].plot(results.time, results[name], label=rf"$\tau_{{{k}}}$")
    if torques:
        axes[1].set_ylabel("motor torque [N·m]")
        axes[1].legend(loc="upper right")
    axes[-1].set_xlabel("time t [s]")
    axes[-1].set_xlim(results.time[0], results.time[-1])
    for a in axes:
        _style(a)
    return fig


def plot_sensors(results: Results, names: Sequence[str] | None = None) -> Figure:
    """One panel per sensor channel against time (s), like the paper's Figs. 8–9.

    ``names`` defaults to every channel that is not a joint angle or a tip position.
    """
    names = list(sensor_channels(results) if names is None else names)
    if not names:
        raise ValueError("no sensor channels to plot")
    fig = _figure(6.4, 1.1 + 1.9 * len(names), top=0.35)
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name in zip(axes, names, strict=True):
        signal = results.signals[name]
        factor, unit = display_scale(signal.unit)
        ax.plot(results.time, signal.values * factor, linewidth=1.0)
        ax.set_ylabel(f"{_QUANTITY.get(unit, name)} [{unit or '-'}]")
        ax.set_title(f"{name}: {signal.description}", fontsize="medium", loc="left")
        _style(ax)
    axes[-1].set_xlabel("time t [s]")
    axes[-1].set_xlim(results.time[0], results.time[-1])
    return fig


def plot_tip_paths(results: Results) -> Figure:
    """The X–Y path (m) of each link's deformed tip in the plane, with equal axis scales."""
    links = tip_links(results)
    if not links:
        raise ValueError("no tip position channels (<link>_tip_X, <link>_tip_Y) in the results")
    fig = _figure(5.6, 5.2, top=0.4)
    ax = fig.add_subplot()
    ax.plot([0.0], [0.0], "k+", markersize=10, label="joint 1 (origin)")
    for link in links:
        x, y = results[f"{link}_tip_X"], results[f"{link}_tip_Y"]
        (line,) = ax.plot(x, y, linewidth=1.0, label=f"tip of {link}")
        ax.plot(x[0], y[0], "o", color=line.get_color(), markersize=4)
        ax.plot(x[-1], y[-1], "s", color=line.get_color(), markersize=4)
    ax.set_xlabel("X [m]")
    ax.set_ylabel("Y [m]")
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_title("tip paths (○ start, □ end)", fontsize="medium")
    ax.legend(loc="upper right", fontsize="small")
    _style(ax)
    return fig
