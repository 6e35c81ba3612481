"""The simulation stage: `simulate` picks the model path for a scenario, runs it and
assembles the `Results`. One module per path, sharing `common`:

* ``prescribed`` — prescribed joints, first-order model (Lawson, Magnus or scipy);
* ``nonlinear`` — prescribed joints, geometrically nonlinear model (Gauss collocation);
* ``forward`` — free/pinned base or driven joints, first-order model (solve_ivp).
"""

from __future__ import annotations

from ..model import Scenario
from ..results import Results
from ..solvers.threads import single_threaded
from .common import ProgressBar, assemble_results, output_times, timed
from .forward import run_forward
from .nonlinear import run_nonlinear
from .prescribed import run_prescribed

PATHS = {"prescribed": run_prescribed, "nonlinear": run_nonlinear, "forward": run_forward}


def model_path(scenario: Scenario) -> str:
    """The path that runs ``scenario``: a key of PATHS."""
    if scenario.is_forward:
        if scenario.settings.model == "nonlinear":
            raise ValueError("model = 'nonlinear' has prescribed joints on a fixed hub only: "
                             "a moving base or a driven joint needs model = 'first_order'")
        return "forward"
    return "nonlinear" if scenario.settings.model == "nonlinear" else "prescribed"


def simulate(scenario: Scenario, progress: bool = False, shapes: bool = True) -> Results:
    """Run one scenario: elastic coordinates start at rest; joints follow their prescriptions,
    or (moving base, driven joints) the equations of motion. ``progress``: a progress bar on
    runs longer than a second; ``shapes``: every link's deformed shape on a grid of points
    (what animations draw; sweeps leave it out)."""
    path = PATHS[model_path(scenario)]
    settings = scenario.settings
    t = output_times(settings.t_end, settings.dt_out)
    # Small matrices and batched products over time: BLAS threads only add overhead.
    with single_threaded(), ProgressBar(settings.t_end, enabled=progress) as bar:
        run, wall_time = timed(lambda: path(scenario, t, bar.update, shapes))
    return assemble_results(scenario, run, wall_time)


__all__ = ["PATHS", "model_path", "output_times", "simulate"]
