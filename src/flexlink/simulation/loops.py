"""Closed loops on the forward path (first-order model): the tree's `ForwardSystem` with the
scenario's loop-closing joints (`dynamics.loops.LoopSystem`), integrated on the closures
(`solvers.loops.integrate_loops`); the closures' force channels and the joints' motor
torques without the constraint forces."""

from __future__ import annotations

import numpy as np

from ..channels.catalogue import closure_name
from ..dynamics import forward_kernel
from ..dynamics.forward import ForwardSystem
from ..dynamics.forward_outputs import ForwardOutputs
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


def closed_loop_outputs(system: ForwardSystem, solution: Solution, joint_forces: np.ndarray
                        ) -> ForwardOutputs:
    """The forward outputs of a closed-loop run at its solved states: the frames at the
    solved rigid motion and each joint's motor torque, its joint row of M ẍ + C ẋ + K x − f
    at the solved accelerations less the constraint forces' torque ``joint_forces`` (nt, N)
    on it. The tree's compiled outputs pass cannot serve: its rates leave the closures'
    forces out. The base is fixed, so there is no momentum."""
    nu = len(system.free)
    t = solution.t
    p, pd, pdd = system.rigid_state(t, solution.q[:, :nu], solution.q_dot[:, :nu],
                                    solution.q_ddot[:, :nu])
    z, zd, zdd = solution.q[:, nu:], solution.q_dot[:, nu:], solution.q_ddot[:, nu:]
    torques = forward_kernel.joint_torques(system, p, pd, pdd, z, zd, zdd) - joint_forces
    rates = np.hstack([solution.q_dot[:, :nu], solution.q_ddot[:, :nu], zd, zdd])
    return ForwardOutputs(rates, system.frames(p, pd, pdd), torques, None)
