"""The simulation stage: `simulate` picks the model path for a scenario, runs it and
assembles the `Results`. One module per path, sharing `common`:

* ``prescribed`` — prescribed joints, first-order model (Lawson, Magnus or scipy);
* ``nonlinear`` — prescribed joints, geometrically nonlinear model (Gauss collocation);
* ``forward`` — free/pinned base or driven joints, first-order model (compiled Radau IIA,
  or solve_ivp for method = "DOP853", "Radau", …);
* ``nonlinear_forward`` — free/pinned base or driven joints, nonlinear model (Gauss
  collocation with the rigid coordinates as unknowns);
* ``closed_loop`` — controllers sampled with zero-order hold, prescribed joints, first-order
  model (the Lawson loop with the held voltages as states); with the nonlinear model the
  ``nonlinear`` path runs them (solvers/gauss_sampled.py), the ``forward`` path with driven
  joints or a moving base (solvers/radau.py), ``nonlinear_forward`` on the closed loops'
  kernel (solvers/nonlinear_loops.py).
Open-loop piezo actuators run in every path.
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import replace
from functools import partial
from importlib import import_module
from os import PathLike
from typing import Any

import numpy as np

from ..errors import SimulationError
from ..model import Scenario
from ..results import Results
from ..solvers.threads import single_threaded
from .common import (
    PathRun,
    Progress,
    ProgressBar,
    assemble_results,
    check_run_memory,
    output_times,
    timed,
)
from .rigid import quasi_rigid_links, rigid_metadata, stiff_forward_links, with_rigid_links

# (scenario, output times, progress callback, with shapes) → the path's run
PathFunction = Callable[[Scenario, np.ndarray, Progress, bool], PathRun]
# Each path's module is imported when a run takes it: a prescribed run from the command
# line need not import the forward, nonlinear and closed-loop machinery.
PATHS = ("prescribed", "nonlinear", "forward", "nonlinear_forward", "closed_loop")


def path_function(name: str) -> PathFunction:
    """The function of the path ``name`` (one of PATHS): ``run_<name>`` of its module."""
    return getattr(import_module(f".{name}", __name__), f"run_{name}")


def model_path(scenario: Scenario) -> str:
    """The path that runs ``scenario``: one of PATHS."""
    if scenario.controllers and scenario.is_forward and scenario.settings.model == "nonlinear" \
            and scenario.settings.step is not None:
        raise ValueError("simulation.step: controllers with a moving base or a driven joint "
                         "run on the nonlinear model with error-controlled steps; drop "
                         "simulation.step")
    if scenario.controllers and scenario.settings.model != "nonlinear" \
            and not scenario.is_forward:
        return "closed_loop"
    if scenario.is_forward:
        return "nonlinear_forward" if scenario.settings.model == "nonlinear" else "forward"
    return "nonlinear" if scenario.settings.model == "nonlinear" else "prescribed"


def simulate(scenario: Scenario | str | PathLike[str], progress: bool = False, shapes: bool = True,
             sensitivities: Sequence[str] | None = None) -> Results:
    """Run one scenario: elastic coordinates start at rest, undeformed or (``initial =
    "equilibrium"``) in static equilibrium; joints follow their prescriptions,
    or (moving base, driven joints) the equations of motion. ``progress``: a progress bar on
    runs longer than a second; ``shapes``: every link's deformed shape on a grid of points
    (what animations draw; sweeps leave it out); ``sensitivities``: field paths
    (``links[0].EI``, …) whose derivatives of every channel the run computes too
    (`Results.sensitivity`, docs/sensitivities.md). ``scenario``: a `Scenario`, or the path
    of a scenario file."""
    from ..scenario.load import as_scenario

    scenario = as_scenario(scenario, "simulate")
    if sensitivities is not None:
        from .sensitivities import simulate_with_sensitivities

        return simulate_with_sensitivities(scenario, sensitivities, progress, shapes)
    return assemble_results(scenario, *run_scenario(scenario, progress, shapes))


def run_scenario(scenario: Scenario, progress: bool = False, shapes: bool = True,
                 channels: Collection[str] | None = None,
                 prescribed: Mapping[str, Any] | None = None) -> tuple[PathRun, float]:
    """`simulate` up to its `Results`: the path's run and its wall time (s). A sweep's
    worker reads the channels it keeps from the run's values. ``channels``: the only
    channels the caller reads (None: all); the prescribed path then computes those alone
    and its validity check without the accuracy metadata, other paths every channel.
    ``prescribed``: more arguments of `prescribed.run_prescribed` on that path (a sweep's
    system and solution integrated with other cases', batch/grouped.py)."""
    check_run_memory(scenario)
    warning = stiff_forward_links(scenario)  # may refuse: before anything runs
    name = model_path(scenario)
    path = path_function(name)
    if channels is not None and name == "prescribed":
        path = partial(path, kept=frozenset(channels))
    if prescribed and name == "prescribed":
        path = partial(path, **prescribed)
    settings = scenario.settings
    t = output_times(settings.t_end, settings.dt_out)
    # Small matrices and batched products over time: BLAS threads only add overhead.
    with single_threaded(), ProgressBar(settings.t_end, enabled=progress) as bar:
        try:
            run, wall_time = timed(lambda: _run_path(path, scenario, t, bar.update, shapes,
                                                     warning))
        except np.linalg.LinAlgError as exc:  # a ValueError, which callers read as bad input
            raise SimulationError(
                f"the {name} run failed: its equations became singular ({exc}); the state "
                "left the range where the model holds. Check for loads, gains or drive "
                "forces far too large, or a cart or slider driven far past its travel"
            ) from None
        if scenario.controllers:
            run = _with_loop_warnings(scenario, t, run)
    return run, wall_time


def _with_loop_warnings(scenario: Scenario, t: np.ndarray, run: PathRun) -> PathRun:
    """The run with its closed loops' warnings (control/loop_check.py) in the metadata."""
    from ..control.loop_check import loop_warnings

    warnings = loop_warnings(scenario, t, run.values)
    if not warnings:
        return run
    return replace(run, metadata={**run.metadata, "control_warning": "; ".join(warnings)})


def _run_path(path: PathFunction, scenario: Scenario, t: np.ndarray,
              on_progress: Progress, shapes: bool, warning: dict[str, str]) -> PathRun:
    """Run ``path``, with the links too stiff to matter made rigid (simulation/rigid.py); a
    forward run's stiff links named in its ``warning`` metadata (`stiff_forward_links`)."""
    if warning:
        run = path(scenario, t, on_progress, shapes)
        return replace(run, metadata={**run.metadata, **warning})
    stiff = quasi_rigid_links(scenario, t)
    if not stiff:
        return path(scenario, t, on_progress, shapes)
    run = path(with_rigid_links(scenario, stiff), t, on_progress, shapes)
    return replace(run, metadata={**run.metadata, **rigid_metadata(scenario, stiff)})


__all__ = ["PATHS", "model_path", "output_times", "path_function", "run_scenario", "simulate"]
