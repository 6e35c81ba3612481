"""Orchestration only: scenario → model → solve → sensors → Results."""

from __future__ import annotations

import time

import numpy as np

from ._version import package_version
from .dynamics.first_order import FirstOrderSystem
from .model import Scenario
from .results import Results
from .sensors.evaluate import Trajectory, joint_and_tip_channels, sensor_channels
from .solvers import SimulationError, integrate_lawson, integrate_magnus, integrate_second_order


def output_times(t_end: float, dt_out: float) -> np.ndarray:
    """0, dt_out, 2 dt_out, … up to and including t_end (s)."""
    count = int(np.floor(t_end / dt_out + 1e-9))
    t = np.arange(count + 1) * dt_out
    return t if np.isclose(t[-1], t_end) else np.append(t, t_end)


def simulate(scenario: Scenario, progress: bool = False) -> Results:
    """Run one scenario. Elastic coordinates start at rest; joints follow their prescriptions
    (or, with a moving base or driven joints, the forward dynamics of forward_simulation)."""
    from .forward_simulation import needs_forward_dynamics, simulate_forward

    settings = scenario.settings
    if needs_forward_dynamics(scenario):
        if settings.model == "nonlinear":
            raise ValueError("model = 'nonlinear' has prescribed joints on a fixed hub only: "
                             "a moving base or a driven joint needs model = 'first_order'")
        return simulate_forward(scenario)
    if settings.model == "nonlinear":
        from .simulation_nonlinear import simulate_nonlinear  # imports this module

        return simulate_nonlinear(scenario, progress)
    system = FirstOrderSystem(scenario.chain, settings.geometric_stiffening)
    t = output_times(settings.t_end, settings.dt_out)
    system.joint_history(t)  # fail early if a measured motion does not cover [0, t_end]

    started = time.perf_counter()
    method = settings.method
    with _ProgressBar(settings.t_end, enabled=progress) as bar:
        if settings.method == "magnus":
            z, zd = integrate_magnus(
                system.matrices, system.n, t, settings.rtol, settings.atol,
                on_progress=bar.update, max_frequency=system.max_frequency,
                coefficient_keys=system.coefficient_keys,
            )
        elif settings.method == "lawson":
            z, zd, zdd, method = integrate_lawson(
                system.matrices, system.n, t, settings.rtol, settings.atol,
                on_progress=bar.update, max_frequency=system.max_frequency,
                coefficient_keys=system.coefficient_keys, breaks=system.breakpoints(),
            )
        else:
            z, zd = integrate_second_order(
                system.matrices, system.n, t, settings.rtol, settings.atol, settings.method,
                on_progress=bar.update,
            )
    _check_small_deflections(system, t, z)
    if settings.method != "lawson":  # Lawson returns z̈ from its coefficient table
        zdd = system.accelerations(t, z, zd)
    if not np.all(np.isfinite(zdd)):
        raise SimulationError("accelerations are not finite")
    traj = Trajectory(t, z, zd, zdd)

    results = Results(time=t, metadata={
        "scenario": scenario.name,
        "flexlink_version": package_version(),
        "model": "first_order",
        "geometric_stiffening": settings.geometric_stiffening,
        "method": method,
        "wall_time_s": time.perf_counter() - started,
        "elastic_coordinates": system.n,
    })
    for ch in sensor_channels(system, traj, scenario.sensors) + joint_and_tip_channels(system, traj):
        results.add(ch.name, ch.values, ch.unit, ch.description)
    return results


def _check_small_deflections(system: FirstOrderSystem, t: np.ndarray, z: np.ndarray) -> None:
    """Refuse a result whose tip deflection exceeds the link's length: the linear model has
    diverged (e.g. centrifugal softening without geometric stiffening above the first frequency)."""
    for body, link in zip(system.bodies, system.chain.links):
        tip = np.abs(z[:, body.slice] @ body.data.tip_value)
        if tip.max() > link.length:
            when = t[int(np.argmax(tip > link.length))]
            hint = ("; the paper's model has no geometric stiffening and diverges when a link "
                    "spins faster than its first frequency: set geometric_stiffening = true"
                    if not system.geometric_stiffening else "")
            raise SimulationError(
                f"the tip deflection of {link.name} exceeds its length ({link.length:g} m) at "
                f"t = {when:.4g} s: the first-order model is not valid here{hint}; "
                f"model = \"nonlinear\" handles large deflections"
            )


class _ProgressBar:
    """A tqdm bar over simulated time that only appears for runs longer than a second."""

    def __init__(self, t_end: float, enabled: bool) -> None:
        self.t_end = t_end
        self.enabled = enabled
        self._bar = None
        self._shown = 0.0

    def __enter__(self) -> _ProgressBar:
        if self.enabled:
            from tqdm import tqdm

            self._bar = tqdm(total=self.t_end, unit="s sim", delay=1.0, leave=False,
                             bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} s [{elapsed}<{remaining}]")
        return self

    def update(self, t: float) -> None:
        if self._bar is not None and t > self._shown:
            self._bar.update(t - self._shown)
            self._shown = t

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.close()
