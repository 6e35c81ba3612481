"""Theory against experiment: measured data in, comparison and identified parameters out.

``files`` reads CSV/.mat columns, ``measurement`` maps and conditions them, ``vibration``
estimates free-vibration frequency and damping, ``compare`` runs a scenario driven by measured
joint angles and scores it, ``fit`` identifies parameters, ``report`` writes the output folders.
Method and keys: docs/experiment.md.
"""

from .compare import Comparison, SignalMetrics, compare
from .files import MeasurementError, read_columns
from .fit import FitResult, fit
from .measurement import Measurement, MeasurementSpec, MeasurementWarning, condition
from .vibration import damped_modes, dominant_mode

__all__ = [
    "Comparison", "FitResult", "Measurement", "MeasurementError", "MeasurementSpec",
    "MeasurementWarning", "SignalMetrics", "compare", "condition", "damped_modes",
    "dominant_mode", "fit", "read_columns",
]
