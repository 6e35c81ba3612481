"""The deformed shape of every link on a grid of points along it, for drawing the arm.

A `LinkShape` holds, at every output time, the global X and Y (m) of `POINTS` material points
at x = fraction·L along the link (fraction 0 … 1, so the last point is the tip) and the link's
zero-order (rigid) frame: origin X, Y (m) and angle (rad, global). The rigid frame is what a
deflection magnification m is measured from: drawn(x) = rigid(x) + m·(shape(x) − rigid(x)),
rigid(x) = origin + x·(cos angle, sin angle).

Each model path computes it from its own kinematics:

* first order (prescribed and forward): the point x of link k sits at
  origin_k + A(θ_k)·[x + ρx, ρy + x·θ1 + Φ(x)q_k] (channels/first_order.py, `link_points`);
* nonlinear: r(x) = Σ_j W_j(x) e(α_j), exact (dynamics/nonlinear.py, `position_rows`).

Like a `Channel`, the record is stored beside the run's channels (results.nc, results.mat),
never in results.csv.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, overload

import numpy as np

POINTS = 21  # points per link: 20 segments draw a 4-mode shape to well under a pixel
SHAPE_KIND = "shape"  # the `kind` attribute of the shape variables in results.nc


def fractions(points: int = POINTS) -> np.ndarray:
    """x/L of the stored points: 0 (the joint) … 1 (the tip), evenly spaced."""
    return np.linspace(0.0, 1.0, points)


@dataclass(frozen=True)
class LinkShape:
    """One link's deformed shape over time (global frame, m) and its rigid frame.

    ``X``, ``Y``: (nt, points) global position of the points at ``fraction``·``length``;
    ``origin``: (nt, 2) rigid frame origin (m); ``angle``: (nt,) rigid frame angle (rad)."""

    link: str
    length: float
    fraction: np.ndarray
    X: np.ndarray
    Y: np.ndarray
    origin: np.ndarray
    angle: np.ndarray

    def rigid(self) -> tuple[np.ndarray, np.ndarray]:
        """X, Y (nt, points) of the same points on the undeformed link in its rigid frame."""
        x = self.fraction * self.length
        return (self.origin[:, :1] + np.cos(self.angle)[:, None] * x,
                self.origin[:, 1:] + np.sin(self.angle)[:, None] * x)

    def magnified(self, factor: float) -> tuple[np.ndarray, np.ndarray]:
        """X, Y (nt, points) with the deflection from the rigid frame times ``factor``."""
        if factor == 1.0:
            return self.X, self.Y
        rx, ry = self.rigid()
        return rx + factor * (self.X - rx), ry + factor * (self.Y - ry)


def rigid_chain_frames(lengths: list[float], angles: np.ndarray
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Rigid frames of a serial chain on a fixed hub at the origin: origins (nt, N, 2), m,
    and absolute angles (nt, N), rad, from the joint angles (nt, N)."""
    theta = np.cumsum(angles, axis=1)
    steps = np.stack([np.cos(theta), np.sin(theta)], -1) * np.asarray(lengths)[None, :, None]
    origins = np.concatenate([np.zeros_like(steps[:, :1]), np.cumsum(steps, 1)[:, :-1]], 1)
    return origins, theta


class LazyShapes(Sequence[LinkShape]):
    """Every link's `LinkShape`, computed on first use: a run's shapes (5001 × 21 points a
    link for the paper, a sixth of its `simulate` time) are only read by the animation and
    the run folder's netCDF and .mat files. Pickles as the computed list."""

    def __init__(self, compute: Callable[[], Sequence[LinkShape]]) -> None:
        self._compute: Callable[[], Sequence[LinkShape]] | None = compute
        self._shapes: list[LinkShape] = []

    def _computed(self) -> list[LinkShape]:
        if self._compute is not None:
            self._shapes = list(self._compute())
            self._compute = None  # drop the solution's arrays the closure holds
        return self._shapes

    @overload
    def __getitem__(self, index: int) -> LinkShape: ...
    @overload
    def __getitem__(self, index: slice) -> list[LinkShape]: ...
    def __getitem__(self, index: int | slice) -> LinkShape | list[LinkShape]:
        return self._computed()[index]

    def __len__(self) -> int:
        return len(self._computed())

    def __iter__(self) -> Iterator[LinkShape]:
        return iter(self._computed())

    def __reduce__(self) -> tuple[Any, ...]:
        return (list, (self._computed(),))
