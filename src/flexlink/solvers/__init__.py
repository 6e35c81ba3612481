"""Time integrators. Each returns a `Solution`; the linear ones take a `LinearSystem`.

`PRESCRIBED_METHODS` maps every ``simulation.method`` (model.METHODS) to its integrator for
prescribed-joint runs of the first-order model, as scipy's ``solve_ivp`` looks a method up.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import numpy as np

from .lawson import integrate_lawson
from .magnus import integrate_magnus
from .ode import integrate_scipy
from .solution import Accuracy, GivenMatrices, LinearSystem, Progress, Solution, rigid_solution

LinearIntegrator = Callable[[LinearSystem, np.ndarray, float, float, Progress | None], Solution]

PRESCRIBED_METHODS: dict[str, LinearIntegrator] = {
    "lawson": integrate_lawson,
    "magnus": integrate_magnus,
    **{name: partial(integrate_scipy, method=name) for name in ("DOP853", "RK45", "Radau", "LSODA")},
}

__all__ = [
    "PRESCRIBED_METHODS",
    "Accuracy",
    "GivenMatrices",
    "LinearIntegrator",
    "LinearSystem",
    "Solution",
    "integrate_lawson",
    "integrate_magnus",
    "integrate_scipy",
    "rigid_solution",
]
