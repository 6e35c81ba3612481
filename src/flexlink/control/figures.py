"""Figures of a plant and of modes along a manoeuvre: Bode plots of chosen input/output pairs,
frequency against time or joint angle, mode shapes. matplotlib's object interface (no
pyplot state, no display needed)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .linear import LinearPlant
from .modes import FrozenModes

if TYPE_CHECKING:
    from ..model import Scenario


def _figure(width: float, height: float):  # type: ignore[no-untyped-def]
    from matplotlib.figure import Figure

    return Figure(figsize=(width, height), layout="constrained")


def default_band(plant: LinearPlant) -> np.ndarray:
    """Frequencies (Hz) from a decade below the lowest to a few times the highest mode."""
    f = plant.modes()[0]
    lo = max(f.min() / 10, 1e-2) if f.size else 0.1
    hi = min(3 * f.max(), 1e4) if f.size else 100.0
    return np.logspace(np.log10(lo), np.log10(max(hi, 10 * lo)), 600)


DEFAULT_PAIRS = 4  # pairs of a Bode plot when none are given
BASE_LOADS = ("base_force_x", "base_force_y", "base_moment")


def default_pairs(plant: LinearPlant, scenario: Scenario | None = None
                  ) -> list[tuple[str, str]]:
    """The Bode plot's pairs when none are given: the first input the scenario acts through
    that reaches an output, to up to `DEFAULT_PAIRS` of the outputs it reaches (not a zero
    transfer on `default_band`): the sensors first, then the joints', base's and loops'
    outputs (positions and torques before rates), the link tips' global X, Y last.

    The scenario acts through every input but a free or pinned base's force or moment that
    its ``[[base.loads]]`` do not apply; those come after, the moment before the forces (a
    free base's forces alone only translate it, rigidly). Without ``scenario``: the inputs
    and outputs in the plant's order."""
    if not plant.input_names or not plant.output_names:
        return []
    zero = plant.zero_transfers(default_band(plant))
    loaded = _loaded_base_inputs(scenario)
    inputs = sorted(range(len(plant.input_names)),
                    key=lambda j: _input_rank(plant.input_names[j], loaded))
    ranks = _output_ranks(plant.output_names, scenario)
    outputs = sorted(range(len(plant.output_names)), key=lambda i: ranks[i])
    for j in inputs:
        reached = [plant.output_names[i] for i in outputs if not zero[i, j]]
        if reached:
            return [(plant.input_names[j], y) for y in reached[:DEFAULT_PAIRS]]
    first = plant.input_names[inputs[0]]
    return [(first, plant.output_names[i]) for i in outputs[:DEFAULT_PAIRS]]


def _loaded_base_inputs(scenario: Scenario | None) -> set[str] | None:
    """The base's load inputs the scenario's base loads apply (None: no base, or unknown)."""
    base = None if scenario is None else scenario.base
    if base is None:
        return None
    from ..model.histories import ZERO

    loaded = set()
    for load in base.loads:
        x, y = load.force_x != ZERO, load.force_y != ZERO
        if load.frame == "body" and (x or y):  # components along the turning body's axes
            x = y = True
        loaded |= {name for name, on in (("base_force_x", x), ("base_force_y", y)) if on}
        if load.moment != ZERO or ((x or y) and tuple(load.point) != (0.0, 0.0)):
            loaded.add("base_moment")
    return loaded


def _input_rank(name: str, loaded: set[str] | None) -> int:
    if loaded is None or name not in BASE_LOADS or name in loaded:
        return 0
    return 1 if name == "base_moment" else 2


def _output_ranks(names: Sequence[str], scenario: Scenario | None) -> list[int]:
    """0 sensors, 1 positions, angles, torques and forces, 2 rates, 3 link tips' X, Y."""
    if scenario is None:
        return [1] * len(names)
    from ..channels import ChannelKind
    from ..channels.catalogue import catalogue

    channels = {c.name: c for c in catalogue(scenario)}
    ranks = []
    for name in names:
        c = channels.get(name)
        if c is None:
            ranks.append(1)
        elif c.kind == ChannelKind.SENSOR:
            ranks.append(0)
        elif c.kind == ChannelKind.TIP:
            ranks.append(3)
        else:
            ranks.append(2 if c.quantity.endswith("rate") or c.quantity == "velocity" else 1)
    return ranks


def bode_figure(plant: LinearPlant, pairs: Sequence[tuple[str, str]], path: Path,
                f_hz: np.ndarray | None = None) -> Path:
    """Magnitude (dB of output unit per input unit) and phase (deg) of each (input, output);
    a pair whose response is zero (`LinearPlant.zero_transfers`) is named in the legend, not
    drawn: its round-off stretched the magnitude axis to −6000 dB."""
    f = default_band(plant) if f_hz is None else np.asarray(f_hz, dtype=float)
    fig = _figure(7.5, 5.5)
    mag, phase = fig.subplots(2, 1, sharex=True)
    for k, (u, y) in enumerate(pairs):
        sub = plant.select([u], [y])
        unit = f"{sub.output_units[0]}/{sub.input_units[0]}"
        if sub.zero_transfers(f)[0, 0]:
            mag.plot([], [], color=f"C{k}", linestyle=":", label=f"{u} → {y}: zero")
            continue
        G = sub.frequency_response(f)[0, 0]
        mag.semilogx(f, 20 * np.log10(np.maximum(np.abs(G), 1e-300)), color=f"C{k}",
                     label=f"{u} → {y} [{unit}]")
        phase.semilogx(f, np.degrees(np.unwrap(np.angle(G))), color=f"C{k}")
    mag.set_xscale("log")
    mag.set_ylabel("magnitude (dB)")
    phase.set_ylabel("phase (deg)")
    phase.set_xlabel("frequency (Hz)")
    # above the panels: inside, it hid the curves it happened to cover
    fig.legend(loc="outside upper center", fontsize="small", ncols=2 if len(pairs) > 2 else 1)
    for ax, span in ((mag, MIN_SPAN_DB), (phase, MIN_SPAN_DEG)):
        ax.grid(True, which="both", alpha=0.3)
        _at_least(ax, span)
    mag.set_title(_title(plant))
    fig.savefig(path, dpi=120)
    return path


# The shortest spans of the Bode plot's axes: a flat response (a feedthrough, a static
# gain) would otherwise be drawn on an axis of 1e-11 dB with an offset, its round-off as
# features.
MIN_SPAN_DB, MIN_SPAN_DEG = 20.0, 20.0


def _at_least(ax: Any, span: float) -> None:
    """The axis' vertical range widened about its middle to ``span`` at least; no offset in
    its labels."""
    low, high = ax.get_ylim()
    if high - low < span:
        middle = 0.5 * (low + high)
        ax.set_ylim(middle - 0.5 * span, middle + 0.5 * span)
    ax.ticklabel_format(axis="y", useOffset=False)


def _title(plant: LinearPlant) -> str:
    op = plant.operating_point
    if "time_s" in op:
        return f"{op.get('scenario', '')} at t = {op['time_s']:g} s"
    joints = ", ".join(f"β{k[5:-4]} = {v:g}°" for k, v in op.items()
                       if k.startswith("joint") and k.endswith("_deg"))
    return f"{op.get('scenario', '')} at rest, {joints}"


def frequency_figure(modes: FrozenModes, path: Path, count: int = 6) -> Path:
    """Natural frequencies (Hz, log scale) of the lowest ``count`` modes against the time or
    the swept joint angle."""
    fig = _figure(7.0, 4.5)
    ax = fig.subplots()
    n = min(count, modes.frequency_hz.shape[1])
    for j in range(n):
        ax.plot(modes.values, modes.frequency_hz[:, j], marker="." if modes.values.size < 30
                else None, label=f"mode {j + 1}")
    ax.set_yscale("log")
    label = "time (s)" if modes.coordinate == "time" else f"{modes.coordinate} angle (deg)"
    ax.set_xlabel(label)
    ax.set_ylabel("natural frequency (Hz)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize="small", ncol=2)
    ax.set_title("frozen-time natural frequencies")
    fig.savefig(path, dpi=120)
    return path


def shapes_figure(modes: FrozenModes, path: Path, index: int = 0, count: int = 4) -> Path:
    """The lowest ``count`` mode shapes at point ``index``: each link's deflection (largest 1)
    against the arc length along the chain (joints marked)."""
    n = min(count, modes.shapes.shape[1])
    fig = _figure(7.0, 1.8 * n + 0.6)
    axes = np.atleast_1d(fig.subplots(n, 1, sharex=True))
    starts = np.concatenate([[0.0], np.cumsum(modes.x[:, -1])])
    for j, ax in enumerate(axes):
        for k, name in enumerate(modes.links):
            ax.plot(starts[k] + modes.x[k], modes.shapes[index, j, k], label=name)
        for s in starts[1:-1]:
            ax.axvline(s, color="0.5", lw=0.8, ls=":")
        ax.axhline(0.0, color="0.8", lw=0.8)
        ax.set_ylabel(f"{modes.frequency_hz[index, j]:.3g} Hz")
    axes[0].legend(fontsize="small")
    axes[-1].set_xlabel("arc length along the chain (m); each link's deflection in its frame")
    where = (f"t = {modes.values[index]:g} s" if modes.coordinate == "time"
             else f"{modes.coordinate} = {modes.values[index]:g}°")
    axes[0].set_title(f"mode shapes at {where}")
    fig.savefig(path, dpi=120)
    return path
