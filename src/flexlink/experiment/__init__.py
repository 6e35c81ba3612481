"""Theory against experiment: measured data in, comparison and identified parameters out.

``files`` reads CSV/.mat columns, ``measurement`` maps and conditions them, ``vibration``
estimates free-vibration frequency and damping, ``comparison`` runs a scenario driven by measured
joint angles and scores it, ``parameters`` and ``identification`` identify parameters, ``report`` writes
the output folders, ``commands`` is the command line. Method and keys: docs/experiment.md.
"""

from __future__ import annotations

import importlib
from typing import Any

_EXPORTS = {
    "read_columns": "files", "MeasurementError": "files",
    "MeasurementSpec": "measurement", "Measurement": "measurement",
    "MeasurementWarning": "measurement", "condition": "measurement",
    "parse_spec": "measurement",
    "dominant_mode": "vibration", "damped_modes": "vibration",
    "compare": "comparison", "Comparison": "comparison", "SignalMetrics": "comparison",
    "fit": "identification", "FitResult": "identification", "parse_parameter": "parameters",
    "load_experiment": "loading",
}
__all__ = ["Comparison", "FitResult", "Measurement", "MeasurementError", "MeasurementSpec",
           "MeasurementWarning", "SignalMetrics", "compare", "condition", "damped_modes",
           "dominant_mode", "fit", "load_experiment", "parse_parameter", "parse_spec",
           "read_columns"]


def __getattr__(name: str) -> Any:
    # lazy, so that registering the commands keeps `flexlink --help` fast
    if name in _EXPORTS:
        return getattr(importlib.import_module(f".{_EXPORTS[name]}", __name__), name)
    raise AttributeError(f"module 'flexlink.experiment' has no attribute {name!r}")
