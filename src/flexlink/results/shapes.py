"""The links' deformed shapes (`flexlink.channels.shapes.LinkShape`) in the file layout.

In results.nc and results.mat, beside the channels and never in results.csv:

- the coordinate ``point`` (x/L of each stored point, 0 at the joint … 1 at the tip);
- ``<link>_shape_X``, ``<link>_shape_Y`` over (time, point): global position (m) of the
  deformed link's points, attribute ``link_length`` (m); 32-bit floats (0.1 µm at 1 m, far
  below a drawn pixel), which halves what they add to a paper run's files;
- ``<link>_frame_X``, ``<link>_frame_Y`` (m), ``<link>_frame_angle`` (rad) over time: the
  link's rigid (zero-order) frame, from which a deflection magnification is measured.

Every one has ``kind = "shape"`` and ``subject`` = the link: readers that take variables over
time with a channel kind as channels pass them by.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..channels.shapes import SHAPE_KIND, LinkShape
from .variables import Layout, Variable

POINT = "point"
STORED = np.float32
_FRAME = (("frame_X", "m", "X of the origin of the rigid frame of"),
          ("frame_Y", "m", "Y of the origin of the rigid frame of"),
          ("frame_angle", "rad", "angle of the rigid frame of"))


def shape_variables(shapes: Sequence[LinkShape]) -> tuple[dict[str, Variable],
                                                          dict[str, Variable]]:
    """(coordinates, data variables) of the shapes; both empty without shapes."""
    if not shapes:
        return {}, {}
    coords = {POINT: Variable((POINT,), np.asarray(shapes[0].fraction, dtype=float), {
        "units": "1", "long_name": "position along the link as a fraction of its length "
                                   "(x/L: 0 at the joint, 1 at the tip)"})}
    data: dict[str, Variable] = {}
    for s in shapes:
        for axis, values in (("X", s.X), ("Y", s.Y)):
            data[f"{s.link}_shape_{axis}"] = Variable(("time", POINT), values.astype(STORED), {
                "units": "m", "long_name": f"global {axis} of points along the deformed "
                                           f"{s.link}", "kind": SHAPE_KIND,
                "quantity": f"shape_{axis}", "subject": s.link, "link_length": s.length})
        frame = (s.origin[:, 0], s.origin[:, 1], s.angle)
        for (quantity, unit, text), values in zip(_FRAME, frame, strict=True):
            data[f"{s.link}_{quantity}"] = Variable(("time",), values, {
                "units": unit, "long_name": f"{text} {s.link} (global)", "kind": SHAPE_KIND,
                "quantity": quantity, "subject": s.link})
    return coords, data


SHAPE_QUANTITIES = ("shape_X", "shape_Y", "frame_X", "frame_Y", "frame_angle")


def shapes_of(layout: Layout) -> list[LinkShape]:
    """The shapes a layout holds (inverse of `shape_variables`), in the links' order."""
    if POINT not in layout.coords:
        return []
    fraction = np.asarray(layout.coords[POINT].values, dtype=float)
    by_link: dict[str, dict[str, Variable]] = {}
    for variable in layout.data.values():
        if variable.attrs.get("kind") == SHAPE_KIND:
            by_link.setdefault(str(variable.attrs["subject"]), {})[
                str(variable.attrs["quantity"])] = variable
    out = []
    for link, parts in by_link.items():
        missing = [f"{link}_{q}" for q in SHAPE_QUANTITIES if q not in parts]
        if missing:
            raise ValueError(f"the shape variables of {link} are incomplete: no "
                             f"{', '.join(missing)}")
        x = parts["shape_X"]
        out.append(LinkShape(
            link, float(x.attrs["link_length"]), fraction, np.asarray(x.values, dtype=float),
            np.asarray(parts["shape_Y"].values, dtype=float),
            np.column_stack([parts["frame_X"].values, parts["frame_Y"].values]).astype(float),
            np.asarray(parts["frame_angle"].values, dtype=float)))
    return out
