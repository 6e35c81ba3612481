"""Closed loops on the forward path (first-order model): the tree's `ForwardSystem` with the
scenario's loop-closing joints (`dynamics.loops.LoopSystem`), integrated on the closures
(`solvers.loops.integrate_loops`); the closures' force channels and the joints' motor
torques without the constraint forces."""

from __future__ import annotations

import numpy as np

from ..channels.catalogue import closure_name
from ..dynamics.forward import ForwardSystem
from ..dynamics.loops import LoopSystem
from ..model import Scenario
from ..solvers import Solution
from ..solvers.loops import integrate_loops
from .common import Progress


def closed_loop_solution(scenario: Scenario, system: ForwardSystem, t: np.ndarray,
                         on_progress: Progress
                         ) -> tuple[Solution, dict[str, np.ndarray], np.ndarray, dict]:
    """The Solution on the closed loops, the closures' channel values, the constraint
    forces' torque on each joint's row (nt, N; subtract it from the equations' joint row
    for the motor's torque) and metadata (the largest closure residual, m, and relative to
    the loop's size)."""
    loops = LoopSystem(system, scenario.closures)
    settings = scenario.settings
    run = integrate_loops(loops, t, settings.rtol, settings.atol, on_progress)
    values: dict[str, np.ndarray] = {}
    for i, c in enumerate(scenario.closures):
        row = int(loops.data.row[i])
        if c.kind == "revolute":
            values[closure_name(c.name, "force_x")] = run.multipliers[:, row]
            values[closure_name(c.name, "force_y")] = run.multipliers[:, row + 1]
        else:
            values[closure_name(c.name, "normal_force")] = run.multipliers[:, row]
    residual = float(np.max(run.residual))
    dependent = [system.free[j] - system.n_base for j in loops.dep]
    return run.solution, values, run.joint_forces, {
        "closure_residual": residual, "closure_residual_relative": residual / loops.size,
        "dependent_joints": " ".join(f"joint{k + 1}" for k in dependent)}
