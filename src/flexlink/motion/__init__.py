"""Prescribed joint motions: analytic profiles and measured angle histories.

Every class implements ``flexlink.model.JointMotion``: ``evaluate(t)`` → angle (rad),
rate (rad/s), acceleration (rad/s²). Constructors take degrees. See docs/motion.md.
"""

from .harmonic import Harmonic
from .measured import MeasuredMotion
from .profiles import Cycloidal, Hold, Quintic, Sequence, Spinup
from .shaped import Shaped
from .shapers import ImpulseSequence
from .travel import Travel

__all__ = ["Cycloidal", "Harmonic", "Hold", "ImpulseSequence", "MeasuredMotion", "Quintic",
           "Sequence", "Shaped", "Spinup", "Travel"]
