"""Closed loops on the nonlinear forward path: the tree's `NonlinearForwardSystem` with the
scenario's loop-closing joints (`dynamics.nonlinear_loops.NonlinearLoopSystem`: exact
closures on the deformed arcs), integrated on the closures
(`solvers.nonlinear_loops.integrate_nonlinear_loops`); the closures' force channels and
metadata as on the first-order path (`simulation/loops.py`)."""

from __future__ import annotations

import numpy as np

from ..dynamics.nonlinear_forward import NonlinearForwardSystem
from ..dynamics.nonlinear_loops import NonlinearLoopSystem
from ..model import Scenario
from ..solvers import Solution
from ..solvers.gauss_sampled import SampledLoop
from ..solvers.nonlinear_loops import integrate_nonlinear_loops
from .common import Progress
from .loops import closure_metadata, closure_values


def nonlinear_loop_solution(scenario: Scenario, system: NonlinearForwardSystem,
                            t: np.ndarray, on_progress: Progress,
                            loop: SampledLoop | None = None
                            ) -> tuple[Solution, dict[str, np.ndarray], np.ndarray, dict]:
    """The Solution on the closed loops, the closures' channel values, the constraint
    forces' torque on each joint (nt, N; N·m: left out of the motor torques) and metadata
    (the largest closure residual, m, and relative to the loop's size); ``loop``: the
    scenario's sampled controllers. Without closures (controllers on an open tree) the
    same kernel integrates the tree alone: no closure channels or metadata, zero
    constraint torques."""
    loops = NonlinearLoopSystem(system, scenario.closures)
    settings = scenario.settings
    run = integrate_nonlinear_loops(loops, t, settings.rtol, settings.atol, on_progress, loop)
    if loops.first_order is None:  # an open tree under sampled controllers: no closures
        return run.solution, {}, run.joint_forces, {}
    return (run.solution, closure_values(scenario, loops.first_order, run.multipliers),
            run.joint_forces, closure_metadata(loops.first_order, run.residual))
