"""Time integration of the assembled equations of motion."""

from .magnus import integrate_magnus
from .ode import SimulationError, integrate_second_order

METHODS = ("magnus", "DOP853", "RK45", "Radau", "LSODA")

__all__ = ["METHODS", "SimulationError", "integrate_magnus", "integrate_second_order"]
