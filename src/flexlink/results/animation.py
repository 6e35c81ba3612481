"""Animations of the moving, deforming arm: GIF (Pillow) or MP4 (imageio-ffmpeg's bundled
ffmpeg), written atomically.

The arm panel is drawn in the global frame at one scale on both axes (m per pixel, stated in
`AnimationInfo`); below it, chosen channels against time with a cursor at the frame's time.
Frames are rendered by blitting: the static parts (axes, traces, labels) are drawn once, only
the moving artists per frame (the cost of a full draw would be most of the run time).

Each link's tip carries a filled dot in a colour of `TIP_COLOURS` (runs) that no other artist
uses, so a reader of the frames can find it (tests/unit/test_animation.py does).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Polygon

from ..channels import ChannelKind, ChannelTable
from ..options import check_size
from .arm_tracks import AnimationInputError, ArmTrack, check_channels, run_track, sweep_tracks
from .atomic import atomic_file
from .plotting import display_scale

FORMATS = ("gif", "mp4")
TIP_COLOURS = ("#ff00ff", "#00ffff", "#ffd700", "#ff8000")  # runs: one per link
CASE_COLOURS = ("#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#8c564b", "#e377c2", "#7f7f7f",
                "#bcbd22", "#17becf", "#ff7f0e")
DPI = 100
WIDTH_PX = 640
ARM_PX = 480  # height of the arm panel
PANEL_PX = 110  # height of each channel panel
MAX_PANELS = 4
MAX_FRAMES = 10_000  # frames of one file: ~8 minutes at 20 fps
PAGE_SECONDS = 30.0  # longest animation a run's page gets (longer runs play faster)
_MARGIN = (60, 16, 34, 40)  # left, right, top, bottom of the arm panel (px)


@dataclass(frozen=True)
class AnimationInfo:
    """What was written: ``path``; ``times`` (s) and ``indices`` (into the run's time grid) of
    the frames; the arm panel's mapping: ``origin_px`` (column, row of global (0, 0), pixels
    from the top left corner, continuous: pixel (i, j) spans [i, i+1) × [j, j+1)) and
    ``metres_per_pixel``; ``size`` (width, height) px; ``magnification``; ``fps``; ``speed``."""

    path: Path
    times: np.ndarray
    indices: np.ndarray
    origin_px: tuple[float, float]
    metres_per_pixel: float
    size: tuple[int, int]
    magnification: float
    fps: float
    speed: float

    def to_pixel(self, X: np.ndarray, Y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Column and row (continuous pixel coordinates) of global points X, Y (m)."""
        return (self.origin_px[0] + np.asarray(X) / self.metres_per_pixel,
                self.origin_px[1] - np.asarray(Y) / self.metres_per_pixel)


def animate(results: ChannelTable, path: str | Path, *, channels: Sequence[str] | None = None,
            magnification: float = 1.0, fps: float = 20.0, speed: float = 1.0,
            trail: float = 1.0, title: str | None = None) -> AnimationInfo:
    """Write an animation of a run to ``path`` (``.gif`` or ``.mp4``).

    ``channels``: traces under the arm (default: the sensors, at most four); ``magnification``:
    deflections drawn × this (1 = true scale; stated on the frame otherwise); ``fps``: frames
    per second of the file; ``speed``: simulated seconds per second of video (1 = real time,
    0.25 = four times slower); ``trail``: seconds of tip path drawn behind each tip."""
    names = list(results.names_of(ChannelKind.SENSOR)[:MAX_PANELS] if channels is None
                 else channels)
    check_channels(results, names)
    _check_options(path, magnification, fps, speed, trail, len(names))
    track = run_track(results, magnification)
    traces = [_trace(results, n) for n in names]
    name = title or f"flexlink: {results.metadata.get('scenario', 'run')}"
    return _write(np.asarray(results.time, float), [track], traces, Path(path), magnification,
                  fps, speed, trail, name, run=True)


def page_speed(time: np.ndarray) -> float:
    """The speed of the animation that ``flexlink run --animate`` and ``report --animate``
    write: real time, or faster so that it lasts PAGE_SECONDS (stated on the frame)."""
    span = float(time[-1] - time[0]) if len(time) else 0.0
    return max(1.0, span / PAGE_SECONDS)


def animate_sweep(sweep_file: str | Path, path: str | Path, *, fps: float = 20.0,
                  speed: float = 1.0, trail: float = 1.0,
                  max_cases: int = len(CASE_COLOURS)) -> AnimationInfo:
    """Write an animation of a sweep file's finished cases overlaid (tips and chords, at true
    scale: a sweep file holds no shapes), at most ``max_cases`` of them."""
    _check_options(path, 1.0, fps, speed, trail, 0)
    time, tracks = sweep_tracks(Path(sweep_file))
    shown = tracks[:max_cases]
    title = f"flexlink sweep: {len(shown)} of {len(tracks)} finished cases"
    return _write(time, shown, [], Path(path), 1.0, fps, speed, trail, title, run=False)


def _check_options(path: str | Path, magnification: float, fps: float, speed: float,
                   trail: float, panels: int) -> None:
    suffix = Path(path).suffix.lower().lstrip(".")
    problems = []
    if suffix not in FORMATS:
        problems.append(f"output {path}: unknown format {suffix or '(none)'!r}; use .gif or .mp4")
    for label, value in (("magnification", magnification), ("fps", fps), ("speed", speed)):
        if not (math.isfinite(value) and value > 0):
            problems.append(f"{label} must be a positive number, got {value!r}")
    if not (math.isfinite(trail) and trail >= 0):
        problems.append(f"trail must be a finite number >= 0 s, got {trail!r}")
    if panels > MAX_PANELS:
        problems.append(f"at most {MAX_PANELS} channels under the arm, got {panels}")
    if problems:
        raise AnimationInputError("; ".join(problems))


@dataclass(frozen=True)
class _Trace:
    name: str
    values: np.ndarray  # display units
    label: str


def _trace(results: ChannelTable, name: str) -> _Trace:
    channel = results.channels[name]
    factor, unit = display_scale(channel.unit)
    return _Trace(name, results[name] * factor, f"{name} [{unit or '-'}]")


def frame_indices(time: np.ndarray, fps: float, speed: float) -> tuple[np.ndarray, np.ndarray]:
    """Frame times (s, every speed/fps of simulated time) and the nearest output sample;
    OptionError beyond MAX_FRAMES."""
    step = speed / fps
    span = float(time[-1] - time[0])
    check_size(f"fps = {fps:g} at speed = {speed:g}", span / step + 1, MAX_FRAMES,
               f"frames for {span:g} s of run",
               f"fps = {_fitting_fps(span, speed):.3g} or fewer fits (or a larger speed)")
    count = math.floor(span / step + 1e-9) + 1
    times = time[0] + step * np.arange(count)
    indices = np.clip(np.searchsorted(time, times), 1, time.size - 1)
    nearer = np.abs(time[indices - 1] - times) <= np.abs(time[indices] - times)
    return times, np.where(nearer, indices - 1, indices)


def _fitting_fps(span: float, speed: float) -> float:
    """The largest frame rate that keeps a run of ``span`` s within MAX_FRAMES frames."""
    return (MAX_FRAMES - 1) * speed / span if span > 0 else math.inf


def _write(time: np.ndarray, tracks: list[ArmTrack], traces: list[_Trace], path: Path,
           magnification: float, fps: float, speed: float, trail: float, title: str,
           run: bool) -> AnimationInfo:
    if time.size < 2:
        raise AnimationInputError("the run has fewer than two samples: nothing to animate")
    times, indices = frame_indices(time, fps, speed)
    scene = _Scene(time, tracks, traces, magnification, speed, title, run)
    info = AnimationInfo(path, times, indices, scene.origin_px, scene.metres_per_pixel,
                         scene.size, magnification, fps, speed)
    trail_samples = round(trail / float(np.median(np.diff(time))))
    frames = (scene.frame(i, t, trail_samples) for i, t in zip(indices, times, strict=True))
    with atomic_file(path) as partial:
        if path.suffix.lower() == ".gif":
            _write_gif(frames, partial, fps)
        else:
            _write_mp4(frames, partial, fps, scene.size)
    return info


class _Scene:
    """The figure, its static background and the artists that move."""

    def __init__(self, time: np.ndarray, tracks: list[ArmTrack], traces: list[_Trace],
                 magnification: float, speed: float, title: str, run: bool) -> None:
        self.time, self.tracks = time, tracks
        height = ARM_PX + PANEL_PX * len(traces) + (44 if traces else 0)
        self.size = (WIDTH_PX, height + height % 2)  # even: what MP4 (yuv420p) needs
        w, h = self.size
        self.fig = Figure(figsize=(w / DPI, h / DPI), dpi=DPI)
        self.canvas = FigureCanvasAgg(self.fig)
        left, right, top, bottom = _MARGIN
        box = (left, h - ARM_PX + bottom, w - left - right, ARM_PX - top - bottom)
        ax = self.fig.add_axes((box[0] / w, box[1] / h, box[2] / w, box[3] / h))
        self._limits(ax, box)
        ax.set_xlabel("X [m]", labelpad=1)
        ax.set_ylabel("Y [m]", labelpad=1)
        ax.grid(True, linewidth=0.4, alpha=0.5)
        ax.set_title(title, fontsize="medium", loc="left")
        notes = []
        if magnification != 1.0:
            notes.append(f"deflection × {magnification:g}")
        if speed != 1.0:
            notes.append(f"{speed:g} × real time")
        if notes:
            ax.text(0.99, 0.98, ", ".join(notes), transform=ax.transAxes, ha="right", va="top",
                    fontsize="medium", color="#b00000", fontweight="bold")
        self.moving: list = []
        self.clock = ax.text(0.01, 0.98, "", transform=ax.transAxes, ha="left", va="top",
                             family="monospace", animated=True)
        self.moving.append(self.clock)
        self._arm_artists(ax, run)
        self.cursors = self._panels(traces, box)
        self.ax = ax
        self.canvas.draw()
        self.background = self.canvas.copy_from_bbox(self.fig.bbox)

    def _limits(self, ax: object, box: tuple[float, float, float, float]) -> None:
        """Limits holding every drawn point, at one scale (m per pixel) on both axes."""
        xs, ys = [np.zeros(1)], [np.zeros(1)]
        for track in self.tracks:
            for X, Y in track.links:
                xs.append(X.ravel())
                ys.append(Y.ravel())
            for tip in track.tips:
                xs.append(tip[:, 0])
                ys.append(tip[:, 1])
            if track.base is not None:
                xs.append(track.base[:, 0])
                ys.append(track.base[:, 1])
            if track.rail is not None:
                xs.append(track.rail[:, 0])
                ys.append(track.rail[:, 1])
            parts = track.parts
            for points in ([c for _, c in parts.bodies]
                           + [e.reshape(-1, 2) for _, _, e in parts.sliders]
                           + ([parts.pivots] if parts.pivots is not None else [])):
                xs.append(points[:, 0])
                ys.append(points[:, 1])
        x, y = np.concatenate(xs), np.concatenate(ys)
        reach = max(np.ptp(x), np.ptp(y), 1e-9)
        self.reach = reach
        pad = 0.08 * reach
        self.metres_per_pixel = max((np.ptp(x) + 2 * pad) / box[2], (np.ptp(y) + 2 * pad) / box[3])
        cx, cy = (x.max() + x.min()) / 2, (y.max() + y.min()) / 2
        half_w, half_h = box[2] / 2 * self.metres_per_pixel, box[3] / 2 * self.metres_per_pixel
        ax.set_xlim(cx - half_w, cx + half_w)  # type: ignore[attr-defined]
        ax.set_ylim(cy - half_h, cy + half_h)  # type: ignore[attr-defined]
        # (0, 0) in pixels from the top left corner of the image
        self.origin_px = (box[0] + (0 - (cx - half_w)) / self.metres_per_pixel,
                          self.size[1] - box[1] - (0 - (cy - half_h)) / self.metres_per_pixel)

    def _arm_artists(self, ax: object, run: bool) -> None:
        add = ax.add_line  # type: ignore[attr-defined]
        one = len(self.tracks) == 1
        self.link_lines, self.trails, self.tip_dots = [], [], []
        for c, track in enumerate(self.tracks):
            colour = "#202020" if one else CASE_COLOURS[c % len(CASE_COLOURS)]
            self.link_lines.append([add(Line2D([], [], color=colour, linewidth=2.2,
                                               solid_capstyle="round", animated=True))
                                    for _ in track.links])
            self.trails.append([add(Line2D([], [], color="#ff9f40" if one else colour,
                                           linewidth=1.3, alpha=0.9 if one else 0.5,
                                           animated=True)) for _ in track.tips])
            dots = []
            for k, _ in enumerate(track.tips):
                dot_colour = TIP_COLOURS[k % len(TIP_COLOURS)] if run else colour
                dots.append(add(Line2D([], [], marker="o", markersize=6.5, linestyle="none",
                                       markerfacecolor=dot_colour, markeredgewidth=0,
                                       zorder=5, animated=True)))
            self.tip_dots.append(dots)
            if not one:
                ax.plot([], [], color=colour, label=track.label)  # type: ignore[attr-defined]
        if not one:
            ax.legend(loc="lower right", fontsize="x-small")  # type: ignore[attr-defined]
        ax.plot([0], [0], marker="^", color="0.3", markersize=8,  # type: ignore[attr-defined]
                linestyle="none")
        # elastic joints: an open ring at the link's root (one artist per case)
        self.spring_marks = [add(Line2D([], [], marker="o", markersize=12, linestyle="none",
                                        markerfacecolor="none", markeredgecolor="#7030a0",
                                        markeredgewidth=1.8, zorder=4, animated=True))
                             for _ in self.tracks]
        self.moving.extend(self.spring_marks)
        # joint frames of a run: x (red) along the link at its joint, y (green) across
        self.frame_x = add(Line2D([], [], color="#d00000", linewidth=1.2, animated=True))
        self.frame_y = add(Line2D([], [], color="#00a000", linewidth=1.2, animated=True))
        self.show_frames = run
        self.base_patch = None
        rail = self.tracks[0].rail
        if rail is not None:  # a cart's rail: static, under the block
            ax.plot(rail[:, 0], rail[:, 1], color="#707070", linewidth=3.0,  # type: ignore[attr-defined]
                    solid_capstyle="butt", zorder=0)
        base = self.tracks[0].base
        if base is not None:
            self.base_patch = Polygon(np.zeros((4, 2)), closed=True, facecolor="#c8d0e0",
                                      edgecolor="#404860", animated=True, zorder=1)
            ax.add_patch(self.base_patch)  # type: ignore[attr-defined]
            self.base_half = self._base_half(self.tracks[0])
        self._parts_artists(ax)
        for group in (*self.link_lines, *self.trails):
            self.moving.extend(group)
        self.moving += [self.frame_x, self.frame_y, *self.part_artists]
        for group in self.tip_dots:  # last: nothing covers a dot (its centre is the tip)
            self.moving.extend(group)
        if self.base_patch is not None:
            self.moving.insert(0, self.base_patch)

    def _parts_artists(self, ax: object) -> None:
        """A run's bodies (a disc at the centre of mass on a stalk from its section point),
        closing pins (open rings), ground pivots (triangles, static) and sliders (a block on
        its dashed line, static; a slider inside the chain's line moves with its parent's
        tip): drawn for the first track (a run has one)."""
        add = ax.add_line  # type: ignore[attr-defined]
        parts = self.tracks[0].parts
        self.part_artists: list = []
        self.stalks = add(Line2D([], [], color="#505050", linewidth=1.4, animated=True))
        self.body_dots = add(Line2D([], [], marker="o", markersize=10, linestyle="none",
                                    markerfacecolor="#4a6fa5", markeredgecolor="#1f3050",
                                    markeredgewidth=1.0, zorder=4, animated=True))
        self.pin_marks = add(Line2D([], [], marker="o", markersize=7, linestyle="none",
                                    markerfacecolor="white", markeredgecolor="#202020",
                                    markeredgewidth=1.5, zorder=4, animated=True))
        self.part_artists += [self.stalks, self.body_dots, self.pin_marks]
        if parts.pivots is not None:
            ax.plot(parts.pivots[:, 0], parts.pivots[:, 1],  # type: ignore[attr-defined]
                    marker="^", color="0.3", markersize=8, linestyle="none")
        self.slider_blocks = []
        for point, angle, ends in parts.sliders:
            rail = None
            if ends.ndim == 2:
                ax.plot(ends[:, 0], ends[:, 1], color="#707070", linewidth=1.5,  # type: ignore[attr-defined]
                        linestyle="--", zorder=0)
            else:  # on a moving link: redrawn every frame
                rail = add(Line2D([], [], color="#707070", linewidth=1.5, linestyle="--",
                                  zorder=2, animated=True))
                self.part_artists.append(rail)
            block = Polygon(np.zeros((4, 2)), closed=True, facecolor="#c8d0e0",
                            edgecolor="#404860", animated=True, zorder=3)
            ax.add_patch(block)  # type: ignore[attr-defined]
            self.slider_blocks.append((block, point, angle, rail, ends))
            self.part_artists.append(block)

    def _place_parts(self, index: int) -> None:
        parts = self.tracks[0].parts
        sx: list[float] = []
        sy: list[float] = []
        for anchor, centre in parts.bodies:  # one line, segments separated by NaN
            sx += [anchor[index, 0], centre[index, 0], np.nan]
            sy += [anchor[index, 1], centre[index, 1], np.nan]
        self.stalks.set_data(sx, sy)
        self.body_dots.set_data([c[index, 0] for _, c in parts.bodies],
                                [c[index, 1] for _, c in parts.bodies])
        self.pin_marks.set_data([p[index, 0] for p in parts.pins],
                                [p[index, 1] for p in parts.pins])
        half = 0.035 * self.reach
        for block, point, angle, rail, ends in self.slider_blocks:
            if rail is not None:
                rail.set_data(ends[index, :, 0], ends[index, :, 1])
                angle = angle[index]
            c, s = math.cos(angle), math.sin(angle)
            corners = np.array([[-1.4 * half, -half], [1.4 * half, -half],
                                [1.4 * half, half], [-1.4 * half, half]])
            block.set_xy(point[index] + corners @ np.array([[c, s], [-s, c]]))

    def _base_half(self, track: ArmTrack) -> float:
        """Half side (m) of the square drawn for a base: reaching its farthest link joint."""
        assert track.base is not None
        ref = track.base[0, :2]
        roots = [np.array([X[0, 0], Y[0, 0]]) for X, Y in track.links]
        tips = [np.array([X[0, -1], Y[0, -1]]) for X, Y in track.links]
        on_base = [r for k, r in enumerate(roots)
                   if k == 0 or np.linalg.norm(r - tips[k - 1]) > 1e-6 * self.reach]
        far = max((float(np.max(np.abs(r - ref))) for r in on_base), default=0.0)
        return far if far > 1e-3 * self.reach else 0.04 * self.reach

    def _panels(self, traces: list[_Trace], arm_box: tuple[float, ...]) -> list[Line2D]:
        w, h = self.size
        cursors = []
        for i, trace in enumerate(traces):
            bottom = h - ARM_PX - PANEL_PX * (i + 1) - 4
            ax = self.fig.add_axes((arm_box[0] / w, bottom / h, arm_box[2] / w,
                                    (PANEL_PX - 22) / h))
            ax.plot(self.time, trace.values, color="0.25", linewidth=0.8)
            ax.set_xlim(self.time[0], self.time[-1])
            ax.set_ylabel(trace.label, fontsize="x-small", rotation=0, ha="left", va="bottom")
            ax.yaxis.set_label_coords(0.0, 1.02)
            ax.tick_params(labelsize="x-small")
            ax.grid(True, linewidth=0.4, alpha=0.5)
            if i < len(traces) - 1:
                ax.tick_params(labelbottom=False)
            else:
                ax.set_xlabel("time t [s]", fontsize="x-small", labelpad=1)
            cursor = ax.axvline(self.time[0], color="#b00000", linewidth=1.0, animated=True)
            dot = ax.plot([], [], "o", color="#b00000", markersize=3.5, animated=True)[0]
            cursors.append((cursor, dot, trace))
            self.moving += [cursor, dot]
        return cursors

    def frame(self, index: int, t: float, trail: int) -> np.ndarray:
        """The RGB image (h, w, 3) at output sample ``index`` (frame time ``t``, s)."""
        self.canvas.restore_region(self.background)
        self.clock.set_text(f"t = {t:7.3f} s")
        fx, fy = [], []
        first = max(0, index - trail)
        for lines, trails, dots, track in zip(self.link_lines, self.trails, self.tip_dots,
                                              self.tracks, strict=True):
            for line, (X, Y) in zip(lines, track.links, strict=True):
                line.set_data(X[index], Y[index])
                if self.show_frames:
                    self._frame_axes(X[index], Y[index], fx, fy)
            for line, dot, tip in zip(trails, dots, track.tips, strict=True):
                line.set_data(tip[first:index + 1, 0], tip[first:index + 1, 1])
                dot.set_data(tip[index:index + 1, 0], tip[index:index + 1, 1])
        for mark, track in zip(self.spring_marks, self.tracks, strict=True):
            mark.set_data([track.links[k][0][index, 0] for k in track.springs],
                          [track.links[k][1][index, 0] for k in track.springs])
        if fx:
            self.frame_x.set_data(fx[0::2], fx[1::2])
            self.frame_y.set_data(fy[0::2], fy[1::2])
        if self.base_patch is not None:
            self._place_base(self.tracks[0].base[index])  # type: ignore[index]
        self._place_parts(index)
        for cursor, dot, trace in self.cursors:
            cursor.set_xdata([self.time[index]] * 2)
            dot.set_data([self.time[index]], [trace.values[index]])
        for artist in self.moving:
            artist.axes.draw_artist(artist)
        return np.asarray(self.canvas.buffer_rgba())[:, :, :3].copy()

    def _frame_axes(self, X: np.ndarray, Y: np.ndarray, fx: list, fy: list) -> None:
        """The joint frame at a link's joint: x along the link's first segment, y across;
        segments separated by NaN in one line per axis colour."""
        size = 0.07 * self.reach
        d = np.array([X[1] - X[0], Y[1] - Y[0]])
        d = d / max(np.hypot(*d), 1e-300)
        n = np.array([-d[1], d[0]])
        for axis, out in ((d, fx), (n, fy)):
            out.extend([X[0], Y[0], X[0] + size * axis[0], Y[0] + size * axis[1],
                        np.nan, np.nan])

    def _place_base(self, pose: np.ndarray) -> None:
        h = self.base_half
        c, s = math.cos(pose[2]), math.sin(pose[2])
        corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
        self.base_patch.set_xy(pose[:2] + corners @ np.array([[c, s], [-s, c]]))  # type: ignore


def _write_gif(frames: Iterator[np.ndarray], path: Path, fps: float) -> None:
    """GIF (Pillow): one palette for all frames, taken from the first frame plus the tip
    colours, so the tip dots keep their exact colour and nothing flickers."""
    from PIL import Image

    first = Image.fromarray(next(frames))
    extra = [int(c[i:i + 2], 16) for c in TIP_COLOURS for i in (1, 3, 5)]
    palette = first.quantize(colors=256 - len(TIP_COLOURS), method=Image.Quantize.MEDIANCUT)
    values = palette.getpalette()[: 3 * (256 - len(TIP_COLOURS))] + extra
    palette.putpalette(values)

    def indexed(image: Image.Image) -> Image.Image:
        return image.quantize(palette=palette, dither=Image.Dither.NONE)

    rest = (indexed(Image.fromarray(f)) for f in frames)
    indexed(first).save(path, format="GIF", save_all=True, append_images=rest, loop=0,
                        duration=round(1000 / fps), optimize=False)


def _write_mp4(frames: Iterator[np.ndarray], path: Path, fps: float,
               size: tuple[int, int]) -> None:
    """MP4 (H.264) with the ffmpeg binary of the imageio-ffmpeg wheel."""
    import imageio_ffmpeg

    writer = imageio_ffmpeg.write_frames(
        str(path), size, fps=fps, codec="libx264", pix_fmt_out="yuv420p", quality=7,
        macro_block_size=2, output_params=["-f", "mp4"], ffmpeg_log_level="error")
    writer.send(None)
    try:
        for frame in frames:
            writer.send(np.ascontiguousarray(frame))
    finally:
        writer.close()
