"""Frozen-time modes along a manoeuvre: natural frequencies, damping ratios and mode shapes
of the linearised plant at each time of a run, or at rest on a grid of joint angles.

At each point the plant's A (`linearize`) is decomposed; every oscillatory pole pair λ gives
f = |λ|/2π (Hz) and ζ = −Re λ/|λ|; its eigenvector's modal coordinates give the shape: each
link's elastic deflection w_k(x) = Φ_k(x) q_k in its clamped frame, on a grid of points,
turned real (phase of the largest deflection) and scaled to a largest |w| of 1. Modes are
sorted by frequency at each point (no tracking through crossings). Rigid-body modes (a free
joint or base) and real poles (servos) are left out.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from ..model import Scenario
from ..options import check_size
from .linear import LinearPlant
from .linearization import forward_plant, forward_system, linearize, run_states
from .operating_point import Configuration, held_scenario, parse_at

POINTS = 41  # points per link of the mode shapes
# Frozen-time points of one call: each is a linearisation and an eigen-decomposition, so more
# points than a figure can show cost minutes for nothing.
MAX_POINTS = 2000


@dataclass(frozen=True)
class FrozenModes:
    """Modes at ``values`` of ``coordinate`` ("time" in s, or a joint's name: angle in deg).

    frequency_hz, damping_ratio: (n_points, n_modes); shapes: (n_points, n_modes, n_links,
    POINTS) deflections, largest |w| = 1; x: (n_links, POINTS) m from each joint; links: names.
    ``configurations``: the joint angles (deg) at each point, (n_points, n_joints); a
    slider's: its constant link angle."""

    coordinate: str
    values: np.ndarray
    frequency_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    x: np.ndarray
    links: tuple[str, ...]
    configurations: np.ndarray

    @property
    def unit(self) -> str:
        return "s" if self.coordinate == "time" else "deg"

    def variables(self) -> dict[str, tuple[tuple[str, ...], np.ndarray, str, str]]:
        """Name → (dimensions, values, UDUNITS unit, description) of every array: the data
        of `to_dataset` and of the modes.npz file (`to_npz`), under modes.npz's names."""
        dim = self.coordinate
        what = "time of the run" if dim == "time" else f"angle of {dim}"
        return {
            "values": ((dim,), self.values, self.unit, f"the points: {what}"),
            "frequency_hz": ((dim, "mode"), self.frequency_hz, "Hz",
                             "natural frequency, modes ascending at each point"),
            "damping_ratio": ((dim, "mode"), self.damping_ratio, "1", "damping ratio"),
            "shapes": ((dim, "mode", "link", "point"), self.shapes, "1",
                       ("deflection of each link in its clamped frame at x, scaled to a "
                        "largest |w| of 1 per mode")),
            "x": (("link", "point"), self.x, "m", "distance along each link from its joint"),
            "links": (("link",), np.array(self.links), "", "link names"),
            "joint_angles_deg": ((dim, "joint"), self.configurations, "degree",
                                 "joint angles at each point (joint 1 first)"),
        }

    def to_dataset(self) -> Any:
        """An xarray Dataset (dimensions: the coordinate, mode, link, point)."""
        import xarray as xr

        names = {"frequency_hz": "frequency", "damping_ratio": "damping_ratio",
                 "shapes": "shape", "x": "x", "joint_angles_deg": "joint_angle"}
        data = {new: (dims, values, {"units": unit, "long_name": text})
                for old, (dims, values, unit, text) in self.variables().items()
                if (new := names.get(old))}
        mode = np.arange(1, self.frequency_hz.shape[1] + 1)
        dim = self.coordinate
        return xr.Dataset(data, coords={dim: (dim, self.values, {"units": self.unit}),
                                        "mode": mode, "link": list(self.links)})

    def to_npz(self, path: Path | str, description: Mapping[str, Any]) -> Path:
        """Write the arrays of `variables` to ``path`` (.npz), with ``coordinate`` (the
        points' dimension), ``variables`` (JSON text: name → dims, units, long_name, as the
        ``variables`` of a results.mat) and ``description`` (JSON text of ``description``)."""
        path = Path(path)
        variables = self.variables()
        meta = {name: {"dims": list(dims), "units": unit, "long_name": text}
                for name, (dims, _, unit, text) in variables.items()}
        np.savez(path, coordinate=np.array(self.coordinate),
                 **{name: values for name, (_, values, _, _) in variables.items()},
                 variables=np.array(json.dumps(meta)),
                 description=np.array(json.dumps(dict(description))))
        return path

    def table(self) -> tuple[list[str], np.ndarray]:
        """Header and rows of a CSV: the coordinate, then f_i (Hz), then ζ_i."""
        n = self.frequency_hz.shape[1]
        header = [f"{self.coordinate}_{self.unit}"] + [f"f{i + 1}_Hz" for i in range(n)] + [
            f"zeta{i + 1}" for i in range(n)]
        return header, np.column_stack([self.values, self.frequency_hz, self.damping_ratio])


def frozen_modes(scenario: Scenario | str | PathLike[str],
                 times: Sequence[float] | np.ndarray | None = None,
                 angles: Mapping[str, Sequence[float]] | None = None,
                 count: int | None = None) -> FrozenModes:
    """Modes over ``times`` (s) of the scenario's run, or at rest over a grid of joint angles
    ``angles = {"joint2": [0, 10, …, 90]}`` (deg; several joints: equal lengths, zipped;
    other joints at their t = 0 angle). Neither: 101 times over the run. ``count``: the
    lowest modes kept (default: as many as every point has). ``scenario``: a `Scenario`, or
    the path of a scenario file."""
    from ..scenario.load import as_scenario

    scenario = as_scenario(scenario, "frozen_modes")
    if times is not None and angles is not None:
        raise ValueError("give times or angles, not both")
    if count is not None and count < 1:
        raise ValueError(f"count: the number of modes kept must be >= 1, got {count}")
    plants: list[tuple[LinearPlant, Scenario]]
    if angles is not None:
        coordinate, values, plants = _over_angles(scenario, angles)
    else:
        if times is None:
            times = np.linspace(0.0, scenario.settings.t_end, 101)
        values = np.asarray(times, dtype=float)
        if values.ndim != 1 or values.size == 0:
            raise ValueError("times: give a non-empty list of times in s")
        check_size("times", values.size, MAX_POINTS, "points (one linearisation each)")
        for t in values:
            try:
                parse_at(scenario, float(t))  # the range check, before any run
            except ValueError as exc:  # named as the caller gave it: times (--times)
                raise ValueError(f"times (--times): {exc}".replace(": at = ", ": ")) from None
        coordinate, plants = "time", _over_times(scenario, values)
    return _collect(scenario, coordinate, values, plants, count)


def _over_angles(scenario: Scenario, angles: Mapping[str, Sequence[float]]
                 ) -> tuple[str, np.ndarray, list[tuple[LinearPlant, Scenario]]]:
    if not angles:
        raise ValueError("angles: name at least one joint, e.g. {'joint2': [0, 45, 90]}")
    grids = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in angles.items()}
    sizes = {g.size for g in grids.values()}
    if len(sizes) != 1 or 0 in sizes:
        raise ValueError("angles: every joint's grid needs the same, non-zero length")
    n = sizes.pop()
    check_size("angles", n, MAX_POINTS, "points (one linearisation each)")
    plants = []
    for i in range(n):
        point = parse_at(scenario, {k: float(g[i]) for k, g in grids.items()})
        assert isinstance(point, Configuration)
        held = held_scenario(scenario, point)
        plants.append((linearize(held, at=point.describe_at()), held))
        if i == 0:
            _check_independent(plants[0][0], list(grids), len(scenario.chain.joints))
    first = next(iter(grids))
    return first, grids[first], plants


def _check_independent(plant: LinearPlant, gridded: list[str], joints: int) -> None:
    """ValueError where every gridded joint is a dependent joint of a closed loop
    (``plant``'s operating point): their angles are only guesses the loop closes from, so
    every point of the grid would be the same configuration under other labels. Guesses
    zipped with a grid of an independent joint are welcome."""
    dependent = str(plant.operating_point.get("dependent_joints", "")).split()
    bad = [k for k in gridded if k in dependent]
    if bad and len(bad) == len(gridded):
        free = [f"joint{k + 1}" for k in range(joints) if f"joint{k + 1}" not in dependent]
        raise ValueError(
            f"angles (--grid): {', '.join(bad)} {'is a' if len(bad) == 1 else 'are'} "
            f"dependent joint{'' if len(bad) == 1 else 's'} of the closed loop, whose angles "
            f"follow from {', '.join(free) or 'the other joints'}: every point of the grid "
            f"would be the same configuration; grid {' or '.join(free) or 'another joint'} "
            "(with these as the loop's guesses, zipped, if you like)")


def _over_times(scenario: Scenario, times: np.ndarray) -> list[tuple[LinearPlant, Scenario]]:
    if not scenario.is_forward:
        return [(linearize(scenario, at=float(t)), scenario) for t in times]
    order = np.argsort(times)
    system = forward_system(scenario)
    plants: list[tuple[LinearPlant, Scenario] | None] = [None] * times.size
    if scenario.closures:  # one closed-loop run, a plant in independent coordinates each
        from ..dynamics.loops import LoopSystem
        from .loop_plant import loop_plant, loop_states

        closed = loop_states(scenario, LoopSystem(system, scenario.closures), times[order])
        for i, y in zip(order, closed):
            plants[i] = (loop_plant(scenario, float(times[i]), float(times[i]), y), scenario)
        return [p for p in plants if p is not None]
    states = run_states(scenario, system, times[order])
    for i, state in zip(order, states):
        plants[i] = (forward_plant(scenario, float(times[i]), float(times[i]), state), scenario)
    return [p for p in plants if p is not None]


def _collect(scenario: Scenario, coordinate: str, values: np.ndarray,
             plants: list[tuple[LinearPlant, Scenario]], count: int | None) -> FrozenModes:
    links = scenario.chain.links
    x = np.stack([np.linspace(0.0, link.length, POINTS) for link in links])
    found = [plant.modes() for plant, _ in plants]
    available = min(f[0].size for f in found)
    n = available if count is None else min(count, available)
    if n == 0:
        if not any(link.modes for link in links):
            raise ValueError("no elastic mode to report: every link is rigid (links[k].rigid "
                             "= true)")
        raise ValueError("no oscillatory mode at some point (rigid links?)")
    freq = np.stack([f[0][:n] for f in found])
    zeta = np.stack([f[1][:n] for f in found])
    shapes = np.zeros((len(plants), n, len(links), POINTS))
    bases: dict[int, list[np.ndarray]] = {}
    for i, ((plant, held), (_, _, vec)) in enumerate(zip(plants, found)):
        phis = bases.setdefault(id(held), _basis(held, x))
        for j in range(n):
            shapes[i, j] = _shape(plant, vec[:, j], links, phis)
    configurations = np.stack([_angles_deg(scenario, plant) for plant, _ in plants])
    return FrozenModes(coordinate, values, freq, zeta, shapes, x,
                       tuple(link.name for link in links), configurations)


def _basis(scenario: Scenario, x: np.ndarray) -> list[np.ndarray]:
    """Φ_k(x) (POINTS, n_k) of each link in the basis the plant's coordinates use."""
    from ..dynamics.first_order import chain_modal_data

    data = chain_modal_data(scenario.chain, scenario.base)
    return [d.shapes.evaluate(x[k], 0) if d.n else np.zeros((x.shape[1], 0))
            for k, d in enumerate(data)]


def _shape(plant: LinearPlant, vector: np.ndarray, links: Sequence[Any],
           phis: list[np.ndarray]) -> np.ndarray:
    """Each link's deflection Φ_k q_k from a state eigenvector, real, largest |w| = 1."""
    index = {name: i for i, name in enumerate(plant.state_names)}
    w = np.zeros((len(links), POINTS), dtype=complex)
    for k, link in enumerate(links):
        q = np.array([vector[index[f"{link.name}_q{i + 1}"]] for i in range(link.modes)])
        if q.size:
            w[k] = phis[k] @ q
    peak = w.flat[np.argmax(np.abs(w))]
    if peak == 0:
        return np.zeros(w.shape)
    real = (w / peak).real
    return real / np.abs(real).max()


def _angles_deg(scenario: Scenario, plant: LinearPlant) -> np.ndarray:
    """The joint angles (deg) the plant is about, from its operating point description; a
    slider's is its constant angle γ (`PrismaticJoint.link_angle`: its travel is no angle)."""
    op = plant.operating_point
    n = len(scenario.chain.joints)
    if "time_s" not in op:
        return np.array([op[f"joint{k + 1}_deg"] for k in range(n)])
    point = parse_at(scenario, float(op["time_s"]))
    assert not isinstance(point, Configuration)
    from ..model import PrismaticJoint, is_driven

    out = np.zeros(n)
    for k, joint in enumerate(scenario.chain.joints):
        name = f"joint{k + 1}_angle"
        if isinstance(joint, PrismaticJoint):
            out[k] = math.degrees(joint.link_angle)
        elif name in op:
            out[k] = math.degrees(op[name])
        elif not is_driven(joint):
            out[k] = math.degrees(float(np.ravel(joint.evaluate(np.array([point]))[0])[0]))
    return out
