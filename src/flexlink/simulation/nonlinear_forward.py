"""Forward dynamics, nonlinear model (free or pinned base, a cart, driven joints):
NonlinearForwardSystem → Gauss collocation → channels."""

from __future__ import annotations

import numpy as np

from ..channels.catalogue import voltage_name
from ..channels.nonlinear_forward import forward_shapes, forward_values
from ..dynamics.nonlinear_forward import NonlinearForwardSystem
from ..errors import StoppedRun
from ..model import Scenario
from ..solvers import Solution
from ..solvers.gauss_forward import solve_nonlinear_forward
from .cart import LAST, STEP, check_travel
from .common import PathRun, Progress
from .prismatic import check_travel as check_slider_travel


def nonlinear_forward_system(scenario: Scenario) -> NonlinearForwardSystem:
    """The nonlinear model of ``scenario`` with its rigid coordinates (driven joints, a
    moving base)."""
    settings = scenario.settings
    return NonlinearForwardSystem(scenario.chain, scenario.base, scenario.actuators,
                                  gravity=settings.gravity, initial=settings.initial)


def run_nonlinear_forward(scenario: Scenario, t: np.ndarray, on_progress: Progress,
                          with_shapes: bool = True, step_ends: list | None = None) -> PathRun:
    """The nonlinear model's forward run; ``step_ends`` as `solve_nonlinear_forward`'s."""
    settings = scenario.settings
    system = nonlinear_forward_system(scenario)
    system.stage_inputs(t)  # fails early if a measured motion or table does not cover t
    closures: dict = {}
    constraint_torques = None
    loop = None
    try:  # a run stopped outside a travel: the travel's error, named (check_travel_at_stop)
        if scenario.closures or scenario.controllers:
            # loops closed by constraints or sampled controllers (simulation/nonlinear_loops.py)
            from .forward import sampled_loop
            from .nonlinear_loops import nonlinear_loop_solution

            if scenario.controllers:  # sensors read as rows over q (first-order modes)
                loop = sampled_loop(scenario, system.loads, t, "nonlinear")
            solution, closure_values, constraint_torques, closures = nonlinear_loop_solution(
                scenario, system, t, on_progress, loop)
        else:
            solution = solve_nonlinear_forward(system, t, settings.rtol, settings.step,
                                               on_progress=on_progress, atol=settings.atol,
                                               step_ends=step_ends)
    except StoppedRun as stop:
        check_travel_at_stop(scenario, system, stop)
        raise
    y, v, a = system.from_solution(solution)
    if system.rail is not None:
        check_travel(scenario.base, t, system.rigid_state(t, y, v, a)[0][:, 0])
    if system.slides:
        check_slider_travel(system.chain.joints, t, system.rigid_state(t, y, v, a)[0],
                            system.n_base)
    values = nonlinear_forward_values(scenario, system, solution, constraint_torques)
    if scenario.closures:
        values.update(closure_values)
    if loop is not None:  # the held voltages replace the commanded ones
        from .forward import loop_values

        values.update(loop_values(scenario, loop, t))
    shapes = forward_shapes(system, t, y) if with_shapes else ()
    return PathRun(solution, values, shapes=shapes, metadata={
        "path": "forward", "elastic_coordinates": system.n,
        "rigid_coordinates": system.n_rigid,
        **({"controllers": len(scenario.controllers)} if loop else {}), **closures})


def check_travel_at_stop(scenario: Scenario, system: NonlinearForwardSystem,
                         stop: StoppedRun) -> None:
    """The travel's error (`simulation.cart.check_travel`, `prismatic.check_travel`) of a
    run that stopped with a cart or a slider outside its travel, read on its last state
    (``stop.y``: [q, p_free, σ], then possibly the rates)."""
    if stop.y is None:
        return
    y = np.asarray(stop.y, dtype=float)[None, :system.n_y]
    if not np.all(np.isfinite(y)):
        return
    times = np.array([stop.t])
    p = system.rigid_state(times, y, np.zeros_like(y), np.zeros_like(y))[0]
    where = STEP if stop.left_travel else LAST
    check_travel(scenario.base, times, p[:, 0], where)
    check_slider_travel(system.chain.joints, times, p, system.n_base, where)


def nonlinear_forward_values(scenario: Scenario, system: NonlinearForwardSystem,
                             solution: Solution, constraint_torques: np.ndarray | None = None
                             ) -> dict[str, np.ndarray]:
    """The channels of a nonlinear forward run from its solution at the output times
    (without the closures' own channels)."""
    t = solution.t
    y, v, a = system.from_solution(solution)
    values = forward_values(system, t, y, v, a, scenario.sensors, constraint_torques)
    volts = system.loads.voltages(t)  # open loop: the commanded voltages, clipped
    values.update({voltage_name(a.name): volts[:, j] for j, a in enumerate(system.actuators)})
    return values
