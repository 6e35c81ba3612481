"""Figures of a run, in the style of the paper's Figs. 7–9.

Figures are built on `matplotlib.figure.Figure` directly (no pyplot, no global state), so
they render with the Agg backend whatever backend is active. Signals are stored in SI and
radians; the axes show degrees for angles and convenient multiples (mm, µstrain) elsewhere.
"""

from __future__ import annotations

import math
import weakref
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..channels import Channel, ChannelKind, ChannelTable, Unit

if TYPE_CHECKING:  # matplotlib loads when a figure is drawn: display_scale needs none of it
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

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
# Line styles cycled over curves that share an axis: equal curves (symmetric appendages)
# would otherwise hide one another.
_STYLES = ("-", "--", "-.", ":")
# Subscript digits: β₁ in a plain label renders like mathtext's $\beta_1$ without loading
# and running matplotlib's mathtext parser (a visible part of a command-line run).
_SUBSCRIPT = str.maketrans("0123456789", "₀₁₂₃₄₅₆₇₈₉")


def _sub(symbol: str, k: str) -> str:
    return symbol + k.translate(_SUBSCRIPT)


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
    if kind is ChannelKind.BASE:
        return plot_base(results)
    return plot_channels(results, results.names_of(kind))


def caption(results: ChannelTable) -> str:
    """What a figure shows: the scenario, the model and the integrator that ran."""
    meta = results.metadata
    model = str(meta.get("model", "")).replace("_", "-")
    if model == "first-order" and "geometric_stiffening" in meta:
        model += ", stiffened" if meta["geometric_stiffening"] else ", the paper's"
    parts = [f"scenario '{meta['scenario']}'" if "scenario" in meta else "",
             f"{model} model" if model else "",
             "forward dynamics" if meta.get("path") == "forward" else "",
             str(meta.get("method", ""))]
    return " · ".join(p for p in parts if p)


# A figure's frame: width and height (in), panels, top, bottom and gap margins (in), and
# whether the panels share the time axis (else one axes); `_frame` builds it.
FrameSpec = tuple[float, float, int, float, float, float, bool]
# Frames built ahead of the data (`prepare_frames`), by spec; a figure of that geometry takes
# one instead of building its own. Empty except in the figure worker's processes.
_PREPARED: dict[FrameSpec, list[tuple[Figure, list[Axes]]]] = {}
PREPARED_TICKS = 8  # ticks made ahead per axis: the figures of a run show 5-10


def _frame(spec: FrameSpec) -> tuple[Figure, list[Axes]]:
    """A figure with fixed margins in inches (room for the y labels, the time axis, a caption
    naming scenario and model at the top, and ``gap`` between panels for their titles) and
    its empty axes: a prepared one if there is one of this ``spec``.

    Fixed margins instead of matplotlib's constrained layout: the layout solver took half of a
    command-line run's plotting time, and these figures all share one simple structure."""
    prepared = _PREPARED.get(spec)
    if prepared:
        return prepared.pop()
    return _build_frame(spec)


def _build_frame(spec: FrameSpec) -> tuple[Figure, list[Axes]]:
    from matplotlib.figure import Figure

    width, height, panels, top, bottom, gap, shared = spec
    fig = Figure(figsize=(width, height), dpi=DPI)
    panel = (height - top - bottom - gap * (panels - 1)) / panels
    fig.subplots_adjust(left=0.85 / width, right=1 - 0.15 / width, bottom=bottom / height,
                        top=1 - top / height, hspace=gap / panel)
    if shared:
        return fig, list(fig.subplots(panels, 1, sharex=True, squeeze=False)[:, 0])
    return fig, [fig.add_subplot()]


def _figure(results: ChannelTable, spec: FrameSpec) -> tuple[Figure, list[Axes]]:
    """`_frame` with the caption (`caption`) at its top left."""
    fig, axes = _frame(spec)
    text = caption(results)
    if text:
        width, height = spec[:2]
        fig.text(0.1 / width, 1 - 0.08 / height, text, fontsize="small", color="0.3",
                 va="top", ha="left")
    return fig, axes


def _channels_spec(panels: int) -> FrameSpec:
    return (6.4, 1.3 + 2.2 * panels, panels, 0.7, 0.5, 0.45, True)


def _joint_spec(panels: int) -> FrameSpec:
    return (6.4, 1.1 + 1.9 * panels, panels, 0.45, 0.5, 0.25, True)


def joint_fixed_panels(results: ChannelTable) -> int:
    """The joint figure's panels besides the torques': the revolute joints' angles, the
    sliders' travels and the sliders' forces, each if there are any."""
    return sum(bool(joint_channels(results, q)) for q in ("angle", "position", "force"))


_TIP_SPEC: FrameSpec = (5.6, 5.8, 1, 0.6, 1.1, 0.45, False)


def frame_specs(results: ChannelTable, stem: str) -> list[FrameSpec]:
    """The frames figure ``stem`` may take, from ``results``' channel records alone (their
    values may not exist yet): the joint figure's torques share one panel or have one each,
    as their sizes turn out (its other panels: `joint_fixed_panels`)."""
    if stem == "sensors":
        return [_channels_spec(len(sensor_channels(results)))]
    if stem == "base":
        return [_channels_spec(len(base_pose_channels(results)))]
    if stem == "tip_paths":
        return [_TIP_SPEC]
    torques = len(joint_channels(results, "torque"))
    fixed = joint_fixed_panels(results)
    return [_joint_spec(fixed + torques)] + ([_joint_spec(fixed + 1)] if torques > 1 else [])


def prepare_frames(specs: Sequence[FrameSpec], stop: Callable[[], bool] | None = None) -> None:
    """Build the frames of ``specs`` ahead of the data, with `PREPARED_TICKS` ticks on each
    axis (making tick objects is a fifth of drawing a figure); the next figures of those
    geometries take them: the same pixels (a test). ``stop()``, asked before each frame,
    ends the preparation early (the data came)."""
    for spec in specs:
        if stop is not None and stop():
            return
        fig, axes = _build_frame(spec)
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig).get_renderer()  # its pixel buffer, cleared when drawn
        for ax in axes:
            ax.xaxis.get_major_ticks(PREPARED_TICKS)
            ax.yaxis.get_major_ticks(PREPARED_TICKS)
            _style(ax)  # styling the ticks made is as costly as making them
            _STYLED.add(ax)
        _PREPARED.setdefault(spec, []).append((fig, axes))


def _title(ax: Axes, text: str, loc: str = "left") -> None:
    """``ax.set_title`` at matplotlib's usual place, without its automatic placement where
    that cannot move the title.

    matplotlib moves a title up only past tick labels on top of the axes (these figures have
    none) or past the y axis' offset text ("1e-14", drawn above the axes): the check lays out
    the axes' ticks an extra time, ~20% of drawing a figure. Where the y axis shows no offset
    text (found from the tick locations, as drawing would) the title is pinned at y = 1, where
    the check would leave it: the same pixels. Call after plotting (the data set the ticks)."""
    formatter = ax.yaxis.get_major_formatter()
    offset = ""
    if hasattr(formatter, "get_offset"):
        formatter.set_locs(ax.yaxis.get_majorticklocs())
        offset = formatter.get_offset()
    ax.set_title(text, fontsize="medium", loc=loc, y=None if offset else 1.0)


# Axes of prepared frames, styled ahead (`prepare_frames`): `_style` leaves them as they are.
_STYLED: weakref.WeakSet[Axes] = weakref.WeakSet()


def _style(ax: Axes) -> None:
    if ax in _STYLED:
        return
    ax.grid(True, linewidth=0.5, alpha=0.6)
    ax.tick_params(direction="in", top=True, right=True)


def plot_joint_angles(results: ChannelTable) -> Figure:
    """Joint angles β_k in degrees against time (s), like the paper's Fig. 7, servo references
    dashed; the sliders' travels s_k (m, references dashed) on a panel of their own; below,
    the joint torques, each joint on its own panel when their sizes differ (a small torque
    would hide under a large one on a shared axis), and the sliders' forces F_k (N)."""
    names = joint_channels(results)
    travels = joint_channels(results, "position")
    if not names and not travels:
        raise ValueError("no joint angle or slider travel channels in the results")
    torques = joint_channels(results, "torque")
    forces = joint_channels(results, "force")
    groups = torque_panels(results, torques)
    # (an elastic joint's servo reference is its motor's, motor-shaft angles: not β's)
    motors = {results.channels[n].subject for n in joint_channels(results, "motor_angle")}
    references = {results.channels[n].subject: n for n in joint_channels(results, "reference")
                  if results.channels[n].subject not in motors}
    fig, axes = _figure(results, _joint_spec(joint_fixed_panels(results) + len(groups)))
    panels = iter(axes)
    colours = {}  # a joint's torque or force in its angle's or travel's colour
    count = 0  # the sliders' colours follow the revolute joints'
    for chosen, symbol, scale, label in ((names, "β", 180.0 / math.pi, "joint angle [deg]"),
                                         (travels, "s", 1.0, "slider travel [m]")):
        if not chosen:
            continue
        ax = next(panels)
        for i, name in enumerate(chosen):
            subject = results.channels[name].subject
            k = subject.removeprefix("joint")
            (line,) = ax.plot(results.time, scale * results[name], label=_sub(symbol, k),
                              linestyle=_STYLES[i % len(_STYLES)], color=f"C{count % 10}")
            count += 1
            colours[subject] = line.get_color()
            if subject in references:
                ax.plot(results.time, scale * results[references[subject]], "--",
                        color=line.get_color(), linewidth=0.8,
                        label=f"{_sub(symbol, k)} reference")
        ax.set_ylabel(label)
        ax.legend(loc="lower right")  # "best" scans every vertex of every line
    for group, symbol, label in ([(g, "τ", "joint torque [N·m]") for g in groups]
                                 + ([(forces, "F", "slider force [N]")] if forces else [])):
        panel = next(panels)
        for i, name in enumerate(group):
            subject = results.channels[name].subject
            panel.plot(results.time, results[name], label=_sub(symbol, subject.removeprefix(
                "joint")), color=colours.get(subject), linestyle=_STYLES[i % len(_STYLES)])
        panel.set_ylabel(label)
        panel.legend(loc="upper right")
    axes[-1].set_xlabel("time t [s]")
    axes[-1].set_xlim(results.time[0], results.time[-1])
    for a in axes:
        _style(a)
    return fig


def torque_panels(results: ChannelTable, torques: list[str]) -> list[list[str]]:
    """Torques sharing a panel: all of them when their peaks are within a factor of 5, else
    one panel each."""
    peaks = [float(np.abs(results[n]).max()) for n in torques]
    if not torques or max(peaks) <= 5.0 * max(min(peaks), 1e-300):
        return [torques] if torques else []
    return [[n] for n in torques]


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
    fig, axes = _figure(results, _channels_spec(len(names)))
    for ax, name in zip(axes, names, strict=True):
        channel = results.channels[name]
        factor, unit = display_scale(channel.unit)
        ax.plot(results.time, results[name] * factor, linewidth=1.0)
        label = _QUANTITY.get(channel.quantity, channel.quantity) or name
        ax.set_ylabel(f"{label} [{unit or '-'}]")
        ax.yaxis.set_offset_position("right")  # a "1e-14" multiplier clear of the title
        _title(ax, panel_title(channel))
        _style(ax)
    axes[-1].set_xlabel("time t [s]")
    axes[-1].set_xlim(results.time[0], results.time[-1])
    return fig


def panel_title(channel: Channel) -> str:
    """``name — description (on link)``: which link a sensor sits on, where it is not in the
    description already."""
    where = channel.subject
    on = f" (on {where})" if where and channel.kind is ChannelKind.SENSOR else ""
    return f"{channel.name} — {channel.description}{on}"


def plot_base(results: ChannelTable) -> Figure:
    """The moving base's pose against time: attitude in degrees, position in mm."""
    names = base_pose_channels(results)
    if not names:
        raise ValueError("no base pose channels in the results")
    return plot_channels(results, names)


def base_pose_channels(results: ChannelTable) -> list[str]:
    """The moving base's pose channels (its rates left out)."""
    return [n for n in results.names_of(ChannelKind.BASE)
            if not results.channels[n].quantity.endswith("_rate")]


def plot_tip_paths(results: ChannelTable) -> Figure:
    """The X–Y path (m) of each link's deformed tip in the plane, with equal axis scales."""
    links = tip_links(results)
    if not links:
        raise ValueError("no tip position channels in the results")
    fig, (ax,) = _figure(results, _TIP_SPEC)
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
    # below the axes: inside, a legend can cover a path
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=3, fontsize="small",
              frameon=False)
    _style(ax)
    return fig
