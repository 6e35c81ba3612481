"""The nonlinear model against the geometrically exact finite-element reference (Exudyn,
tests/validation/exudyn_reference.py), computed live: the spin-up beam and the paper's arm in a
slow and in the paper's manoeuvre. Slow; skipped without Exudyn. The fast manoeuvre (link 2
bending past 90°) needs 64 elements per link for a converged reference: it is compared with a
stored solution in test_nonlinear.py."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.model import Chain, PointSensor, Scenario, SimulationSettings
from flexlink.motion import Cycloidal
from flexlink.simulation import simulate
from tests.helpers import chain_of, paper_links

pytest.importorskip("exudyn")
from tests.validation.exudyn_reference import (
    krb_link,
    krb_motion,
    simulate_chain_exudyn,
    simulate_krb_exudyn,
)

pytestmark = pytest.mark.slow
T_END = 3.0
DT = 0.002
SENSORS = (PointSensor("acc", "acceleration", 0, 1.37), PointSensor("w1", "deflection", 0, 1.37),
           PointSensor("w2", "deflection", 1, 0.6),
           PointSensor("s_start", "slope", 1, 0.01), PointSensor("s_end", "slope", 1, 0.04))


def _rel(t_ref, ref, t, values) -> float:
    return float(np.abs(np.interp(t_ref, t, values) - ref).max() / np.abs(ref).max())


@pytest.mark.parametrize("omega", [4.0, 10.0])
def test_spinup_beam_matches_exact(omega: float) -> None:
    exact = simulate_krb_exudyn(omega, elements=16)
    r = simulate(Scenario(Chain((krb_link(6),), (krb_motion(omega),)),
                          (PointSensor("tip", "deflection", 0, 10.0),),
                          SimulationSettings(20.0, 0.01, model="nonlinear", step=0.01)))
    err = _rel(np.asarray(exact["t"]), np.asarray(exact["tip_deflection"][0]), r.time, r["tip"])
    assert err < 0.005  # measured 0.04% (Ω = 4) and 0.12% (Ω = 10)


def _arm_errors(duration: float, elements: int, dt: float, modes: int,
                step: float) -> dict[str, float]:
    links = paper_links(damping=False)
    motions = [Cycloidal(0.0, 90.0, 0.5, duration), Cycloidal(90.0, 170.0, 0.5, duration)]
    exact = simulate_chain_exudyn(links, motions, T_END, DT, elements, dt=dt, spectral_radius=1.0,
                                  slope_positions={1: [0.01, 0.04]})
    t_ref = np.asarray(exact["t"])
    ref = {"acc": exact["tip_acceleration_normal"][0], "w1": exact["tip_deflection"][0],
           "w2": exact["tip_deflection"][1],
           "piezo": np.asarray(exact["slope"][1][0.04]) - np.asarray(exact["slope"][1][0.01])}
    r = simulate(Scenario(chain_of(paper_links(modes=modes, damping=False), motions), SENSORS,
                          SimulationSettings(T_END, DT, model="nonlinear", step=step)))
    ours = {"acc": r["acc"], "w1": r["w1"], "w2": r["w2"], "piezo": r["s_end"] - r["s_start"]}
    return {k: _rel(t_ref, np.asarray(ref[k]), r.time, ours[k]) for k in ref}


@pytest.mark.parametrize(("duration", "elements", "dt", "modes", "step", "limit"), [
    (2.0, 16, 2e-3, 4, 0.01, 0.01),
    (1.0, 32, 5e-4, 6, 0.005, 0.01),
])
def test_paper_arm_against_exact(duration, elements, dt, modes, step, limit) -> None:
    """Errors (max |difference| / peak) of the link-1 tip accelerometer, both tip deflections
    and the PZT slope difference. Measured (acc, w1, w2, PZT): D = 2 s 0.49/0.07/0.09/0.23%,
    D = 1 s 0.28/0.02/0.03/0.05% (docs/validation.md)."""
    errors = _arm_errors(duration, elements, dt, modes, step)
    assert max(errors.values()) < limit, errors
