"""The run folder's figures: which are drawn, and the warm-up of a process that draws them
(`figure_worker`)."""

from __future__ import annotations

from pathlib import Path

from ..channels import ChannelKind, ChannelTable


def write_figures(results: ChannelTable, folder: Path) -> list[Path]:
    """joint_angles.png, sensors.png (channels of kind ``sensor`` only), tip_paths.png and
    base.png (a moving base's pose), each if the results have such channels; return their
    paths."""
    from . import plotting

    folder.mkdir(exist_ok=True)
    figures = {}
    if plotting.joint_channels(results):
        figures["joint_angles"] = plotting.plot_joint_angles(results)
    if results.names_of(ChannelKind.SENSOR):
        figures["sensors"] = plotting.plot_sensors(results)
    if plotting.tip_links(results):
        figures["tip_paths"] = plotting.plot_tip_paths(results)
    if results.names_of(ChannelKind.BASE):
        figures["base"] = plotting.plot_base(results)
    paths = []
    for stem, fig in figures.items():
        paths.append(folder / f"{stem}.png")
        fig.savefig(paths[-1], dpi=plotting.DPI)
    return paths


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
