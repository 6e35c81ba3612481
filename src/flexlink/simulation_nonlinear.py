"""Orchestration of the nonlinear model: scenario → NonlinearSystem → Gauss solver → sensors."""

from __future__ import annotations

import functools
import time

import numpy as np

from ._version import package_version
from .dynamics.nonlinear import NonlinearSystem
from .model import Scenario
from .results import Results
from .sensors.evaluate import Trajectory
from .sensors.nonlinear import joint_and_tip_channels, sensor_channels
from .simulation import _ProgressBar, output_times
from .solvers import SimulationError
from .solvers.gauss import solve_nonlinear
from .solvers.threads import single_threaded

_version = functools.lru_cache(maxsize=1)(package_version)  # metadata lookup: ~5 ms per call


def simulate_nonlinear(scenario: Scenario, progress: bool = False) -> Results:
    """Run one scenario with the geometrically nonlinear model (elastic coordinates from rest)."""
    # Small matrices and batched products over time: BLAS threads only add overhead.
    with single_threaded():
        return _simulate(scenario, progress)


def _simulate(scenario: Scenario, progress: bool) -> Results:
    settings = scenario.settings
    system = NonlinearSystem(scenario.chain)
    t = output_times(settings.t_end, settings.dt_out)
    system.joint_history(t)  # fail early if a measured motion does not cover [0, t_end]

    started = time.perf_counter()
    with _ProgressBar(settings.t_end, enabled=progress) as bar:
        q, qd, qdd, step = solve_nonlinear(system, t, settings.rtol, settings.step,
                                           on_progress=bar.update)
    if not np.all(np.isfinite(qdd)):
        raise SimulationError("accelerations are not finite")
    traj = Trajectory(t, q, qd, qdd)

    results = Results(time=t, metadata={
        "scenario": scenario.name,
        "flexlink_version": _version(),
        "model": "nonlinear",
        "wall_time_s": time.perf_counter() - started,
        "elastic_coordinates": system.n,
        "time_step_s": step,
    })
    hist = system.joint_history(t)
    for ch in (sensor_channels(system, traj, scenario.sensors, hist)
               + joint_and_tip_channels(system, traj, hist)):
        results.add(ch.name, ch.values, ch.unit, ch.description)
    return results
