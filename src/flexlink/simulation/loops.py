"""Closed loops on the forward path (first-order model): the tree's `ForwardSystem` with the
scenario's loop-closing joints (`dynamics.loops.LoopSystem`), integrated on the closures
(`solvers.loops.integrate_loops`); the closures' force channels and the joints' motor
torques without the constraint forces."""

from __future__ import annotations

import numpy as np

from ..channels.catalogue import closure_name
from ..dynamics import forward_kernel
from ..dynamics.forward import ForwardSystem, momentum
from ..dynamics.forward_outputs import ForwardOutputs
from ..dynamics.loops import LoopSystem
from ..model import Scenario
from ..solvers import Solution
from ..solvers.gauss_sampled import SampledLoop
from ..solvers.loops import integrate_loops
from .common import Progress


def closed_loop_solution(scenario: Scenario, system: ForwardSystem, t: np.ndarray,
                         on_progress: Progress, loop: SampledLoop | None = None,
                         steps: list | None = None
                         ) -> tuple[Solution, dict[str, np.ndarray], np.ndarray, dict]:
    """The Solution on the closed loops, the closures' channel values, the constraint
    forces' torque on each joint's row (nt, N; subtract it from the equations' joint row
    for the motor's torque) and metadata (the largest closure residual, m, and relative to
    the loop's size); ``loop``: the scenario's sampled controllers; ``steps``: a list that
    receives the accepted steps (`solvers.radau.integrate_radau`)."""
    loops = LoopSystem(system, scenario.closures)
    settings = scenario.settings
    run = integrate_loops(loops, t, settings.rtol, settings.atol, on_progress, loop, steps)
    return (run.solution, closure_values(scenario, loops, run.multipliers), run.joint_forces,
            closure_metadata(loops, run.residual))


def closure_values(scenario: Scenario, loops: LoopSystem, multipliers: np.ndarray
                   ) -> dict[str, np.ndarray]:
    """The closures' force channels (N) from the multipliers λ (nt, n_c) of either model."""
    values: dict[str, np.ndarray] = {}
    for i, c in enumerate(scenario.closures):
        row = int(loops.data.row[i])
        if c.kind == "revolute":
            values[closure_name(c.name, "force_x")] = multipliers[:, row]
            values[closure_name(c.name, "force_y")] = multipliers[:, row + 1]
        else:
            values[closure_name(c.name, "normal_force")] = multipliers[:, row]
    return values


def closure_metadata(loops: LoopSystem, residual: np.ndarray) -> dict:
    """The largest closure residual of a run (m, and relative to the loop's size) and the
    dependent joints."""
    largest = float(np.max(residual))
    system = loops.system
    dependent = [system.free[j] - system.n_base for j in loops.dep]
    return {"closure_residual": largest, "closure_residual_relative": largest / loops.size,
            "dependent_joints": " ".join(f"joint{k + 1}" for k in dependent)}


def closed_loop_outputs(system: ForwardSystem, solution: Solution, joint_forces: np.ndarray
                        ) -> ForwardOutputs:
    """The forward outputs of a closed-loop run at its solved states: the frames at the
    solved rigid motion and each joint's motor torque, its joint row of M ẍ + C ẋ + K x − f
    at the solved accelerations less the constraint forces' torque ``joint_forces`` (nt, N)
    on it. The tree's compiled outputs pass cannot serve: its rates leave the closures'
    forces out. A moving base's momentum is the kinematics' (`dynamics.forward.momentum`):
    the constraint forces do not enter it."""
    nu = len(system.free)
    t = solution.t
    p, pd, pdd = system.rigid_state(t, solution.q[:, :nu], solution.q_dot[:, :nu],
                                    solution.q_ddot[:, :nu])
    z, zd, zdd = solution.q[:, nu:], solution.q_dot[:, nu:], solution.q_ddot[:, nu:]
    torques = forward_kernel.joint_torques(system, p, pd, pdd, z, zd, zdd) - joint_forces
    rates = np.hstack([solution.q_dot[:, :nu], solution.q_ddot[:, :nu], zd, zdd])
    momenta = None if system.base.kind == "fixed" else momentum(system, p, pd, z, zd)
    return ForwardOutputs(rates, system.frames(p, pd, pdd), torques, momenta)
