"""What an animation draws of each case: the links as polylines over time (global frame, m),
every link's tip, a moving base (a cart: a block on its rail), and a run's bodies, closing
pins and sliders and ground pivots (`mechanism_parts`), from a run's `Results` or a sweep
file.

A run draws each link's stored deformed shape (`flexlink.channels.shapes`); a sweep file holds
channels only, so each case is drawn as the chords from joint to tip of a serial chain (the
tip channels), or only its tips when the scenario hangs its links on a base.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..channels import ChannelKind, ChannelTable
from .mechanism_parts import DrawnParts, drawn_parts


class AnimationInputError(ValueError):
    """The input cannot be animated: not a run or sweep, a missing channel, a bad option."""


@dataclass(frozen=True)
class ArmTrack:
    """One case to draw: ``links`` (X, Y) polylines (nt, points) each, m, global;
    ``tips`` (nt, 2) per link at the stated magnification; ``base`` (nt, 3): x, y (m) and
    attitude (rad) of a moving base, else None; ``label`` for the legend; ``springs``: the
    links whose joint is elastic (marked at the link's root); ``rail`` (2, 2): the ends of a
    cart's rail (m, global), else None."""

    links: list[tuple[np.ndarray, np.ndarray]]
    tips: list[np.ndarray]
    base: np.ndarray | None
    label: str
    springs: tuple[int, ...] = ()
    rail: np.ndarray | None = None
    parts: DrawnParts = field(default_factory=DrawnParts)


def run_track(results: ChannelTable, magnification: float = 1.0) -> ArmTrack:
    """The arm of a run: every link's deformed shape, deflections × ``magnification``."""
    shapes = list(getattr(results, "shapes", ()))
    if not shapes:
        raise AnimationInputError(
            "these results hold no link shapes (written by a flexlink older than the "
            "animation, or not a run): run the scenario again to animate it")
    links = [s.magnified(magnification) for s in shapes]
    if magnification == 1.0:  # the tip channels themselves: what the animation is checked by
        tips = [_tip_xy(results, s.link) for s in shapes]
    else:
        tips = [np.column_stack([X[:, -1], Y[:, -1]]) for X, Y in links]
    label = str(results.metadata.get("scenario", ""))
    parts = drawn_parts(results.metadata, links, [s.length for s in shapes])
    cart = _cart(results, shapes)
    if cart is not None:
        return ArmTrack(links, tips, cart[0], label, _springs(results), cart[1], parts)
    return ArmTrack(links, tips, _base(results), label, _springs(results), parts=parts)


def _cart(results: ChannelTable, shapes: list) -> tuple[np.ndarray, np.ndarray] | None:
    """A cart's block pose (nt, 3) and its rail's ends (2, 2), m, or None without a cart.

    The channels hold the travel s only; the first link's root, which the cart carries,
    moves along a line parallel to the rail by the travel's changes: the block is drawn
    there, turned along the rail (level when the cart does not move)."""
    travel = [results[n] for n in results.names_of(ChannelKind.BASE)
              if results.channels[n].subject == "cart"
              and results.channels[n].quantity == "position"]
    if not travel or not shapes:
        return None
    s = travel[0]
    X, Y = shapes[0].X, shapes[0].Y
    root = np.column_stack([X[:, 0], Y[:, 0]])
    i, j = int(np.argmin(s)), int(np.argmax(s))
    if s[j] - s[i] > 0.0:
        direction = (root[j] - root[i]) / (s[j] - s[i])
        direction /= max(float(np.hypot(*direction)), 1e-300)
    else:
        direction = np.array([1.0, 0.0])
    angle = float(np.arctan2(direction[1], direction[0]))
    pose = np.column_stack([root, np.full(s.size, angle)])
    reach = max(float(np.hypot(X - X[:, :1], Y - Y[:, :1]).max()), 1e-3)
    ends = np.array([root[i] - 0.15 * reach * direction, root[j] + 0.15 * reach * direction])
    return pose, ends


def _springs(results: ChannelTable) -> tuple[int, ...]:
    """Indices of the links on elastic joints: those with a spring-torque channel."""
    subjects = {results.channels[n].subject for n in results.names_of(ChannelKind.JOINT)
                if results.channels[n].quantity == "spring_torque"}
    return tuple(sorted(int(s.removeprefix("joint")) - 1 for s in subjects))


def _tip_xy(results: ChannelTable, link: str) -> np.ndarray:
    axes = {results.channels[n].quantity: results[n] for n in results.names_of(ChannelKind.TIP)
            if results.channels[n].subject == link}
    if set(axes) != {"X", "Y"}:
        raise AnimationInputError(f"missing channel: the tip X and Y of {link} "
                                  f"({link}_tip_X, {link}_tip_Y)")
    return np.column_stack([axes["X"], axes["Y"]])


def _base(results: ChannelTable) -> np.ndarray | None:
    """x, y, attitude of a moving base (a pinned base turns about the origin), else None."""
    pose = {results.channels[n].quantity: results[n] for n in results.names_of(ChannelKind.BASE)}
    if "attitude" not in pose:
        return None
    zero = np.zeros_like(pose["attitude"])
    return np.column_stack([pose.get("x", zero), pose.get("y", zero), pose["attitude"]])


def sweep_tracks(path: Path) -> tuple[np.ndarray, list[ArmTrack]]:
    """Time (s) and one track per finished case of a sweep file (netCDF)."""
    from .file_checks import DamagedRunFileError, read_sweep_layout

    layout = read_sweep_layout(path)
    if "time" not in layout.coords:
        raise AnimationInputError(f"{path} keeps summary metrics only (a sweep run without "
                                  "histories): nothing to animate; sweep again with the "
                                  "histories of the links' tip channels")
    try:
        base = tomllib.loads(str(layout.attrs.get("base_scenario", "")) or "")
        names = [str(link["name"]) for link in base.get("links", [])]
    except (ValueError, KeyError, TypeError) as exc:
        raise DamagedRunFileError(f"{path}: its attribute base_scenario is damaged "
                                  f"({type(exc).__name__}: {exc})") from None
    on_base = "base" in base
    tips = {}
    for name in names:
        x, y = layout.data.get(f"{name}_tip_X"), layout.data.get(f"{name}_tip_Y")
        if x is None or y is None:
            raise AnimationInputError(f"missing channel: {name}_tip_X and {name}_tip_Y are not "
                                      f"in {path} (sweep with --channels that keep them)")
        tips[name] = (np.asarray(x.values, float), np.asarray(y.values, float))
    if not names:
        raise AnimationInputError(f"{path} names no links (attribute base_scenario)")
    status = np.asarray(layout.data["status"].values).astype(str)
    parameters = [n for n, v in layout.coords.items() if v.dims == ("case",) and n != "case"]
    tracks = []
    for case in np.flatnonzero(status == "ok"):
        case_tips = [np.column_stack([tips[n][0][case], tips[n][1][case]]) for n in names]
        links = [] if on_base else _chords(case_tips)
        label = ", ".join(f"{p} = {layout.coords[p].values[case]:.4g}" for p in parameters)
        tracks.append(ArmTrack(links, case_tips, None, label or f"case {case}"))
    if not tracks:
        raise AnimationInputError(f"{path}: no case finished (status ok)")
    return np.asarray(layout.coords["time"].values, float), tracks


def _chords(tips: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
    """Straight lines joint → tip of a serial chain on a hub at the origin."""
    roots = [np.zeros_like(tips[0])] + tips[:-1]
    return [(np.column_stack([r[:, 0], t[:, 0]]), np.column_stack([r[:, 1], t[:, 1]]))
            for r, t in zip(roots, tips, strict=True)]


def check_channels(results: ChannelTable, names: list[str]) -> None:
    """AnimationInputError naming every requested channel the results do not have."""
    missing = [n for n in names if n not in results.channels]
    if missing:
        raise AnimationInputError(
            f"missing channel(s): {', '.join(missing)}; available: {', '.join(results.channels)}")
