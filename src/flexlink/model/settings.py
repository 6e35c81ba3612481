"""Simulation settings and the allowed values of their choices.

The literal types are the one list of allowed values: the scenario schema, the solver table
and the generated docs read them from here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

ModelName = Literal["first_order", "nonlinear"]
# "lawson" and "magnus" integrate prescribed-joint runs; the others are scipy solve_ivp methods
MethodName = Literal["magnus", "lawson", "DOP853", "RK45", "Radau", "LSODA"]

MODELS: tuple[str, ...] = get_args(ModelName)
METHODS: tuple[str, ...] = get_args(MethodName)


@dataclass(frozen=True)
class SimulationSettings:
    """Time span and output grid (s), tolerances, model and integrator of one run."""

    t_end: float  # s
    dt_out: float  # s
    geometric_stiffening: bool = False
    rtol: float = 1e-6  # error relative to the peak of the displacements / velocities
    atol: float = 1e-12
    method: MethodName = "lawson"
    model: ModelName = "first_order"  # "nonlinear": large deflections (docs/nonlinear.md)
    step: float | None = None  # s, fixed step of the nonlinear model (None: step halving)
