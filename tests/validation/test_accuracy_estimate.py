"""The first-order models' accuracy statement (simulation/accuracy.py) against the error
measured with the nonlinear model, on arms and manoeuvres that are not among the calibration
cases of scripts/accuracy_calibration.py: within a factor 1.5 either way."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from flexlink.model import Chain, Link, PointSensor, Scenario, SimulationSettings
from flexlink.motion import Cycloidal
from flexlink.scenario.builtin import load_paper_experiment
from flexlink.simulation import simulate


def _hub_beam(EI: float, tip_mass: float, duration: float) -> Scenario:
    link = Link("beam", 1.0, 0.5, EI, tip_mass=tip_mass, modes=4, damping_ratio=0.01)
    chain = Chain((link,), (Cycloidal(0.0, 90.0, 0.0, duration),))
    return Scenario(chain, (), SimulationSettings(t_end=duration + 1.0, dt_out=1e-3))


def _paper_arm(EI_scale: float, duration: float) -> Scenario:
    paper = load_paper_experiment()
    links = tuple(dataclasses.replace(link, EI=link.EI * EI_scale)
                  for link in paper.chain.links)
    joints = tuple(dataclasses.replace(j, duration=duration) for j in paper.chain.joints)
    return dataclasses.replace(paper, chain=Chain(links, joints), sensors=())


def _two_links(EI: float, duration: float) -> Scenario:
    links = tuple(Link(f"link{k + 1}", 0.8, 0.5, EI, tip_mass=0.1, modes=4,
                       damping_ratio=0.01) for k in range(2))
    joints = (Cycloidal(0.0, 90.0, 0.0, duration), Cycloidal(0.0, 60.0, 0.0, duration))
    return Scenario(Chain(links, joints), (),
                    SimulationSettings(t_end=duration + 2.0, dt_out=1e-3))


HELD_OUT = {
    "hub-beam EI 6, tip 0.1 kg, 1.0 s": _hub_beam(6.0, 0.1, 1.0),
    "hub-beam EI 12, tip 0.05 kg, 1.6 s": _hub_beam(12.0, 0.05, 1.6),
    "paper arm EI ×0.85, 1.2 s": _paper_arm(0.85, 1.2),
    "paper arm EI ×1.2, 0.9 s": _paper_arm(1.2, 0.9),
    "paper arm EI ×1.2, 1.7 s": _paper_arm(1.2, 1.7),
    "two equal links EI 20, 1.2 s": _two_links(20.0, 1.2),
}


def _with(scenario: Scenario, **settings: object) -> Scenario:
    sensors = tuple(PointSensor(f"tip{k}", "deflection", k, link.length)
                    for k, link in enumerate(scenario.chain.links))
    return dataclasses.replace(scenario, sensors=sensors,
                               settings=dataclasses.replace(scenario.settings, **settings))


@pytest.mark.parametrize("name", HELD_OUT)
def test_the_stated_error_is_within_a_factor_1_5_of_the_measured_one(name: str) -> None:
    scenario = HELD_OUT[name]
    reference = simulate(_with(scenario, model="nonlinear"), shapes=False)
    for stiffening in (True, False):
        run = simulate(_with(scenario, geometric_stiffening=stiffening), shapes=False)
        meta = run.metadata
        k = scenario.chain.link_index(meta["expected_error_link"])
        exact = reference[f"tip{k}"]
        measured = np.abs(run[f"tip{k}"] - exact).max() / np.abs(exact).max()
        stated = meta["expected_error_vs_nonlinear"]
        print(f"{name}, stiffening {stiffening}: stated {stated:.2%}, measured {measured:.2%}")
        assert 1 / 1.5 <= stated / measured <= 1.5, (name, stiffening, stated, measured)
        assert f"{100 * stated:.2g}"[:2] in meta["accuracy"]


def test_the_paper_command_states_the_error_of_the_unstiffened_model() -> None:
    """The shipped paper experiment (no geometric stiffening): link 2's tip is ~22% of its
    peak off the nonlinear model, and the statement says about that, not the stiffened
    model's ~2%."""
    paper = load_paper_experiment()
    run = simulate(paper, shapes=False)
    reference = simulate(dataclasses.replace(paper, settings=dataclasses.replace(
        paper.settings, model="nonlinear")), shapes=False)
    exact = reference["link2_tip_deflection"]
    measured = np.abs(run["link2_tip_deflection"] - exact).max() / np.abs(exact).max()
    assert measured > 0.15
    assert run.metadata["expected_error_link"] == "link2"
    assert 1 / 1.5 <= run.metadata["expected_error_vs_nonlinear"] / measured <= 1.5
    assert "without geometric stiffening" in run.metadata["accuracy"]
    assert "geometric_stiffening = true" in run.metadata["validity_warning"]


def test_forward_runs_state_no_estimate() -> None:
    """Driven joints or a moving base: the formula is not calibrated there (its measured
    ratio scatters far beyond 1.5, scripts/accuracy_calibration.py --forward), so the run
    states no number, only where to compare."""
    from pathlib import Path

    from flexlink.scenario import load_scenario

    servo = load_scenario(Path(__file__).parents[2] / "examples" / "paper_servo.toml")
    short = dataclasses.replace(servo, settings=dataclasses.replace(servo.settings, t_end=0.5))
    meta = simulate(short, shapes=False).metadata
    assert "expected_error_vs_nonlinear" not in meta
    assert meta["accuracy"].startswith("not estimated for driven joints or a moving base")
