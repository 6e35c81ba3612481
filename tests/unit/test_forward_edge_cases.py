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
    """The refusal's advice is checked as the first-order warning's is: rigid = true here
    moves the frequencies below the 500 Hz Nyquist frequency by 1e-8."""
    d = _driven_paper(0.1, model="nonlinear")
    d["links"][0]["EI"] = 1e9
    with pytest.raises(ValueError, match=r"links\[0\] \(link1\).*set rigid = true on links\[0\] "
                       r"\(it then costs no more than a rigid link; the frequencies below 500 Hz "
                       r"move by"):
        simulate(scenario_from_dict(d), shapes=False)


def _four_bar_with_four_crank_modes() -> dict:
    from pathlib import Path

    d = resolve_scenario_dict(Path(__file__).resolve().parents[2] / "examples"
                              / "four_bar_benchmark.toml")
    d["links"][0]["modes"] = 4
    return d


def test_the_nonlinear_refusal_of_a_link_whose_bending_matters_advises_a_finer_grid() -> None:
    """Fewer modes leave a refused link's first frequency where it is: where rigid = true
    would move a frequency the output shows (the four-bar's crank), the refusal's advice is
    the output grid that resolves the link, with the reason it is not rigid = true."""
    from flexlink.simulation import rigid

    scenario = scenario_from_dict(_four_bar_with_four_crank_modes())
    advice = rigid._fix(scenario, 0, 1000.0, 20e3, refused=True)
    assert advice.startswith("give it a dt_out of at most 0.00025 s")
    assert "not rigid = true: with it rigid a mode below 1e+03 Hz has no counterpart" in advice
    assert "modes =" not in advice


def test_only_a_mechanism_without_modes_at_t0_leaves_the_stiff_link_advice_unchecked(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A singular mass matrix or a loop that does not assemble at t = 0 gives the advice
    without the band check; any other failure of the check is a defect and is raised."""
    from flexlink.simulation import rigid

    scenario = scenario_from_dict(_four_bar_with_four_crank_modes())

    def failing(error: Exception):  # type: ignore[no-untyped-def]
        def change(*_: object) -> None:
            raise error
        return change

    monkeypatch.setattr(rigid, "frequency_change", failing(np.linalg.LinAlgError("singular")))
    assert rigid._fix(scenario, 0, 1000.0, 118.0) == (
        "set rigid = true on links[0] if its bending does not matter, or give it fewer modes")
    monkeypatch.setattr(rigid, "frequency_change", failing(IndexError("a defect")))
    with pytest.raises(IndexError, match="a defect"):
        rigid._fix(scenario, 0, 1000.0, 118.0)


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
    warning = stiff_forward_links(scenario_from_dict(_four_bar_with_four_crank_modes()))[
        "stiff_links_warning"]
    assert "links[0] (crank): its highest mode" in warning
    assert "give links[0] modes = 1" in warning and "set rigid = true" not in warning
    assert "with it rigid a mode below 1e+03 Hz has no counterpart" in warning
