"""Closed loops on the forward path (first-order model): the tree's `ForwardSystem` with the
scenario's loop-closing joints (`dynamics.loops.LoopSystem`), integrated on the closures
(`solvers.loops.integrate_loops`); the closures' force channels and the joints' motor
torques without the constraint forces."""

from __future__ import annotations

import numpy as np

from ..channels.catalogue import closure_name
from ..dynamics import forward_kernel
from ..dynamics.forward import ForwardSystem
from ..dynamics.forward_outputs import ForwardOutputs, forward_outputs
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
    """The forward outputs of a closed-loop run at its solved states, from the tree's
    compiled outputs pass (`dynamics.forward_outputs`) at the solved accelerations (the
    tree's rates leave the closures' forces out, so they are given, not solved for): the
    frames at the solved rigid motion, the momentum of a moving base (the kinematics': the
    constraint forces do not enter it) and each joint's motor torque. With a prescribed
    joint the pass returns every joint's row of M ẍ + C ẋ + K x − f at the solved
    accelerations, less the constraint forces' torque ``joint_forces`` (nt, N) on it here;
    otherwise every joint row was solved for and the pass returns its applied torque, which
    that difference equals."""
    from ..dynamics._forward_numba import PRESCRIBED, workspace

    nu = len(system.free)
    t = solution.t
    data = forward_kernel.pack(system)
    states = np.hstack([solution.q[:, :nu], solution.q_dot[:, :nu], solution.q[:, nu:],
                        solution.q_dot[:, nu:], solution.extra])
    outputs = forward_outputs(system, data, workspace(data, len(system.servos)),
                              forward_kernel.inputs(system, t), states,
                              accelerations=solution.q_ddot)
    torques = outputs.torques
    if np.any(data.joint_kind[:len(system.chain.links)] == PRESCRIBED):
        torques -= joint_forces
    return outputs
