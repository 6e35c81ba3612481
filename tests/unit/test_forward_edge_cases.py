"""Forward runs at the edges: an arm whose only link is rigid (both models, against the exact
rigid-body answer), links stiffer than the output grid resolves (named, or refused by the
nonlinear model), and no run that writes non-finite values."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.errors import SimulationError
from flexlink.scenario import paper_experiment_path, resolve_scenario_dict, scenario_from_dict
from flexlink.simulation import simulate
from flexlink.simulation.common import _check_finite
from flexlink.simulation.rigid import stiff_forward_links

TORQUE, DURATION = 0.05, 0.5  # N·m, s: bang-bang, rest to rest


def _driven_paper(t_end: float, **simulation_keys: object) -> dict:
    d = resolve_scenario_dict(paper_experiment_path())
    d.pop("flexlink_version", None)
    d["simulation"].update(t_end=t_end, **simulation_keys)
    for joint in d["joints"]:
        joint.pop("motion")
        joint.update(drive="torque", torque=[{"profile": "bang_bang", "amplitude": TORQUE,
                                              "start": 0.0, "duration": DURATION}])
    return d


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_a_single_rigid_link_turns_as_the_rigid_body_does(model: str) -> None:
    """+τ then −τ for T/2 each turns a body of inertia J by τ T²/(4 J) and leaves it at rest;
    the nonlinear model failed on an arm without elastic coordinates."""
    d = _driven_paper(0.8, model=model, dt_out=0.01)
    d["links"] = d["links"][:1]
    d["joints"] = d["joints"][:1]
    d["sensors"] = []
    link = d["links"][0]
    for key in ("EI", "width", "thickness", "damping_ratio", "modes", "mode_shapes"):
        link.pop(key, None)
    link["rigid"] = True
    results = simulate(scenario_from_dict(d), shapes=False)
    inertia = (link["mass_per_length"] * link["length"] ** 3 / 3
               + link["tip_mass"] * link["length"] ** 2)
    angle = results["joint1_angle"]
    assert angle[-1] == pytest.approx(TORQUE * DURATION**2 / (4 * inertia), rel=1e-9)
    assert angle[-1] == pytest.approx(angle[-10], rel=1e-12)  # at rest after the move


def test_a_link_that_sets_the_step_alone_is_named() -> None:
    """First order: the run goes on with a warning naming the link, the frequency that sets
    the step and rigid = true; the paper arm has no such link."""
    d = _driven_paper(0.1, dt_out=0.01, geometric_stiffening=True)
    assert "stiff_links_warning" not in simulate(scenario_from_dict(d), shapes=False).metadata
    d["links"][0]["EI"] *= 100.0  # first mode ≈ 55 Hz > 50 Hz, the 100 Hz grid's Nyquist
    warning = simulate(scenario_from_dict(d), shapes=False).metadata["stiff_links_warning"]
    assert "links[0] (link1): its highest mode" in warning and "rigid = true" in warning
    assert "set rigid = true on links[0]" in warning  # the band below 50 Hz moves 0.0025%
    assert "Nyquist frequency (50 Hz)" in warning and "links[1]" not in warning
    d["simulation"]["dt_out"] = 0.001  # resolved by the output, yet 20× link2's top mode
    warning = simulate(scenario_from_dict(d), shapes=False).metadata["stiff_links_warning"]
    assert "× the other links' highest" in warning and "Nyquist" not in warning


def test_the_nonlinear_model_refuses_a_link_it_cannot_resolve_before_running() -> None:
    d = _driven_paper(0.1, model="nonlinear")
    d["links"][0]["EI"] = 1e9
    with pytest.raises(ValueError, match=r"links\[0\] \(link1\).*set rigid = true on links\[0\]"):
        simulate(scenario_from_dict(d), shapes=False)


def test_non_finite_channel_values_are_an_error_naming_the_channel_and_time() -> None:
    t = np.linspace(0.0, 1.0, 5)
    _check_finite("pzt", np.ones(5), t)
    with pytest.raises(SimulationError, match=r"channel pzt is not finite .* from t = 0\.5 s"):
        _check_finite("pzt", np.array([0.0, 1.0, np.nan, np.inf, 1.0]), t)


def test_a_stiff_link_whose_bending_matters_is_advised_fewer_modes_not_rigid() -> None:
    """The four-bar linkage with 4 crank modes: the crank's top mode sets the step, but a rigid
    crank puts the coupler's and follower's midspan strains 14% / 23% off (its bending under
    the pin's force moves the coupler's boundary; the loop's lowest mode, 43 Hz, has no
    counterpart with the crank rigid). The advice is its fewest modes keeping the frequencies
    the output shows within 1%: modes = 1 (strains within 0.01% of 4 modes)."""
    from pathlib import Path

    d = resolve_scenario_dict(Path(__file__).resolve().parents[2] / "examples"
                              / "four_bar_benchmark.toml")
    d["links"][0]["modes"] = 4
    warning = stiff_forward_links(scenario_from_dict(d))["stiff_links_warning"]
    assert "links[0] (crank): its highest mode" in warning
    assert "give links[0] modes = 1" in warning and "set rigid = true" not in warning
    assert "with it rigid a mode below 1e+03 Hz has no counterpart" in warning
