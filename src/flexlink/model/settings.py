"""Simulation settings and the allowed values of their choices.

The literal types are the one list of allowed values: the scenario schema, the solver table
and the generated docs read them from here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal, get_args

ModelName = Literal["first_order", "nonlinear"]
# "lawson" and "magnus" integrate prescribed-joint runs; the others are scipy solve_ivp methods
MethodName = Literal["magnus", "lawson", "DOP853", "RK45", "Radau", "LSODA"]

# "rest": every link undeformed at rest at t = 0; "equilibrium": in static equilibrium with
# the loads at t = 0 (gravity, held joints)
InitialName = Literal["rest", "equilibrium"]

MODELS: tuple[str, ...] = get_args(ModelName)
INITIAL_STATES: tuple[str, ...] = get_args(InitialName)
METHODS: tuple[str, ...] = get_args(MethodName)

# The default simulation.rtol of a run whose scenario gives none: its time-integration error
# about a tenth of the model's own error on the validation cases or less. Per model
# (docs/nonlinear.md §4 for the nonlinear model; the first-order one reproduces the paper's
# published values to ~5e-7 with it), and for first-order forward runs (driven joints, moving
# base; docs/performance.md, "Tolerances of forward runs"): 1e-4 keeps their error at ≤ 1e-4
# of peak on displacements, angles and rates, against the first-order model's 1.7e-3–2.6e-3
# from the geometrically exact FE model at small deflection. Closed loops on the nonlinear
# model run on the same Radau IIA integrator, where rtol is the global error (as on the
# first-order forward runs), not the Gauss collocation's local one: 1e-4 keeps their
# deflection's integration error at a tenth of the model's own or less (docs/performance.md,
# "Closed loops on the nonlinear model"). Sliders on the nonlinear model on a fixed base
# (Gauss collocation): 1e-4 keeps every channel's integration error (hub angle and rate,
# travel and its rate, tip) at about a tenth of the model's own error against the converged
# FE model or less, the hub rate's being the largest (docs/nonlinear.md §4).
DEFAULT_RTOL: dict[str, float] = {"first_order": 1e-6, "nonlinear": 1e-5}
FORWARD_RTOL = 1e-4
NONLINEAR_SLIDER_RTOL = 1e-4


def default_rtol(model: str, forward: bool, closed: bool = False,
                 sliding: bool = False) -> float:
    """rtol of a run whose scenario gives none: by model, by whether it is a forward run,
    whether it closes loops (``closed``: the nonlinear model's loops run on Radau IIA) and
    whether a slider runs on the nonlinear model on a fixed base without controllers
    (``sliding``: Gauss collocation)."""
    if forward and (model == "first_order" or closed):
        return FORWARD_RTOL
    if forward and sliding and model == "nonlinear":
        return NONLINEAR_SLIDER_RTOL
    return DEFAULT_RTOL[model]


@dataclass(frozen=True)
class SimulationSettings:
    """Time span and output grid (s), tolerances, model and integrator of one run."""

    t_end: float  # s
    dt_out: float  # s
    geometric_stiffening: bool = True
    # error relative to the peak of the displacements / velocities; None: `default_rtol`
    # (the Scenario holding these settings fills it in)
    rtol: float | None = None
    atol: float = 1e-12
    method: MethodName = "lawson"
    model: ModelName = "first_order"  # "nonlinear": large deflections (docs/nonlinear.md)
    step: float | None = None  # s, fixed step of the nonlinear model (None: step halving)
    gravity: tuple[float, float] = (0.0, 0.0)  # m/s², uniform field in the base plane's axes
    initial: InitialName = "rest"

    def __post_init__(self) -> None:
        # The scenario loader reports these with every other problem; a model built in
        # Python gets the same words here instead of an error deep inside a run.
        for name in ("t_end", "dt_out", "atol"):
            value = getattr(self, name)
            if not value > 0:
                raise ValueError(f"simulation.{name} must be > 0, got {value!r}")
        if self.dt_out > self.t_end:
            raise ValueError(f"simulation.dt_out must be <= simulation.t_end ({self.t_end!r} s), "
                             f"got {self.dt_out!r}")
        if self.rtol is not None and not 0 < self.rtol <= 1e-2:
            raise ValueError(f"simulation.rtol must be in (0, 0.01], got {self.rtol!r}")
        if self.method not in METHODS:
            raise ValueError(f"simulation.method must be one of {', '.join(map(repr, METHODS))}, "
                             f"got {self.method!r}")
        if self.model not in MODELS:
            raise ValueError(f"simulation.model must be one of {', '.join(map(repr, MODELS))}, "
                             f"got {self.model!r}")
        if len(self.gravity) != 2 or not all(math.isfinite(g) for g in self.gravity):
            raise ValueError("simulation.gravity must be two finite numbers [gx, gy] (m/s²), "
                             f"got {self.gravity!r}")
        object.__setattr__(self, "gravity", (float(self.gravity[0]), float(self.gravity[1])))
        if self.initial not in INITIAL_STATES:
            raise ValueError("simulation.initial must be one of "
                             f"{', '.join(map(repr, INITIAL_STATES))}, got {self.initial!r}")
        if self.step is not None and not self.step > 0:
            raise ValueError(f"simulation.step must be > 0 s, got {self.step!r}")
