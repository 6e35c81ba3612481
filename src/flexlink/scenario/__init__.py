"""Scenario files: TOML → validated `Scenario`, with every problem reported at once.

Public API: `load_scenario`, `scenario_from_dict`, `resolve_scenario_dict`, `ScenarioError`,
`load_paper_experiment`, `paper_experiment_path`. Every key, with its unit, default and
allowed values, is declared once in `flexlink.scenario.schema`; the key tables of
``docs/scenario.md``, which documents the file format, are generated from it.
"""

from __future__ import annotations

from .builtin import load_paper_experiment, paper_experiment_path, paper_experiment_text
from .errors import ScenarioError
from .load import flexlink_version, load_scenario, resolve_scenario_dict, scenario_from_dict

__all__ = [
    "ScenarioError",
    "flexlink_version",
    "load_paper_experiment",
    "load_scenario",
    "paper_experiment_path",
    "paper_experiment_text",
    "resolve_scenario_dict",
    "scenario_from_dict",
]
