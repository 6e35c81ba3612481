"""Time integration of the assembled equations of motion."""

from .lawson import integrate_lawson
from .magnus import integrate_magnus
from .ode import SimulationError, integrate_second_order

METHODS = ("magnus", "lawson", "DOP853", "RK45", "Radau", "LSODA")

__all__ = ["METHODS", "SimulationError", "integrate_lawson", "integrate_magnus", "integrate_second_order"]
