"""The built-in scenario of Choi & Kwak (2016), shipped as package data."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path

from ..model import Scenario
from .load import parse_toml, scenario_from_dict

_RESOURCE = ("data", "paper_experiment.toml")
_SOURCE = "paper_experiment.toml (built in)"


def paper_experiment_path() -> Path:
    """Where the built-in paper scenario file is installed."""
    resource = files("flexlink").joinpath(*_RESOURCE)
    return resource if isinstance(resource, Path) else Path(str(resource))


def paper_experiment_text() -> str:
    """The built-in paper scenario as TOML text (with its comments), ready to copy and edit."""
    return files("flexlink").joinpath(*_RESOURCE).read_text(encoding="utf-8")


def load_paper_experiment() -> Scenario:
    """The two-link experiment of the paper (Table 1, Figs. 7–9) as a `Scenario`."""
    raw = parse_toml(paper_experiment_text(), _SOURCE)
    return scenario_from_dict(raw, base_dir=paper_experiment_path().parent,
                              name="paper-experiment", source=_SOURCE)
