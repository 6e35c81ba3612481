"""The mechanism's parts an animation draws besides the links: rigid bodies at their centre of
mass, the pins and sliders that close loops, and the ground pivots of links that start on a
fixed base.

A run's metadata carries their geometry under ``drawn_parts`` (JSON text, so results.nc and
results.mat keep it and a run folder is drawn as the run was):

- ``bodies``: ``[link, at, dx, dy]``, a body fixed to link ``link`` (0-based) at ``at`` (m from
  its joint), its centre of mass ``(dx, dy)`` (m) in the section's frame (`model.chain.Body`);
- ``pins``: ``[link, x, to_link, x_to, gx, gy]``, a revolute closure pinning the point ``x`` of
  ``link`` to the point ``x_to`` of ``to_link``, or (``to_link`` = −1) to the ground point
  ``(gx, gy)`` (m, global);
- ``sliders``: ``[link, x, gx, gy, angle]``, a slider closure keeping the point ``x`` of
  ``link`` on the fixed line through ``(gx, gy)`` at ``angle`` (rad from global X);
- ``pivots``: links other than the first whose joint sits on a fixed base;
- ``rails``: ``[link, axis]`` or ``[link, axis, at]``, a slider inside the chain
  (`model.PrismaticJoint`): link ``link`` rides on a block along the line through the tip of
  link ``link`` − 1 (or through its section ``at``, m from its joint) at ``axis`` (rad) from
  that section, the line turning with it.

Positions over time are read off the drawn (possibly magnified) link polylines: a point at
``x`` is interpolated between the stored points, the section's angle is the polyline's
tangent there (second-order differences), which is what the eye reads from the drawn link.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

KEY = "drawn_parts"


def parts_metadata(scenario: Any) -> dict[str, str]:
    """``{KEY: json}`` with the scenario's bodies, closures and ground pivots; empty if it has
    none (``scenario``: a `model.Scenario`)."""
    bodies = [[k, b.at, b.offset[0], b.offset[1]]
              for k, link in enumerate(scenario.chain.links) for b in link.bodies]
    pins, sliders = [], []
    for c in getattr(scenario, "closures", ()):
        if c.kind == "revolute":
            pins.append([c.link, c.x, -1 if c.to_link is None else c.to_link, c.x_to,
                         c.ground[0], c.ground[1]])
        else:
            sliders.append([c.link, c.x, c.ground[0], c.ground[1], c.angle])
    base = scenario.base
    pivots = ([k for k, _ in base.attachments if k != 0]
              if base is not None and base.kind == "fixed" else [])
    rails = [[k, joint.axis_angle] + ([joint.at] if joint.at is not None else [])
             for k, joint in enumerate(scenario.chain.joints) if hasattr(joint, "axis_angle")]
    parts = {name: value for name, value in (("bodies", bodies), ("pins", pins),
                                             ("sliders", sliders), ("pivots", pivots),
                                             ("rails", rails)) if value}
    return {KEY: json.dumps(parts, separators=(",", ":"))} if parts else {}


@dataclass(frozen=True)
class DrawnParts:
    """What to draw over time (global frame, m): ``bodies`` (anchor, centre), each (nt, 2):
    the section point and the body's centre of mass; ``pins`` (nt, 2) each: the moving pins;
    ``pivots`` (n, 2): fixed ground pivots; ``sliders`` (point (nt, 2), angle rad, line ends
    (2, 2)): a block on its line; a slider inside the chain's line moves: its angle (nt,)
    and ends (nt, 2, 2)."""

    bodies: tuple[tuple[np.ndarray, np.ndarray], ...] = ()
    pins: tuple[np.ndarray, ...] = ()
    pivots: np.ndarray | None = None
    sliders: tuple[tuple[np.ndarray, float, np.ndarray], ...] = ()


def drawn_parts(metadata: Mapping[str, Any], links: Sequence[tuple[np.ndarray, np.ndarray]],
                lengths: Sequence[float]) -> DrawnParts:
    """The parts of a run (its ``metadata``) placed on its drawn ``links`` (X, Y (nt, points)
    each) of undeformed ``lengths`` (m)."""
    text = metadata.get(KEY)
    if not text:
        return DrawnParts()
    try:
        parts = json.loads(str(text))
    except ValueError:
        raise ValueError(f"the run's metadata {KEY} is damaged: {text!r}") from None

    def at(link: int, x: float) -> tuple[np.ndarray, np.ndarray]:
        X, Y = links[int(link)]
        return section(X, Y, float(x) / float(lengths[int(link)]))

    bodies = []
    for link, x, dx, dy in parts.get("bodies", ()):
        point, angle = at(link, x)
        c, s = np.cos(angle), np.sin(angle)
        centre = point + np.column_stack([c * dx - s * dy, s * dx + c * dy])
        bodies.append((point, centre))
    pins, fixed = [], []
    for link, x, to_link, _x_to, gx, gy in parts.get("pins", ()):
        pins.append(at(link, x)[0])
        if to_link < 0:
            fixed.append((gx, gy))
    for link in parts.get("pivots", ()):
        X, Y = links[int(link)]
        fixed.append((float(X[0, 0]), float(Y[0, 0])))
    sliders = []
    for link, x, gx, gy, angle in parts.get("sliders", ()):
        point = at(link, x)[0]
        direction = np.array([np.cos(angle), np.sin(angle)])
        along = (point - np.array([gx, gy])) @ direction
        reach = max(float(np.ptp(along)), 0.1 * float(lengths[int(link)]))
        ends = np.array([gx, gy]) + np.outer([along.min() - 0.25 * reach,
                                              along.max() + 0.25 * reach], direction)
        sliders.append((point, float(angle), ends))
    for link, axis, *line_at in parts.get("rails", ()):
        X, Y = links[int(link)]
        point = np.column_stack([X[:, 0], Y[:, 0]])  # the block: the carried link's root
        tip, tip_angle = at(int(link) - 1, line_at[0] if line_at else lengths[int(link) - 1])
        angle = tip_angle + float(axis)
        direction = np.column_stack([np.cos(angle), np.sin(angle)])
        along = np.sum((point - tip) * direction, axis=1)
        reach = max(float(np.ptp(along)), 0.1 * float(lengths[int(link)]))
        low, high = min(float(along.min()), 0.0) - 0.25 * reach, float(along.max()) + 0.25 * reach
        ends = tip[:, None, :] + np.array([low, high])[None, :, None] * direction[:, None, :]
        sliders.append((point, angle, ends))
    return DrawnParts(tuple(bodies), tuple(pins),
                      np.array(fixed, dtype=float) if fixed else None, tuple(sliders))


def section(X: np.ndarray, Y: np.ndarray, fraction: float) -> tuple[np.ndarray, np.ndarray]:
    """Position (nt, 2), m, and tangent angle (nt,), rad, of the polyline X, Y (nt, points),
    points evenly spaced in x/L, at x/L = ``fraction`` (0 … 1)."""
    points = X.shape[1]
    u = min(max(fraction, 0.0), 1.0) * (points - 1)
    i = min(int(np.floor(u)), points - 2)
    w = u - i
    point = np.column_stack([(1 - w) * X[:, i] + w * X[:, i + 1],
                             (1 - w) * Y[:, i] + w * Y[:, i + 1]])
    dX = np.gradient(X, axis=1, edge_order=2)
    dY = np.gradient(Y, axis=1, edge_order=2)
    tx = (1 - w) * dX[:, i] + w * dX[:, i + 1]
    ty = (1 - w) * dY[:, i] + w * dY[:, i + 1]
    return point, np.arctan2(ty, tx)
