"""Time integration of the assembled equations of motion."""

from .ode import SimulationError, integrate_second_order

__all__ = ["SimulationError", "integrate_second_order"]
