"""Forward dynamics, first-order model (free or pinned base, driven joints):
ForwardSystem → compiled RK4 loop (or solve_ivp, method = "DOP853", "Radau", …) → channels."""

from __future__ import annotations

import numpy as np

from ..channels.catalogue import voltage_name
from ..channels.first_order import sensor_values, shape_values, tip_deflections, tip_values
from ..channels.forward import SolvedMotion, rigid_values
from ..dynamics.forward import ForwardSystem
from ..model import Base, Scenario
from ..solvers import Solution
from ..solvers.forward import FAST_METHOD, integrate_forward
from .common import PathRun, Progress, check_tip_deflection


def run_forward(scenario: Scenario, t: np.ndarray, on_progress: Progress,
                  with_shapes: bool = True) -> PathRun:
    settings = scenario.settings
    system = ForwardSystem(scenario.chain, scenario.base or Base(), settings.geometric_stiffening,
                           scenario.actuators)
    method = settings.method if settings.method not in ("lawson", "magnus") else FAST_METHOD
    solution = integrate_forward(system, t, settings.rtol, settings.atol, method, on_progress)
    nu = len(system.free)
    p, pd, pdd = system.rigid_state(t, solution.q[:, :nu], solution.q_dot[:, :nu],
                                    solution.q_ddot[:, :nu])
    z, zd, zdd = solution.q[:, nu:], solution.q_dot[:, nu:], solution.q_ddot[:, nu:]
    view = SolvedMotion(system, system.frames(p, pd, pdd))
    validity = check_tip_deflection(scenario.chain.links, t, tip_deflections(view, z),
                                    system.geometric_stiffening)
    elastic = Solution(t, z, zd, zdd, solution.method)
    values = sensor_values(view, view.frames, elastic, scenario.sensors)
    values.update(rigid_values(system, t, p, pd, pdd, z, zd, zdd, solution.extra))
    values.update(tip_values(view, view.frames, z))
    volts = system.voltages(t)  # open loop: the commanded voltages, clipped
    values.update({voltage_name(a.name): volts[:, j] for j, a in enumerate(system.actuators)})
    shapes = shape_values(view, view.frames, z) if with_shapes else ()
    return PathRun(solution, values, shapes=shapes, metadata={
        "path": "forward", "geometric_stiffening": settings.geometric_stiffening,
        "elastic_coordinates": system.n, "rigid_coordinates": system.n_rigid,
        **validity})
