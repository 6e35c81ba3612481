"""Sweep files: a sweep definition in TOML, to keep beside the results and run again.

    base = "my_arm.toml"          # a scenario file, relative to this file; or "paper"
    samples = 100                 # random draws (with [random])
    seed = 1
    sampler = "random"            # or "lhs"
    channels = ["link1_tip_acceleration"]   # optional
    summaries = ["residual:link2_tip_deflection:after=3"]   # optional per-case metrics
    histories = true              # optional; false keeps only the summaries

    [grid]
    "links[0].EI" = [250.0, 300.0, 350.0]
    "joints[0].motion[0].start" = "linspace:0.2:0.8:4"

    [random]
    "joints[0].motion[0].duration" = "uniform:0.8:1.2"

Keys with brackets must be quoted in TOML. Every problem is reported at once (SweepError).
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from ..scenario import ScenarioError, paper_experiment_path
from ..scenario.errors import Problems, describe
from ..scenario.load import read_toml
from .errors import SweepError
from .parameters import SAMPLERS, grid_values, random_distribution

KEYS = ("base", "samples", "seed", "sampler", "channels", "summaries", "histories", "grid",
        "random")


def read_sweep_file(path: str | Path) -> dict[str, Any]:
    """The keyword arguments of `flexlink.sweep` that a sweep file defines."""
    path = Path(path)
    try:
        raw = read_toml(path)
    except ScenarioError as exc:
        raise SweepError(_in_file(path, exc.problems)) from None
    p = Problems()
    p.unknown_keys(raw, KEYS, "", meant={"scenario": "base"})  # base: the scenario swept
    where = "sweep"  # messages read "sweep.samples must be …", prefixed with the file
    base_name = p.string(raw, "base", where)
    out: dict[str, Any] = {
        "samples": p.integer(raw, "samples", where, ge=1, le=10**9, default=None),
        "seed": p.integer(raw, "seed", where, ge=0, le=2**63 - 1, default=None),
        "sampler": p.string(raw, "sampler", where, choices=SAMPLERS, default="random"),
    }
    if base_name is not None:
        out["base"] = (paper_experiment_path() if base_name == "paper"
                       else path.parent / base_name)
    channels = raw.get("channels")
    if channels is not None:
        if isinstance(channels, list) and channels and all(isinstance(c, str) for c in channels):
            out["channels"] = channels
        else:
            p.add(f"{where}.channels: expected an array of channel names, "
                  f"got {describe(channels)}")
    summaries = raw.get("summaries")
    if summaries is not None:
        if isinstance(summaries, list) and all(isinstance(c, str) for c in summaries):
            out["summaries"] = summaries
        else:
            p.add(f"{where}.summaries: expected an array of texts such as "
                  f"\"peak:link2_tip_deflection\", got {describe(summaries)}")
    histories = raw.get("histories", True)
    if isinstance(histories, bool):
        out["histories"] = histories
    else:
        p.add(f"{where}.histories: expected true or false, got {describe(histories)}")
    out["grid"], out["random"] = [], []
    for section, build in (("grid", grid_values), ("random", random_distribution)):
        table = raw.get(section, {})
        if not isinstance(table, dict):
            p.add(f"{where}.{section}: expected a table [{section}], got {describe(table)}")
            continue
        for key, spec in table.items():
            try:
                out[section].append(build(key, spec))
            except SweepError as exc:
                p.messages += exc.problems
    if p:
        raise SweepError(_in_file(path, p.messages))
    return out


def _in_file(path: Path, problems: list[str]) -> list[str]:
    """Problems prefixed with the sweep file (unless they name it already)."""
    return [m if m.startswith(str(path)) else f"{path}: {m}" for m in problems]


@contextlib.contextmanager
def sweep_file_errors(path: str | Path) -> Iterator[None]:
    """Name the sweep file in the problems of a sweep it defines: a SweepError's (an unknown
    field path, a missing samples, an invalid case) and its base scenario's."""
    path = Path(path)
    try:
        yield
    except SweepError as exc:
        raise SweepError(_in_file(path, exc.problems)) from None
    except ScenarioError as exc:
        base = f"base scenario {exc.source}" if exc.source else "base scenario"
        raise SweepError([f"{path}: {base}: {m}" for m in exc.problems]) from None
