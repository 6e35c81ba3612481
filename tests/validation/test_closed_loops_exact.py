"""The flexible slider-crank (examples/slider_crank.toml: crank 0.152 m, steel rod 0.304 m,
6 mm round section, piston 0.05 kg, crank spun up to 150 rad/s) against the geometrically
exact FE model (Exudyn, tests/validation/exudyn_loops_reference.py): the rod's midpoint
deflection from its chord and the piston's position.

Slow, and skipped where Exudyn is not installed (`pip install -e '.[test,reference]'`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from flexlink import simulate
from flexlink.scenario import load_scenario

pytest.importorskip("exudyn")
from tests.validation.exudyn_loops_reference import simulate_slider_crank_exudyn

pytestmark = pytest.mark.slow

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "slider_crank.toml"
EA = 2e11 * math.pi * 0.003**2  # N: the steel rod's axial stiffness (Exudyn's beams stretch)


def test_flexible_slider_crank_matches_the_geometrically_exact_model() -> None:
    """Measured: the stiffened first-order model within 0.7% of the peak midpoint deflection
    (4.09 mm) over the run (1.5% asserted), the FE model converged to 3e-4 (32 elements, steps 2.5e-5 s
    against 1.25e-5 s); without the closure's foreshortening (the loop's axial force in the
    rod's stiffness) it was 11% off, without geometric stiffening 31%."""
    scenario = load_scenario(EXAMPLE)
    run = simulate(scenario)
    rod = scenario.chain.links[1]
    crank = scenario.chain.links[0].length
    ref = simulate_slider_crank_exudyn(crank, rod, scenario.chain.joints[0], EA,
                                       scenario.settings.t_end, scenario.settings.dt_out,
                                       elements=32, dt=2.5e-5)
    peak = np.abs(ref["mid_deflection"]).max()
    assert peak > 3e-3  # the rod bends: 1.3% of its length
    assert np.abs(run["rod_mid"] - ref["mid_deflection"]).max() < 0.015 * peak
    # the tip channels are the first-order (linear) kinematics: without the rod's
    # foreshortening ½∫w'² (0.14 mm here), measured 0.10 mm from the FE piston
    assert np.abs(run["rod_tip_X"] - ref["piston_x"]).max() < 4e-4 * (crank + rod.length)


def test_four_bar_with_a_flexible_coupler_matches_the_geometrically_exact_model() -> None:
    """The four-bar of test_closed_loops.py with a light coupler (0.3 kg/m, EI = 2 N·m²,
    4 pinned–pinned modes; first frequency 45 Hz), the crank spun up to 20.9 rad/s in 0.2 s:
    the coupler's midpoint deflection from its chord (peak 0.58 mm) within 0.08% of its peak
    of Exudyn's (32 elements, steps 2.5e-5 s; 16 elements and 5e-5 s differ by 0.5%), the
    rocker angle within 5e-5 rad. Without geometric stiffening: 13%."""
    import copy

    from flexlink.model import Link
    from flexlink.scenario import scenario_from_dict
    from tests.validation.exudyn_loops_reference import simulate_four_bar_exudyn
    from tests.validation.test_closed_loops import FOUR_BAR, L1, L2, L3, D, _four_bar_angles

    d = copy.deepcopy(FOUR_BAR)
    d["links"][1] = {"name": "coupler", "length": L2, "mass_per_length": 0.3, "EI": 2.0,
                     "modes": 4}
    d["joints"][0] = {"motion": [{"profile": "spinup", "to_rate_deg_s": 1200.0, "start": 0.0,
                                  "duration": 0.2, "from_deg": 90.0}]}
    d["sensors"] = [{"name": "mid", "kind": "deflection", "link": "coupler", "x": L2 / 2}]
    d["simulation"] = {"name": "four-bar", "t_end": 0.6, "dt_out": 5e-4}
    scenario = scenario_from_dict(d)
    run = simulate(scenario)
    ref = simulate_four_bar_exudyn(L1, Link("coupler", L2, 0.3, 2.0), Link("rocker", L3, 2.0,
                                   math.inf), (D, 0.0), scenario.chain.joints[0],
                                   _four_bar_angles(math.radians(90.0)), 1e6, 0.6, 5e-4,
                                   elements=32, dt=2.5e-5)
    peak = np.abs(ref["mid_deflection"]).max()
    assert peak > 4e-4
    assert np.abs(run["mid"] - ref["mid_deflection"]).max() < 0.01 * peak
    assert np.abs(np.unwrap(run["joint3_angle"]) - ref["rocker_angle"]).max() < 3e-4
