"""Scenario plus measurement file in one call: what ``compare`` and ``fit`` start from."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..model import Scenario
from ..scenario.fields import ScenarioFile
from .files import MeasurementError, read_columns
from .measurement import Measurement, condition, parse_map_option, parse_spec


@dataclass
class Experiment:
    file: ScenarioFile  # the parsed scenario file: what fit parameters are paths into
    scenario: Scenario
    resolved: dict[str, Any]  # the scenario with every default filled in
    measurement: Measurement
    fit_table: dict[str, Any]  # the scenario's raw [fit] section ({} if none)


def load_experiment(scenario_path: str | Path, measured: str | Path | None = None,
                    maps: Sequence[str] = (), **overrides: Any) -> Experiment:
    """Read the scenario (with its ``[measurement]`` and ``[fit]`` sections) and the
    measurement file. ``maps`` are ``--map`` texts (they replace the section's columns);
    ``overrides`` set ``time_column``, ``time_offset`` or ``free_vibration_start`` (None:
    keep). ``measured`` defaults to ``[measurement] file`` (relative to the scenario)."""
    path = Path(scenario_path)
    file = ScenarioFile.read(path)
    raw = file.raw
    scenario = file.build()
    resolved = file.resolved()
    spec = parse_spec(raw.get("measurement"), scenario, f"{path} [measurement]")
    changes = {k: v for k, v in overrides.items() if v is not None}
    if maps:
        changes["columns"] = tuple(parse_map_option(m, scenario) for m in maps)
    spec = replace(spec, **changes)
    if measured is None:
        if spec.file is None:
            raise MeasurementError("no measurement file: give MEASURED.csv on the command line "
                                   f"or file = \"...\" in {path}'s [measurement] section")
        measured = path.parent / spec.file
    measured = Path(measured)
    measurement = condition(read_columns(measured), spec, scenario, str(measured))
    fit_table = raw.get("fit", {})
    if not isinstance(fit_table, Mapping):
        raise MeasurementError(f"{path}: [fit] must be a table")
    return Experiment(file, scenario, resolved, measurement, dict(fit_table))
