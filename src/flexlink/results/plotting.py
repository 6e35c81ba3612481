"""Figures of a run, in the style of the paper's Figs. 7–9.

Figures are built on `matplotlib.figure.Figure` directly (no pyplot, no global state), so
they render with the Agg backend whatever backend is active. Signals are stored in SI and
radians; the axes show degrees for angles and convenient multiples (mm, µstrain) elsewhere.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from ..channels import ChannelKind, ChannelTable, Unit

DPI = 150
# stored unit → (display factor, display unit)
_DISPLAY: dict[str, tuple[float, str]] = {
    Unit.RADIAN: (180.0 / math.pi, "deg"),
    Unit.METRE: (1e3, "mm"),
    Unit.ONE: (1e6, "µstrain"),
    Unit.METRE_PER_SECOND2: (1.0, "m/s²"),
    Unit.RADIAN_PER_SECOND: (180.0 / math.pi, "deg/s"),
    Unit.NEWTON_METRE: (1.0, "N·m"),
    Unit.METRE_PER_SECOND: (1.0, "m/s"),
    Unit.NEWTON_SECOND: (1.0, "N·s"),
    Unit.NEWTON_METRE_SECOND: (1.0, "N·m·s"),
}
_QUANTITY = {"piezo": "voltage"}  # axis label of a quantity, where it differs


def display_scale(unit: str) -> tuple[float, str]:
    """(factor, unit) to show a signal stored in ``unit``: values × factor in that unit."""
    return _DISPLAY.get(unit, (1.0, unit))


def joint_channels(results: ChannelTable, quantity: str = "angle") -> list[str]:
    """Joint channels of one quantity (``angle``, ``torque``, ``reference`` …), joint order."""
    return [n for n in results.names_of(ChannelKind.JOINT)
            if results.channels[n].quantity == quantity]


def tip_links(results: ChannelTable) -> list[str]:
    """Names of the links whose tip position (X and Y) was saved."""
    subjects = [results.channels[n].subject for n in results.names_of(ChannelKind.TIP)]
    return [s for s in dict.fromkeys(subjects) if subjects.count(s) == 2]


def _tip(results: ChannelTable, link: str, quantity: str) -> np.ndarray:
    for n in results.names_of(ChannelKind.TIP):
        c = results.channels[n]
        if c.subject == link and c.quantity == quantity:
            return results[n]
    raise KeyError(f"no tip {quantity} of {link!r}")


def sensor_channels(results: ChannelTable) -> list[str]:
    """The user's sensors."""
    return results.names_of(ChannelKind.SENSOR)


def plot_kind(results: ChannelTable, kind: ChannelKind) -> Figure:
    """The figure of one kind of channel: joints, tips (paths), or one panel per channel."""
    if not results.names_of(kind):
        raise ValueError(f"no channels of kind {kind.value!r} in the results")
    if kind is ChannelKind.JOINT:
        return plot_joint_angles(results)
    if kind is ChannelKind.TIP:
        return plot_tip_paths(results)
    return plot_channels(results, results.names_of(kind))


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


def plot_joint_angles(results: ChannelTable) -> Figure:
    """Joint angles β_k in degrees against time (s), like the paper's Fig. 7."""
    names = joint_channels(results)
    if not names:
        raise ValueError("no joint angle channels in the results")
    torques = joint_channels(results, "torque")
    references = {results.channels[n].subject: n for n in joint_channels(results, "reference")}
    fig = _figure(6.4, 3.6 if not torques else 5.6)
    axes = fig.subplots(2 if torques else 1, 1, sharex=True, squeeze=False)[:, 0]
    ax = axes[0]
    for name in names:
        subject = results.channels[name].subject
        k = subject.removeprefix("joint")
        (line,) = ax.plot(results.time, np.degrees(results[name]), label=rf"$\beta_{{{k}}}$")
        if subject in references:
            ax.plot(results.time, np.degrees(results[references[subject]]), "--",
                    color=line.get_color(), linewidth=0.8, label=rf"$\beta_{{{k}}}$ reference")
    ax.set_ylabel("joint angle [deg]")
    ax.legend(loc="lower right")  # "best" scans every vertex: ~0.1 s a legend
    for name in torques:
        k = results.channels[name].subject.removeprefix("joint")
        axes[1].plot(results.time, results[name], label=rf"$\tau_{{{k}}}$")
    if torques:
        axes[1].set_ylabel("motor torque [N·m]")
        axes[1].legend(loc="upper right")
    axes[-1].set_xlabel("time t [s]")
    axes[-1].set_xlim(results.time[0], results.time[-1])
    for a in axes:
        _style(a)
    return fig


def plot_sensors(results: ChannelTable, names: Sequence[str] | None = None) -> Figure:
    """One panel per sensor channel against time (s), like the paper's Figs. 8–9.

    ``names`` defaults to every channel of kind ``sensor``.
    """
    names = list(sensor_channels(results) if names is None else names)
    if not names:
        raise ValueError("no sensor channels to plot")
    return plot_channels(results, names)


def plot_channels(results: ChannelTable, names: Sequence[str]) -> Figure:
    """One panel per channel against time (s), in display units."""
    if not names:
        raise ValueError("no channels to plot")
    fig = _figure(6.4, 1.1 + 1.9 * len(names), top=0.35)
    axes = fig.subplots(len(names), 1, sharex=True, squeeze=False)[:, 0]
    for ax, name in zip(axes, names, strict=True):
        channel = results.channels[name]
        factor, unit = display_scale(channel.unit)
        ax.plot(results.time, results[name] * factor, linewidth=1.0)
        label = _QUANTITY.get(channel.quantity, channel.quantity) or name
        ax.set_ylabel(f"{label} [{unit or '-'}]")
        ax.set_title(f"{name}: {channel.description}", fontsize="medium", loc="left")
        _style(ax)
    axes[-1].set_xlabel("time t [s]")
    axes[-1].set_xlim(results.time[0], results.time[-1])
    return fig


def plot_tip_paths(results: ChannelTable) -> Figure:
    """The X–Y path (m) of each link's deformed tip in the plane, with equal axis scales."""
    links = tip_links(results)
    if not links:
        raise ValueError("no tip position channels in the results")
    fig = _figure(5.6, 5.2, top=0.4)
    ax = fig.add_subplot()
    ax.plot([0.0], [0.0], "k+", markersize=10, label="joint 1 (origin)")
    for link in links:
        x, y = _tip(results, link, "X"), _tip(results, link, "Y")
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
