"""The run folder's figures: which are drawn, how to share them between two processes, and the
warm-up of a process that draws them (`figure_worker`)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ..channels import Channel, ChannelKind, ChannelTable

if TYPE_CHECKING:
    from matplotlib.figure import Figure


def figure_stems(results: ChannelTable) -> list[str]:
    """The figures ``results`` have channels for, in order: joint_angles (joint angles or
    sliders' travels), sensors (channels of kind ``sensor`` only), tip_paths, base (a
    moving base's pose)."""
    from . import plotting

    stems = []
    if plotting.joint_channels(results) or plotting.joint_channels(results, "position"):
        stems.append("joint_angles")
    if results.names_of(ChannelKind.SENSOR):
        stems.append("sensors")
    if plotting.tip_links(results):
        stems.append("tip_paths")
    if results.names_of(ChannelKind.BASE):
        stems.append("base")
    return stems


def draw_figure(results: ChannelTable, stem: str) -> Figure:
    """The figure ``stem`` (one of `figure_stems`) of ``results``."""
    from . import plotting

    draw = {"joint_angles": plotting.plot_joint_angles, "sensors": plotting.plot_sensors,
            "tip_paths": plotting.plot_tip_paths, "base": plotting.plot_base}[stem]
    return draw(results)


def write_figures(results: ChannelTable, folder: Path,
                  stems: Sequence[str] | None = None) -> list[Path]:
    """joint_angles.png, sensors.png, tip_paths.png and base.png, each if the results have
    such channels (`figure_stems`; ``stems``: only these); return their paths."""
    folder.mkdir(exist_ok=True)
    paths = []
    for stem in figure_stems(results) if stems is None else stems:
        paths.append(folder / f"{stem}.png")
        save_png(draw_figure(results, stem), paths[-1])
    return paths


def save_png(fig: Figure, path: Path) -> None:
    """Render ``fig`` at its own dpi and write it as a PNG: the pixels of
    ``fig.savefig(path)``, stored as RGB where the figure is opaque (it always is here).

    savefig writes RGBA at zlib level 6; the opaque pixels as RGB at level 1 give files of
    the same size in half the encoding time."""
    import matplotlib
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image, PngImagePlugin

    canvas = fig.canvas  # an Agg canvas already where the frame was prepared
    if not isinstance(canvas, FigureCanvasAgg):
        canvas = FigureCanvasAgg(fig)
    canvas.draw()
    rgba = np.asarray(canvas.buffer_rgba())
    opaque = bool((rgba[..., 3] == 255).all())
    image = Image.fromarray(rgba)
    if opaque:
        image = image.convert("RGB")  # PIL drops the alpha in C, faster than numpy's copy
    info = PngImagePlugin.PngInfo()  # what savefig records
    info.add_text("Software", f"Matplotlib version{matplotlib.__version__}, "
                              "https://matplotlib.org/")
    image.save(path, format="png", compress_level=1 if opaque else 6, pnginfo=info,
               dpi=(fig.dpi, fig.dpi))


def split_figures(results: ChannelTable) -> tuple[list[str], list[str]]:
    """The figures in two groups of about equal drawing time, for two processes.

    A figure costs about one panel's worth of fixed work (figure, text, PNG encoding) plus its
    panels (ticks, labels, lines), as measured on the paper run's figures. Largest first, each
    to the lighter group. Only the channel records count: the same groups before the
    values exist (a `ChannelRecords`) as after."""
    from . import plotting

    def weight(stem: str) -> int:
        if stem == "joint_angles":  # a panel per torque at most (the records alone: the
            # figures are shared out before the values exist, `prepare_figures`)
            return (1 + plotting.joint_fixed_panels(results)
                    + len(plotting.joint_channels(results, "torque")))
        if stem == "sensors":
            return 1 + len(results.names_of(ChannelKind.SENSOR))
        if stem == "base":
            return 1 + len(plotting.base_pose_channels(results))
        return 2  # tip_paths

    groups: tuple[list[str], list[str]] = ([], [])
    loads = [0, 0]
    for stem in sorted(figure_stems(results), key=weight, reverse=True):
        lighter = loads.index(min(loads))
        groups[lighter].append(stem)
        loads[lighter] += weight(stem)
    return groups


def preload_figures() -> None:
    """Import matplotlib's Agg backend and the plotting code, and load the fonts by drawing a
    tiny figure: what the first figure would otherwise spend first (`figure_worker`)."""
    import io

    from matplotlib.figure import Figure

    from . import plotting

    fig = Figure(figsize=(1, 1), dpi=plotting.DPI)
    ax = fig.subplots()
    ax.plot([0.0, 1.0], [0.0, 1.0], label="x")
    ax.set_title("x", fontsize="medium")
    ax.legend(fontsize="small")
    fig.text(0.0, 1.0, "x", fontsize="small")
    fig.savefig(io.BytesIO(), format="png", dpi=plotting.DPI)


class ChannelRecords:
    """The channel records of a run whose values do not exist yet (a `ChannelTable` without
    values): enough to tell which figures it will have and how they are laid out."""

    def __init__(self, channels: Iterable[Channel]) -> None:
        self.channels = {c.name: c for c in channels}
        self.time = np.empty(0)
        self.metadata: dict[str, object] = {}
        self.created = ""

    def __getitem__(self, name: str) -> np.ndarray:
        raise KeyError(f"{name}: no values before the run")

    def names_of(self, *kinds: ChannelKind) -> list[str]:
        """Names of the channels of the given kinds, in order."""
        return [n for n, c in self.channels.items() if c.kind in kinds]


def prepare_figures(records: ChannelTable, stems: Sequence[str],
                    stop: Callable[[], bool] | None = None) -> None:
    """Build the frames (figure, margins, axes, ticks) of the figures ``stems`` will draw
    for a run of these channel records, ahead of its values (`plotting.prepare_frames`;
    ``stop`` ends it early): the figure worker's processes do so while the run simulates."""
    from . import plotting

    specs = [spec for stem in stems for spec in plotting.frame_specs(records, stem)]
    plotting.prepare_frames(specs, stop)
