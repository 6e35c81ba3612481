"""Prescribed joint motions: analytic profiles and measured angle histories.

Every class implements ``flexlink.model.JointMotion``: ``evaluate(t)`` → angle (rad),
rate (rad/s), acceleration (rad/s²). Constructors take degrees. See docs/motion.md.
"""

from .measured import MeasuredMotion
from .profiles import Cycloidal, Hold, Quintic, Sequence, Spinup

__all__ = ["Cycloidal", "Hold", "MeasuredMotion", "Quintic", "Sequence", "Spinup"]
