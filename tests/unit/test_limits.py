"""Input at the limits (issue 15): output grids too large for memory, absurd but finite link
values, rigid and very stiff links on every model path, sweep files that name themselves in
their errors, and sweeps that skip their invalid cases."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from flexlink.batch import SweepError, sweep
from flexlink.batch.spec import read_sweep_file, sweep_file_errors
from flexlink.cli import main
from flexlink.errors import SimulationError
from flexlink.scenario import ScenarioError, load_paper_experiment, scenario_from_dict
from flexlink.scenario.load import resolve_scenario_dict
from flexlink.simulation import common, simulate

L, MASS, TIP_MASS, TIP_INERTIA = 0.8, 0.5, 0.2, 0.003  # m, kg/m, kg, kg·m²


def _arm(link: dict[str, Any] | None = None, **simulation: Any) -> dict[str, Any]:
    """One link on a hub, a cycloidal move of 60° in 0.5 s, sensors on the link."""
    return {
        "simulation": {"t_end": 1.0, "dt_out": 0.01, **simulation},
        "links": [{"name": "arm", "length": L, "mass_per_length": MASS, "tip_mass": TIP_MASS,
                   "tip_inertia": TIP_INERTIA, **(link or {"rigid": True})}],
        "joints": [{"motion": [{"profile": "cycloidal", "from_deg": 0.0, "to_deg": 60.0,
                                "start": 0.1, "duration": 0.5}]}],
        "sensors": [{"name": "w", "kind": "deflection", "link": "arm", "x": 0.5},
                    {"name": "eps", "kind": "strain", "link": "arm", "x": 0.1,
                     "thickness": 0.01},
                    {"name": "acc", "kind": "acceleration", "link": "arm", "x": L}],
    }


def _joint_inertia() -> float:
    """The rigid link's inertia about its joint, kg·m²."""
    return MASS * L**3 / 3 + TIP_MASS * L**2 + TIP_INERTIA


# --- output grids too large for memory -----------------------------------------------------

def test_a_grid_of_billions_of_samples_is_refused_with_the_numbers() -> None:
    scenario = scenario_from_dict(_arm(t_end=5.0, dt_out=1e-9))
    with pytest.raises(SimulationError, match=r"simulation\.dt_out: this run needs 5e\+09 "
                                              r"output samples") as info:
        simulate(scenario)  # before the fix: numpy's allocation error (or 17 GB of RAM)
    assert "dt_out = " in str(info.value) and "or coarser fits" in str(info.value)


def test_the_suggested_dt_out_fits(monkeypatch: pytest.MonkeyPatch) -> None:
    scenario = scenario_from_dict(_arm(t_end=10.0, dt_out=1e-4))
    estimate = common.run_memory(scenario)
    available = int(estimate.total)  # half of it is the budget: the grid does not fit
    problem = common.memory_problem(estimate, 10.0, "this run", available=available)
    assert problem is not None and f"{estimate.samples:.3g} output samples" in problem
    suggested = float(problem.split("dt_out = ")[-1].split(" s")[0])
    coarser = common.MemoryEstimate(common.sample_count(10.0, suggested), estimate.per_sample)
    assert common.memory_problem(coarser, 10.0, "this run", available=available) is None


def test_a_sweep_too_large_for_memory_is_refused_before_any_case(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(common, "available_memory", lambda: 10**4)  # 10 kB
    with pytest.raises(SweepError, match=r"a sweep of 3 cases × \d+ channels needs .* of "
                                         r"memory.*--channels"):
        sweep(_arm(), grid={"links[0].mass_per_length": [0.4, 0.5, 0.6]}, workers=1)


# --- absurd but finite values ----------------------------------------------------------------

@pytest.mark.parametrize(("link", "field"), [
    ({"EI": 1e300}, "links[0]: EI (EI = 1e+300"),
    ({"EI": 1.0, "mass_per_length": 1e-300}, "mass_per_length = 1e-300"),
    ({"E": 1e300, "width": 0.01, "thickness": 0.01}, "links[0]: E (EI = "),
])
def test_frequencies_beyond_any_beam_name_the_field(link: dict[str, Any], field: str) -> None:
    entry = {"EI": 100.0, **link} if "E" not in link else link
    with pytest.raises(ScenarioError) as info:  # before: a numba typing error mid-run
        scenario_from_dict(_arm(entry))
    assert field in str(info.value) and "rigid = true" in str(info.value)


@pytest.mark.parametrize(("link", "key"), [({"length": 1e120}, "mass_per_length"),
                                           ({"tip_mass": 1e300}, "tip_mass")])
def test_an_overflowing_inertia_names_the_field(link: dict[str, Any], key: str) -> None:
    entry = {"EI": 100.0, "modes": 1, **link}
    data = _arm(entry)
    data["sensors"] = []
    with pytest.raises(ScenarioError, match=rf"links\[0\]: length = .* and {key} = "):
        scenario_from_dict(data)


def test_a_stiff_but_physical_link_is_accepted() -> None:
    scenario_from_dict(_arm({"EI": 1e12}))


# --- rigid links ---------------------------------------------------------------------------

def test_rigid_link_is_read_without_modes_or_stiffness() -> None:
    scenario = scenario_from_dict(_arm())
    link = scenario.chain.links[0]
    assert link.rigid and link.modes == 0
    resolved = resolve_scenario_dict(_arm())["links"][0]
    assert resolved["rigid"] is True and "modes" not in resolved and "EI" not in resolved
    assert scenario_from_dict(resolve_scenario_dict(_arm())) == scenario


@pytest.mark.parametrize("key", ["modes", "damping_ratio", "mode_shapes"])
def test_rigid_link_refuses_modal_keys(key: str) -> None:
    value = {"modes": 3, "damping_ratio": 0.01, "mode_shapes": "tip_loaded"}[key]
    with pytest.raises(ScenarioError, match=rf"links\[0\]\.{key}: a rigid link"):
        scenario_from_dict(_arm({"rigid": True, key: value}))


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_rigid_link_torque_is_the_rigid_inverse_dynamics(model: str) -> None:
    results = simulate(scenario_from_dict(_arm(model=model)))
    frame = results.to_pandas()
    t = frame.index.to_numpy()
    beta, _, beta_dd = scenario_from_dict(_arm()).chain.joints[0].evaluate(t)
    expected = _joint_inertia() * beta_dd  # τ = J β̈ about the joint
    np.testing.assert_allclose(frame["joint1_torque"], expected, atol=1e-12 * _joint_inertia())
    np.testing.assert_allclose(frame["arm_tip_X"], L * np.cos(beta), atol=1e-12)
    np.testing.assert_allclose(frame["arm_tip_Y"], L * np.sin(beta), atol=1e-12)
    assert not frame["w"].any() and not frame["eps"].any()
    assert results.metadata["elastic_coordinates"] == 0


def test_rigid_outer_link_keeps_its_mass_on_the_inner_one() -> None:
    """The paper arm with link 2 rigid: its mass loads link 1 (the joint torque grows with
    it), link 1 still vibrates, link 2's sensors read zero deflection and strain."""
    paper = load_paper_experiment()
    import dataclasses

    rigid = dataclasses.replace(paper.chain.links[1], modes=0)
    heavy = dataclasses.replace(rigid, mass_per_length=2 * rigid.mass_per_length)
    runs = [simulate(dataclasses.replace(paper, chain=dataclasses.replace(
        paper.chain, links=(paper.chain.links[0], link)))).to_pandas() for link in (rigid, heavy)]
    assert not runs[0]["link2_tip_deflection"].any()
    assert not runs[0]["link2_root_strain"].any()
    assert runs[0]["link1_tip_acceleration"].abs().max() > 1.0
    assert runs[1]["joint1_torque"].abs().max() > runs[0]["joint1_torque"].abs().max()


def test_rigid_link_on_a_torque_drive_follows_newton() -> None:
    data = _arm()
    data["joints"] = [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.5}]}]
    frame = simulate(scenario_from_dict(data)).to_pandas()
    t = frame.index.to_numpy()
    np.testing.assert_allclose(frame["joint1_angle"], 0.5 * t**2 / 2 / _joint_inertia(),
                               rtol=1e-5, atol=1e-9)
    assert not frame["eps"].any()


def test_paper_arm_with_a_rigid_link_runs_on_lawson() -> None:
    """Regression: couplings to a rigid link are round-off, which the coefficient table
    refined to its smallest piece until it fell back to Magnus."""
    data = resolve_scenario_dict(Path(flexlink_paper()))
    link = data["links"][0]
    for key in ("damping_ratio", "modes", "mode_shapes"):
        link.pop(key)
    link["rigid"] = True
    results = simulate(scenario_from_dict(data))
    assert results.metadata["method"] == "lawson"


def flexlink_paper() -> str:
    from flexlink.scenario import paper_experiment_path

    return str(paper_experiment_path())


def test_a_link_a_million_times_stiffer_runs_as_rigid() -> None:
    """Regression: EI × 10⁶ of the paper's link 1 took 13 s for 2 s (steps of 3/ω_max)."""
    data = resolve_scenario_dict(Path(flexlink_paper()))
    data["simulation"]["t_end"] = 2.0
    data["links"][0]["EI"] *= 1e6
    results = simulate(scenario_from_dict(data))
    assert results.metadata["rigid_links"] == "link1"
    assert "rigid = true" in results.metadata["rigid_links_note"]
    assert results.metadata["elastic_coordinates"] == 4  # link 2's modes only


def test_a_resolved_stiff_link_stays_flexible() -> None:
    """A link whose vibration the grid resolves, or whose deflection matters, keeps its
    modes (EI × 10³: first frequency ~170 Hz, below 10 × the 500 Hz Nyquist frequency)."""
    data = resolve_scenario_dict(Path(flexlink_paper()))
    data["simulation"]["t_end"] = 1.0
    data["links"][0]["EI"] *= 1e3
    results = simulate(scenario_from_dict(data))
    assert "rigid_links" not in results.metadata


# --- sweep files and invalid cases ---------------------------------------------------------

def test_sweep_file_errors_name_the_file(tmp_path: Path) -> None:
    syntax = tmp_path / "broken.toml"
    syntax.write_text('base = "paper"\nsamples = \n')
    with pytest.raises(SweepError, match=r"broken\.toml: TOML syntax error"):
        read_sweep_file(syntax)
    wrong = tmp_path / "wrong.toml"
    wrong.write_text('base = "paper"\nsamples = 2\n[random]\n"links[7].EI" = "uniform:1:2"\n')
    definition = read_sweep_file(wrong)
    with (pytest.raises(SweepError, match=r"wrong\.toml: links\[7\]\.EI"),
          sweep_file_errors(wrong)):
        sweep(**definition, workers=1)


def test_sweep_file_with_missing_base_names_both(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    spec = tmp_path / "spec.toml"
    spec.write_text('base = "nope.toml"\n[grid]\n"links[0].EI" = [1.0]\n')
    assert main(["sweep", "--spec", str(spec), "-o", str(tmp_path / "s.nc")]) == 2
    err = capsys.readouterr().err
    assert "spec.toml: base scenario" in err and "nope.toml" in err


def test_invalid_cases_refuse_the_sweep_by_default_or_fail_alone() -> None:
    grid = {"sensors[0].x": [0.5, 0.7, 0.9]}  # 0.9 m is beyond the 0.8 m link
    with pytest.raises(SweepError, match=r"sensors\[0\]\.x must be <= 0\.8"):
        sweep(_arm(), grid=grid, workers=1)
    dataset = sweep(copy.deepcopy(_arm()), grid=grid, workers=1, skip_invalid=True)
    assert list(dataset.status.values) == ["ok", "ok", "failed"]
    assert "sensors[0].x must be <= 0.8" in str(dataset.error.values[2])
    assert not np.isnan(dataset["w"].values[:2]).any()
    assert np.isnan(dataset["w"].values[2]).all()  # a case that did not run reads NaN


def test_skip_invalid_on_the_command_line(tmp_path: Path) -> None:
    out = tmp_path / "s.nc"
    args = ["sweep", "--paper", "--grid", "sensors[0].x=1.0,1.5", "--workers", "1", "-q",
            "-o", str(out)]
    assert main(args) == 2 and not out.exists()
    assert main([*args, "--skip-invalid"]) == 1 and out.exists()  # 1: a case failed
