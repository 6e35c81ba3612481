"""The closed loops of test_closed_loops_exact.py on the geometrically nonlinear model
(exact closures on the deformed arcs) against the geometrically exact FE model (Exudyn,
tests/validation/exudyn_loops_reference.py): the flexible slider-crank of
examples/slider_crank.toml and the four-bar with a light flexible coupler.

Slow, and skipped where Exudyn is not installed (`pip install -e '.[test,reference]'`).
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np
import pytest

from flexlink import simulate
from flexlink.scenario import resolve_scenario_dict, scenario_from_dict

pytest.importorskip("exudyn")
from tests.validation.exudyn_loops_reference import (
    simulate_four_bar_exudyn,
    simulate_slider_crank_exudyn,
)

pytestmark = pytest.mark.slow

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "slider_crank.toml"
EA = 2e11 * math.pi * 0.003**2  # N: the steel rod's axial stiffness (Exudyn's beams stretch)


def nonlinear_slider_crank():
    d = resolve_scenario_dict(EXAMPLE)
    d["simulation"]["model"] = "nonlinear"
    return scenario_from_dict(d)


def nonlinear_four_bar():
    from tests.validation.test_closed_loops import FOUR_BAR, L2

    d = copy.deepcopy(FOUR_BAR)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 2.0,
                     "modes": 4}
    d["joints"][0] = {"motion": [{"profile": "spinup", "to_rate_deg_s": 1200.0, "start": 0.0,
                                  "duration": 0.2, "from_deg": 90.0}]}
    d["sensors"] = [{"name": "mid", "kind": "deflection", "link": "coupler", "x": L2 / 2}]
    d["simulation"] = {"name": "four-bar", "t_end": 0.6, "dt_out": 5e-4, "model": "nonlinear"}
    return scenario_from_dict(d)


def test_nonlinear_slider_crank_matches_the_geometrically_exact_model() -> None:
    """Measured (default rtol 1e-4): the rod's midpoint deflection within 0.64% of its peak
    (4.09 mm), the piston (the rod's deformed tip, exact arc kinematics: its foreshortening
    included) within 3.2e-5 m of Exudyn's (32 elements, steps 2.5e-5 s), the closure
    residual 9e-13 of the loop's size."""
    scenario = nonlinear_slider_crank()
    run = simulate(scenario)
    rod = scenario.chain.links[1]
    crank = scenario.chain.links[0].length
    ref = simulate_slider_crank_exudyn(crank, rod, scenario.chain.joints[0], EA,
                                       scenario.settings.t_end, scenario.settings.dt_out,
                                       elements=32, dt=2.5e-5)
    peak = np.abs(ref["mid_deflection"]).max()
    assert peak > 3e-3
    assert np.abs(run["rod_mid"] - ref["mid_deflection"]).max() < 0.01 * peak
    assert np.abs(run["rod_tip_X"] - ref["piston_x"]).max() < 1e-4 * (crank + rod.length)
    assert run.metadata["closure_residual_relative"] < 1e-8


def test_nonlinear_four_bar_matches_the_geometrically_exact_model() -> None:
    """Measured: the coupler's midpoint deflection (peak 0.58 mm) within 0.073% of its peak
    of Exudyn's, the rocker angle within 5.2e-5 rad."""
    from flexlink.model import Link
    from tests.validation.test_closed_loops import L1, L2, L3, D, _four_bar_angles

    scenario = nonlinear_four_bar()
    run = simulate(scenario)
    ref = simulate_four_bar_exudyn(L1, Link("coupler", L2, 0.3, 2.0), Link("rocker", L3, 2.0,
                                   math.inf), (D, 0.0), scenario.chain.joints[0],
                                   _four_bar_angles(math.radians(90.0)), 1e6, 0.6, 5e-4,
                                   elements=32, dt=2.5e-5)
    peak = np.abs(ref["mid_deflection"]).max()
    assert peak > 4e-4
    assert np.abs(run["mid"] - ref["mid_deflection"]).max() < 0.01 * peak
    assert np.abs(np.unwrap(run["joint3_angle"]) - ref["rocker_angle"]).max() < 3e-4
    assert run.metadata["closure_residual_relative"] < 1e-8
