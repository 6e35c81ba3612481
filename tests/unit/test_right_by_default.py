"""Right by default: input a user may well give that used to be accepted and then ignored,
or that produced a wrong result without a word."""

from __future__ import annotations

import dataclasses
import math
import re
import tomllib
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest

from flexlink.batch import SweepError, sweep
from flexlink.batch.dataset import parameter_unit
from flexlink.batch.summaries import parse_summary
from flexlink.cli import main
from flexlink.errors import SimulationError
from flexlink.scenario import (
    ScenarioError,
    load_paper_experiment,
    load_scenario,
    paper_experiment_path,
    scenario_from_dict,
)
from flexlink.scenario.fields import ScenarioFile, Target, parse
from flexlink.simulation import simulate
from flexlink.simulation.objective import MeanSquare, Objective
from flexlink.simulation.sensitivities import SensitivityError, field_unit

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_an_output_grid_coarser_than_the_move_keeps_the_links_flexible() -> None:
    """dt_out longer than the whole move: the output samples see no acceleration, yet the
    links vibrate after it; the quasi-rigid check must look at the motion, not the samples
    (it made both links rigid: zero deflection at every sample)."""
    base = load_paper_experiment()

    def run(dt_out: float) -> np.ndarray:
        settings = dataclasses.replace(base.settings, t_end=6.0, dt_out=dt_out)
        results = simulate(dataclasses.replace(base, settings=settings), shapes=False)
        assert "rigid_links" not in results.metadata
        return results.to_pandas().loc[[3.0, 6.0], "link2_tip_deflection"].to_numpy()

    fine, coarse = run(1.0), run(3.0)
    assert np.all(np.abs(fine) > 1e-3)  # m: the arm rings after its move
    np.testing.assert_allclose(coarse, fine, rtol=1e-4)


def _servo_dict() -> dict[str, Any]:
    with open(EXAMPLES / "paper_servo.toml", "rb") as file:
        return tomllib.load(file)


def test_a_fixed_step_on_the_first_order_model_is_refused() -> None:
    """simulation.step is the nonlinear model's; the first-order model used to ignore it."""
    d = _servo_dict()
    d["simulation"]["step"] = 1e-3
    with pytest.raises(ScenarioError, match=r"simulation\.step: .*model = \"nonlinear\""):
        scenario_from_dict(d)
    d["simulation"]["model"] = "nonlinear"
    assert scenario_from_dict(d).settings.step == 1e-3


@pytest.mark.parametrize("name", ["../escaped", "runs/arm", "a\\b"])
def test_a_scenario_name_with_a_path_separator_is_refused(name: str) -> None:
    """The name makes default output names (a sweep's `<name>_sweep.nc`): '../x' wrote
    outside the working folder."""
    d = _servo_dict()
    d["simulation"]["name"] = name
    with pytest.raises(ScenarioError, match=r"simulation\.name .*no '/'"):
        scenario_from_dict(d)


def test_a_sweep_with_a_path_in_the_scenario_name_writes_nothing(tmp_path: Path,
                                                                monkeypatch: pytest.MonkeyPatch
                                                                ) -> None:
    text = (EXAMPLES / "paper_servo.toml").read_text()
    work = tmp_path / "work"
    work.mkdir()
    (work / "s.toml").write_text(text.replace('name = "paper-servo"', 'name = "../escaped"'))
    monkeypatch.chdir(work)
    assert main(["sweep", "s.toml", "--grid", "links[0].E=30e9", "-q"]) == 2
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["s.toml", "work"]


def test_a_pair_with_a_nan_or_a_third_number_shows_it() -> None:
    d = _servo_dict()
    d["simulation"]["gravity"] = [0.0, math.nan]
    with pytest.raises(ScenarioError, match=r"simulation\.gravity: .*finite, got \[0\.0, nan\]"):
        scenario_from_dict(d)


@pytest.mark.parametrize("keys", [{"after": math.nan}, {"target": math.inf}, {"after": "1.5"}])
def test_a_mean_square_metric_refuses_a_value_that_makes_it_nan(keys: dict[str, Any]) -> None:
    """MeanSquare(target=nan) made every objective value NaN, silently."""
    with pytest.raises(ValueError, match=r"MeanSquare\.(after|target) must be a finite number"):
        MeanSquare("link2_tip_deflection", **keys)


def test_an_objective_refuses_one_field_by_two_paths() -> None:
    """x would set links[0].damping_ratio twice, the last value winning, while the gradient
    reports both as independent."""
    with pytest.raises(SensitivityError, match=r"'links\[0\]\.damping_ratio' and "
                       r"'links\[link1\]\.damping_ratio' are the same field"):
        Objective(load_paper_experiment(), ["links[0].damping_ratio",
                                            "links[link1].damping_ratio"],
                  MeanSquare("link2_tip_deflection", after=1.5))


def test_a_settling_time_not_reached_in_the_run_is_nan() -> None:
    """Still ringing at the end: the band held only at the last sample (trivially, the final
    value is its own reference), which read as a settling time of t_end."""
    t = np.linspace(0.0, 1.0, 101)
    ringing = np.sin(2 * np.pi * 7.3 * t)
    assert math.isnan(parse_summary("settling:x:band=1e-3").evaluate(t, ringing))
    settled = np.where(t < 0.5, ringing, 0.0)
    assert parse_summary("settling:x:band=1e-3").evaluate(t, settled) == pytest.approx(0.5)


@pytest.mark.parametrize("name", ["study.csv", "study", "study.txt"])
def test_a_sweep_output_that_is_neither_netcdf_nor_matlab_is_refused(
        tmp_path: Path, name: str, capsys: pytest.CaptureFixture[str]) -> None:
    """-o study.csv wrote a netCDF file named .csv."""
    assert main(["sweep", "--paper", "--grid", "links[0].EI=300", "-o",
                 str(tmp_path / name), "-q"]) == 2
    assert "name a netCDF file (.nc) or a MATLAB file (.mat)" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_compare_states_the_units_of_its_simulated_columns(tmp_path: Path) -> None:
    """simulated.csv of compare and fit had no units anywhere in the folder."""
    out = tmp_path / "cmp"
    assert main(["compare", str(EXAMPLES / "lab_arm.toml"), str(EXAMPLES / "lab_run3.csv"),
                 "-o", str(out), "-q", "--no-figures"]) == 0
    columns = (out / "simulated.csv").read_text().splitlines()[0].split(",")
    table = pd.read_csv(out / "simulated_channels.csv")
    assert list(table["name"]) == columns
    units = dict(zip(table["name"], table["unit"], strict=True))
    assert units["t"] == "s" and units["link1_tip_acceleration"] == "m s-2"
    assert table["unit"].notna().all()


@pytest.mark.parametrize(("kind", "value", "message"), [
    ("grid", 300.0, r"grid links\[0\]\.EI: expected a list of numbers or a rule"),
    ("grid", {"from": 1}, r"grid links\[0\]\.EI: expected a list of numbers or a rule"),
    ("random", 300.0, r"random links\[0\]\.EI: expected uniform:low:high"),
])
def test_a_sweep_value_that_is_a_lone_number_is_refused(kind: str, value: Any,
                                                        message: str) -> None:
    """`"links[0].EI" = 300.0` in a sweep file's [grid] ended in a TypeError traceback."""
    with pytest.raises(SweepError, match=message):
        sweep(paper_experiment_path(), **{kind: {"links[0].EI": value}}, samples=1 if
              kind == "random" else None, workers=1)


@pytest.mark.parametrize("at", ["1.2", "12"])
def test_a_linearisation_point_given_as_text_is_refused(at: str) -> None:
    """at="12" on a two-joint arm was read as joint angles 1 deg and 2 deg, one per
    character; at="1.2" as three angles."""
    from flexlink.control import linearize

    with pytest.raises(TypeError, match=r"at: give a time in s, joint angles in degrees"):
        linearize(load_paper_experiment(), at=at)


@pytest.mark.parametrize("command", [["animate"], ["report"]])
def test_a_matlab_sweep_file_is_not_called_damaged(tmp_path: Path, command: list[str],
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """A sweep written with -o sweep.mat was reported as 'damaged or not written by
    flexlink'."""
    from scipy.io import savemat

    savemat(tmp_path / "sweep.mat", {"t": np.zeros(3)})
    assert main([*command, str(tmp_path / "sweep.mat")]) == 2
    err = capsys.readouterr().err
    assert "is a MATLAB file; animate and report read a sweep's netCDF file" in err
    assert "damaged" not in err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sweep.mat"]


@pytest.mark.parametrize(("path", "unit"), [
    ("joints[0].torque[0].amplitude", "N m"), ("base.loads[0].moment[0].amplitude", "N m"),
    ("base.loads[0].force_x[1].amplitude", "N"), ("actuators[0].voltage[0].amplitude", "V"),
    ("base.cart.force[0].values[2]", "N"), ("base.mass", "kg"), ("joints[0].P", "V rad-1"),
    ("links[0].EI", "N m2"), ("joints[1].motion[0].to_deg", "degree"),
])
def test_a_swept_field_has_its_unit(path: str, unit: str) -> None:
    """A sweep's parameter coordinates took their units from a short table of link, motion
    and sensor keys (base.mass, servo gains, loads had none), and a history's amplitude
    read as dimensionless ("1") in the sensitivities."""
    assert parameter_unit(path) == unit
    steps = parse(path)
    assert field_unit(Target(path, steps, None, False)) == unit


def test_a_cart_servo_gain_has_the_cart_unit() -> None:
    assert parameter_unit("base.cart.P") == "V m-1"


@pytest.mark.parametrize(("path", "unit"), [
    ("joints[0].D", "V s rad-1"), ("joints[1].rate_per_volt_deg_s", "degree s-1 V-1"),
    ("base.cart.D", "V s m-1"), ("base.cart.rate_per_volt", "m s-1 V-1"),
])
def test_a_swept_servo_gain_has_the_unit_of_its_table(path: str, unit: str) -> None:
    """joints[k].D had none (the schema's D is also a controller's LTI matrix, unitless) and
    "deg/s per V" was not spelt in UDUNITS."""
    assert parameter_unit(path) == unit
    assert field_unit(Target(path, parse(path), None, False)) == unit


def _paper_dict() -> dict[str, Any]:
    with open(paper_experiment_path(), "rb") as file:
        return tomllib.load(file)


@pytest.mark.parametrize(("make", "field"), [(_paper_dict, "motion"),
                                             (_servo_dict, "reference")])
def test_a_move_that_starts_at_or_after_t_end_is_warned(make: Any, field: str) -> None:
    """A joint whose move starts at t_end or later holds still in the whole run: it was
    accepted without a word."""
    d = make()
    d["simulation"].update(t_end=0.5, dt_out=0.01)  # both moves start at 0.5 s
    with pytest.warns(UserWarning) as caught:
        scenario_from_dict(d)
    assert [str(w.message) for w in caught] == [
        f"joints[{k}].{field}[0].start = 0.5 s is at or after simulation.t_end = 0.5 s: the "
        "joint does not move in the run; start the move earlier or raise t_end"
        for k in (0, 1)]
    d["simulation"]["t_end"] = 0.6  # the moves start within the run: no warning
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenario_from_dict(d)
    assert caught == []


def test_run_prints_the_warning_of_a_move_after_t_end(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    text = (EXAMPLES / "paper_servo.toml").read_text()
    (tmp_path / "s.toml").write_text(text.replace("t_end = 3.0", "t_end = 0.05").replace(
        "dt_out = 0.001", "dt_out = 0.05"))
    assert main(["run", str(tmp_path / "s.toml"), "--no-figures", "-o",
                 str(tmp_path / "out")]) == 0
    assert ("warning: joints[0].reference[0].start = 0.5 s is at or after simulation.t_end "
            "= 0.05 s") in capsys.readouterr().err


def _four_bar(**rocker: Any) -> dict[str, Any]:
    with open(EXAMPLES / "four_bar.toml", "rb") as file:
        d = tomllib.load(file)
    d["simulation"].update(t_end=0.02, dt_out=0.01)
    d["joints"][2].update(rocker)
    return d


def test_a_sweep_of_a_mechanism_that_cannot_close_is_refused(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    """The rocker's pivot 3 m away: every case failed with the same reason; now the sweep is
    refused before any case runs, with the run's message."""
    d = _four_bar(base_point=[3.0, 0.0])
    message = r"the base scenario cannot run: the mechanism does not close at t = 0"
    with pytest.raises(SweepError, match=message):
        sweep(d, grid={"links[1].EI": [20.0, 30.0]}, workers=1)
    with open(EXAMPLES / "four_bar.toml") as file:
        text = file.read()
    (tmp_path / "s.toml").write_text(text.replace("base_point = [0.3, 0.0]",
                                                  "base_point = [3.0, 0.0]"))
    monkeypatch.chdir(tmp_path)
    assert main(["sweep", "s.toml", "--grid", "links[1].EI=20,30", "-q"]) == 2
    assert "the base scenario cannot run: the mechanism does not close" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["s.toml"]


def test_a_far_guess_of_a_dependent_joint_still_closes_the_loop() -> None:
    """The coupler's guess 105° off (45° for -60°): the projection's Newton steps failed and
    the run was refused as 'does not close (residual 5e-11 m)'; the dependent joints are
    now brought to the loop by least squares first, landing on the closed assembly."""
    near = simulate(scenario_from_dict(_four_bar()), shapes=False)
    d = _four_bar()
    d["joints"][1]["initial_angle_deg"] = 45.0
    far = simulate(scenario_from_dict(d), shapes=False)
    assert far.metadata["closure_residual_relative"] < 1e-8
    for name in ("joint2_angle", "joint3_angle"):
        assert abs(far[name][0] - near[name][0]) < 1e-9


def test_a_case_whose_values_open_the_loop_fails_alone() -> None:
    """A rocker too long to reach the coupler (2 m) fails its case; the nominal one closes."""
    result = sweep(_four_bar(), grid={"links[2].length": [0.25, 2.0]}, workers=1)
    assert result.status.values.tolist() == ["ok", "failed"]
    assert "does not close at t = 0" in str(result.error.values[1])


def _slider_servo() -> dict[str, Any]:
    """The telescoping arm with its slider on a velocity servo."""
    with open(EXAMPLES / "telescoping_arm.toml", "rb") as file:
        d = tomllib.load(file)
    slider = d["joints"][1]
    for key in ("drive", "motion"):
        del slider[key]
    slider.update(drive="servo", servo="velocity_pid", P=50.0, D=1.0, rate_per_volt=0.1,
                  loop_gain=200.0, reference=[{"profile": "cycloidal", "from": 0.1, "to": 0.6,
                                              "start": 0.0, "duration": 2.0}])
    return d


@pytest.mark.parametrize(("path", "unit"), [
    ("joints[1].P", "V m-1"), ("joints[1].D", "V s m-1"), ("joints[1].I", "V m-1 s-1"),
    ("joints[1].rate_per_volt", "m s-1 V-1"), ("joints[1].loop_gain", "N s m-1"),
    ("joints[1].reference[0].to", "m"), ("joints[1].mass", "kg"),
    ("joints[0].motion[0].to_deg", "degree"),
])
def test_a_swept_slider_gain_has_the_units_per_metre(path: str, unit: str) -> None:
    """A slider's servo gains, swept or differentiated by their joints[k] path, had the
    revolute servo's units (V rad-1, N m s rad-1 ...)."""
    file = ScenarioFile(_slider_servo())
    assert field_unit(file.locate(path)) == unit
    assert parameter_unit(path, file) == unit


def test_a_slider_sweep_records_the_gains_per_metre() -> None:
    d = _slider_servo()
    d["simulation"].update(t_end=0.02, dt_out=0.01)
    result = sweep(d, grid={"joints[1].P": [40.0, 50.0], "joints[1].loop_gain": [200.0]},
                   workers=1)
    assert result.status.values.tolist() == ["ok", "ok"]
    assert result["joints[1].P"].attrs["units"] == "V m-1"
    assert result["joints[1].loop_gain"].attrs["units"] == "N s m-1"


def _cart_prescribed(start: float) -> dict[str, Any]:
    with open(EXAMPLES / "cart_beam.toml", "rb") as file:
        d = tomllib.load(file)
    cart = d["base"]["cart"]
    del cart["force"]
    cart.update(drive="prescribed", motion=[{"profile": "cycloidal", "from": 0.0, "to": 0.3,
                                             "start": start, "duration": 1.0}])
    return d


def test_a_cart_or_slider_move_after_t_end_is_warned() -> None:
    """A cart's (or a slider's) move starting at or after t_end was accepted without a word,
    where a revolute joint's was warned."""
    with pytest.warns(UserWarning) as caught:
        scenario_from_dict(_cart_prescribed(2.0))
    assert [str(w.message) for w in caught] == [(
        "base.cart.motion[0].start = 2 s is at or after simulation.t_end = 2 s: the cart does "
        "not move in the run; start the move earlier or raise t_end")]
    d = _slider_servo()
    d["joints"][0]["motion"][0]["start"] = 1.0  # the boom moves within the run
    d["joints"][1]["reference"][0]["start"] = 3.5
    with pytest.warns(UserWarning) as caught:
        scenario_from_dict(d)
    assert [str(w.message) for w in caught] == [(
        "joints[1].reference[0].start = 3.5 s is at or after simulation.t_end = 3 s: the "
        "slider does not move in the run; start the move earlier or raise t_end")]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scenario_from_dict(_cart_prescribed(1.0))
    assert caught == []


def _pushed_slider(force: float, model: str = "first_order") -> dict[str, Any]:
    """The telescoping arm with its slider pushed by a constant force (N), 0.1 s."""
    with open(EXAMPLES / "telescoping_arm.toml", "rb") as file:
        d = tomllib.load(file)
    del d["joints"][1]["motion"]
    d["joints"][1].update(drive="force", force=[{"profile": "step", "amplitude": force}])
    d["simulation"].update(t_end=0.1, dt_out=0.01, model=model)
    return d


def test_a_slider_pushed_off_its_travel_is_named_when_the_run_then_stops() -> None:
    """The slider left its travel before the first output sample and the run then blew up:
    the error said the first-order model was out of range (try method = "Radau"), not that
    the travel was left."""
    with pytest.raises(SimulationError, match=r"the slider of joint 2 left its travel \[0, "
                       r"0\.7\] m \(joints\[1\]\.travel\).*\(the end of the integrator's "
                       r"first step outside it: the run stopped there\)\. Widen "
                       r"joints\[1\]\.travel"):
        simulate(scenario_from_dict(_pushed_slider(1e6)))


def _travel_error(scenario: dict[str, Any]) -> tuple[float, float]:
    """The travel s (m) and time t (s) that a run's travel error names."""
    with pytest.raises(SimulationError) as caught:
        simulate(scenario_from_dict(scenario), shapes=False)
    message = str(caught.value)
    assert "the end of the integrator's first step outside it: the run stopped there" in message
    found = re.search(r"s = (\S+) m at t = (\S+) s", message)
    assert found, message
    return float(found[1]), float(found[2])


def _pushed_cart(force: float, model: str = "first_order", **settings: Any) -> dict[str, Any]:
    """cart_beam with its cart pushed by a constant force (N) for 2 s."""
    with open(EXAMPLES / "cart_beam.toml", "rb") as file:
        d = tomllib.load(file)
    d["base"]["cart"]["force"] = [{"profile": "step", "amplitude": force}]
    d["simulation"].update(model=model, dt_out=0.05, **settings)
    return d


@pytest.mark.parametrize(("model", "settings"), [("first_order", {}), ("nonlinear", {}),
                                                 ("nonlinear", {"step": 2e-3})])
def test_a_cart_that_leaves_its_travel_stops_the_run_there(model: str,
                                                          settings: dict[str, Any]) -> None:
    """The travel was checked on the output samples once the run had ended (or blown up): a
    cart pushed by 1e9 N ran 77 s of CPU before the integrator stalled, 950 m past its
    travel. The integrator now stops at its first step that ends outside the travel: s
    just past 0.5 m, t = √(2 · 0.5 m · 3.26 kg / 100 N) ≈ 0.18 s (the beam's swing aside)."""
    s, t = _travel_error(_pushed_cart(100.0, model, **settings))
    assert 0.5 < s < 0.52
    assert 0.15 < t < 0.2


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_a_slider_that_leaves_its_travel_stops_the_run_there(model: str) -> None:
    """As for a cart: the slider pushed by 200 N leaves [0, 0.7] m between two output samples
    (0.01 s apart) and the run stops at that step, not at the next sample."""
    s, t = _travel_error(_pushed_slider(200.0, model))
    assert 0.7 < s < 0.75
    assert abs(t / 0.01 - round(t / 0.01)) > 1e-3  # a step's end, not an output sample


def test_a_run_whose_equations_become_singular_is_a_simulation_error() -> None:
    """numpy's LinAlgError (a ValueError) from the nonlinear model's steps reached the user
    as "error: Matrix is singular to machine precision." with an input error's status."""
    with pytest.raises(SimulationError, match=r"the nonlinear run failed after t = \S+ s: its "
                       "equations became singular"):
        simulate(scenario_from_dict(_pushed_slider(1e6, "nonlinear")))


def test_a_travel_left_before_the_equations_became_singular_is_named() -> None:
    """The nonlinear model kept no state when its equations became singular inside a batch
    of steps: the slider that had left its travel a step before got the generic message.
    The batch's step ends reached before the singular step are read for the travel."""
    from flexlink.errors import StoppedRun
    from flexlink.simulation.nonlinear_forward import (
        check_travel_at_stop,
        nonlinear_forward_system,
    )
    from flexlink.solvers.gauss_forward import singular_stop

    scenario = scenario_from_dict(_pushed_slider(1.0, "nonlinear"))
    system = nonlinear_forward_system(scenario)
    column = int(system.free_travels()[0][0])
    y = np.full((4, system.n_y), np.nan)
    y[0], _ = system.initial_state()
    y[1] = y[0]
    y[2] = y[0]
    y[2, column] = 0.75  # left [0, 0.7] m at the second step end; singular in the third step
    with pytest.raises(StoppedRun) as caught:
        raise singular_stop(system, np.linalg.LinAlgError("singular"),
                            np.array([0.0, 0.001, 0.002, 0.003]), y)
    with pytest.raises(SimulationError, match=r"joints\[1\]\.travel\): s = 0\.75 m at "
                       r"t = 0\.002 s"):
        check_travel_at_stop(scenario, system, caught.value)
    y[2, column] = 0.5
    stop = singular_stop(system, np.linalg.LinAlgError("singular"),
                         np.array([0.0, 0.001, 0.002, 0.003]), y)
    assert stop.t == 0.002 and stop.y[column] == 0.5


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
@pytest.mark.parametrize("limit", [{"torque_limit": 0.1}, {"saturation_V": 0.001}])
def test_an_equilibrium_a_limited_servo_cannot_hold_is_refused(model: str,
                                                              limit: dict[str, float]) -> None:
    """The vertical arm needs 6.9 N·m to hold level: with its servo limited below that,
    initial = "equilibrium" started the run anyway and the arm fell from t = 0 (Newton's
    steps vanish where the clipped torque no longer moves; its residual did not)."""
    with open(EXAMPLES / "vertical_arm.toml", "rb") as file:
        d = tomllib.load(file)
    d["simulation"].update(t_end=0.05, dt_out=0.01, model=model)
    d["joints"][0].update(limit)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)  # the move starts after t_end
        scenario = scenario_from_dict(d)
    with pytest.raises(SimulationError, match='initial = "equilibrium": no static equilibrium'):
        simulate(scenario)


@pytest.mark.parametrize("at", [{"joint2": 0.3}, [0.0, 0.3]])
def test_a_slider_travel_given_as_a_linearisation_point_is_refused(at: Any) -> None:
    """`linearize --at joint2=0.3` (or `modes --grid joint2=…`) on a slider read 0.3 as
    degrees and then held the slider where it starts: every point the same plant, silently."""
    from flexlink.control import linearize

    with open(EXAMPLES / "telescoping_arm.toml", "rb") as file:
        d = tomllib.load(file)
    with pytest.raises(ValueError, match=r"at: joint2 is a slider \(joints\[1\] type = "
                       r"\"prismatic\"\): a configuration holds its travel where it starts"):
        linearize(scenario_from_dict(d), at=at)


@pytest.mark.parametrize(("k", "kind"), [(1, "Prismatic"), (0, "revolute")])
def test_a_joint_type_other_than_prismatic_is_one_clear_problem(k: int, kind: str) -> None:
    """type = "revolute" (or a misspelt "Prismatic") read the table as a revolute joint's:
    eight problems, "unknown key 'type'" among them, with the allowed keys listed three
    times over."""
    with open(EXAMPLES / "telescoping_arm.toml", "rb") as file:
        d = tomllib.load(file)
    d["joints"][k]["type"] = kind
    with pytest.raises(ScenarioError) as caught:
        scenario_from_dict(d)
    assert caught.value.problems == [(
        f"joints[{k}].type must be \"prismatic\" (a slider), got string '{kind}'; a revolute "
        "joint has no type: leave the key out")]


def test_the_allowed_keys_of_an_unknown_key_are_listed_once() -> None:
    d = _servo_dict()
    d["joints"][0].update(drive="prescribed", xyz=1.0)  # no such drive: every drive's keys
    with pytest.raises(ScenarioError) as caught:
        scenario_from_dict(d)
    message = next(m for m in caught.value.problems if "unknown key 'xyz'" in m)
    allowed = message.split("allowed: ")[1].rstrip(")").split(", ")
    assert len(allowed) == len(set(allowed)) > 5


@pytest.mark.parametrize(("path", "hint"), [
    ("joints[1].mas", " (did you mean joints[1].mass?)"),
    ("links[0].EJ", "; its numeric keys: length, mass_per_length, EI, tip_mass"),
])
def test_a_misspelt_sensitivity_field_is_named_with_its_neighbours(path: str, hint: str
                                                                   ) -> None:
    """A misspelt key said only "has no value in the scenario"."""
    from flexlink.simulation.sensitivities import simulate_with_sensitivities

    with open(EXAMPLES / "telescoping_arm.toml", "rb") as file:
        d = tomllib.load(file)
    with pytest.raises(SensitivityError, match=re.escape(f"{path} has no value in the "
                                                         f"scenario{hint}")):
        simulate_with_sensitivities(scenario_from_dict(d), [path])


def test_a_cart_under_a_closed_loop_pushed_off_its_travel_is_named() -> None:
    """The four-bar on a cart pushed by 1 MN leaves its travel at t ≈ 1.3 ms: the
    closed-loop run stalled after the cart had left it, and said the mechanism may have
    reached a toggle position. Whether a step ends beyond the travel before the loop meets
    a state it cannot close is a draw of the step sequence (at rtol 1.74e-4 the run stalls
    at 1.17 ms, still inside): over 11 tolerances about the default, the travel is named
    at the first step beyond it in the large majority, and no run goes on."""
    with open(EXAMPLES / "four_bar.toml", "rb") as file:
        d = tomllib.load(file)
    d["simulation"].update(t_end=0.3, dt_out=0.01)
    d["base"] = {"type": "cart", "mass": 1.0, "cart": {
        "travel": [-0.5, 0.5], "drive": "force",
        "force": [{"profile": "step", "amplitude": 1e6}]}}
    named = 0
    for rtol in np.geomspace(0.5e-4, 2e-4, 11):
        d["simulation"]["rtol"] = float(rtol)
        with pytest.raises(SimulationError) as error:
            simulate(scenario_from_dict(d), shapes=False)
        named += bool(re.search(r"the cart left its travel \[-0\.5, 0\.5\] m "
                                r"\(base\.cart\.travel\): s = 0\.5\d* m .*\(the end of the "
                                r"integrator's first step outside it: the run stopped there\)",
                                str(error.value)))
    assert named >= 9


def test_a_loops_plant_states_the_closed_angles_not_the_guesses() -> None:
    """`at={"joint2": -50}` on the four-bar: the coupler's angle is a guess the loop moves to
    its closed value; the operating point said -50° where the plant was made at ~-60.7°."""
    from flexlink import linearize

    op = linearize(scenario_from_dict(_four_bar()), at={"joint2": -50.0}).operating_point
    assert op["joint2_deg"] == pytest.approx(math.degrees(op["joint2_angle"]), abs=1e-12)
    assert abs(op["joint2_deg"] + 50.0) > 1.0
    assert op["joint1_deg"] == pytest.approx(90.0)


@pytest.mark.parametrize("example, named", [
    ("four_bar.toml", r"base_point.*\[\[closures\]\].*joints\[1\], joints\[2\] are driven"),
    ("paper_servo.toml", r"joints\[0\], joints\[1\] are driven; give joints\[0\]"),
    ("telescoping_arm.toml", r"fixed hub: joints\[1\] is a slider$"),
    ("cart_beam.toml", r"the base moves \(base.kind = 'cart'\); remove \[base\]")])
def test_optimize_names_what_is_not_prescribed(example: str, named: str) -> None:
    """`optimize` of a mechanism it cannot take said only 'needs prescribed joints on a fixed
    hub (no drive, no moving base)': now the base, the loop and the joints, and the fix; a
    slider is named as one ("joints[1] is driven or sliders" was said of one slider)."""
    from flexlink.scenario import load_scenario
    from flexlink.shaping import InfeasibleMove, optimize_move

    with pytest.raises(InfeasibleMove, match=named):
        optimize_move(load_scenario(EXAMPLES / example))


def _spinning_arm(torque: float, rate_deg_s: float, stiffening: bool = True) -> dict[str, Any]:
    """gravity_release spun up (its joint's initial rate) in a level plane, pushed by a
    constant torque (N·m), 0.1 s."""
    with open(EXAMPLES / "gravity_release.toml", "rb") as file:
        d = tomllib.load(file)
    joint = d["joints"][0]
    joint["torque"][0]["amplitude"] = torque
    joint["initial_rate_deg_s"] = rate_deg_s
    d["simulation"].update(t_end=0.1, dt_out=0.001, gravity=[0.0, 0.0],
                           geometric_stiffening=stiffening)
    return d


def test_a_forward_run_past_the_axial_load_the_first_order_model_holds_warns() -> None:
    """A forward run warned on its tip deflection only: the arm spun at 5000°/s (axial load
    parameter S = 13) and pushed by 20 N·m deflects 5.7% of its length (below the 10%
    warning) yet the first-order tip deflection is 17% of peak off the nonlinear model's
    (measured, rtol 1e-7). A 1e7 N·m torque (S ~ 1e10) ran without a word."""
    run = simulate(scenario_from_dict(_spinning_arm(20.0, 5000.0)), shapes=False)
    warning = run.metadata["validity_warning"]
    assert re.search(r"arm carries 100% of the inertia of a free coordinate that moves it, an "
                     r"axial load S = 13\.\d times its first mode's bending stiffness .* tip "
                     r"deflection of 5\.7% of its length: μ²·δ·√S = 0\.2\d+, beyond 0\.005, "
                     r".*model = \"nonlinear\"", warning), warning
    assert "deflected" not in warning  # the deflection alone is within its limit


def test_a_forward_run_that_is_silently_off_the_nonlinear_model_warns() -> None:
    """The arm spun at 2000°/s and pushed by 5 N·m (δ = 3.3%, S = 1.9, δ·S = 0.064 below
    the old limit 0.22) was 7.3% of peak off the nonlinear model without a warning: the
    forward limit is now calibrated on forward runs (μ²·δ·√S, μ = 1 here: the arm turns
    alone on its free pin). At 500°/s and 0.5 N·m (measured 0.35% off) it stays quiet."""
    run = simulate(scenario_from_dict(_spinning_arm(5.0, 2000.0)), shapes=False)
    warning = run.metadata["validity_warning"]
    assert re.search(r"μ²·δ·√S = 0\.04\d+, beyond 0\.005", warning), warning
    assert run.metadata["forward_validity_link"] == "arm"
    calm = simulate(scenario_from_dict(_spinning_arm(0.5, 500.0)), shapes=False)
    assert "validity_warning" not in calm.metadata


@pytest.mark.parametrize(("hub", "share"), [(0.0, 1.0), (0.2304, 0.5), (2.0736, 0.1)])
def test_a_links_share_of_its_free_joints_inertia(hub: float, share: float) -> None:
    """`ForwardSystem.inertia_shares`: the arm (0.6 kg/m over 0.8 m, 0.2 kg at its tip) has
    J = ρA L³/3 + m_t L² = 0.2304 kg·m² about its pin; a hub (motor_inertia) of J takes half,
    of 9 J nine tenths; a prescribed joint moves it with no free coordinate (0)."""
    from flexlink.simulation.forward import forward_system

    d = _spinning_arm(1.0, 0.0)
    d["joints"][0]["motor_inertia"] = hub
    system = forward_system(scenario_from_dict(d))
    zero = np.zeros((1, system.n_rigid))
    np.testing.assert_allclose(system.inertia_shares(zero, zero, zero), [share], rtol=1e-12)
    held = {**d, "joints": [{"motion": [{"profile": "hold", "angle_deg": 0.0}]}]}
    system = forward_system(scenario_from_dict(held))
    zero = np.zeros((1, system.n_rigid))
    assert system.inertia_shares(zero, zero, zero).tolist() == [0.0]


def test_a_forward_run_of_the_paper_model_under_axial_load_warns() -> None:
    """The paper's model (no geometric stiffening) leaves out the geometric stiffness of the
    axial load: forward runs of it were up to 10.8 S off the nonlinear model, so it warns
    beyond S = 0.0025 (3% of peak); a forward run did not say so."""
    run = simulate(scenario_from_dict(_spinning_arm(1.0, 1000.0, stiffening=False)),
                   shapes=False)
    assert re.search(r"arm carries an axial load S = \S+ times its first mode's bending "
                     r"stiffness \(axial_load_parameter\), beyond 0\.0025, .*set "
                     r"geometric_stiffening = true", run.metadata["validity_warning"])


def test_a_four_bar_of_the_paper_model_spun_fast_warns() -> None:
    """examples/four_bar.toml's crank spun up to 2880°/s on the paper's model: the
    coupler's mid-span deflection 7.2% of peak off the nonlinear model's, and no warning
    (S = 0.0066, below the old limit 0.017)."""
    with open(EXAMPLES / "four_bar.toml", "rb") as file:
        d = tomllib.load(file)
    d["joints"][0]["motion"][0]["to_rate_deg_s"] = 2880.0
    d["simulation"].update(t_end=1.0, geometric_stiffening=False)
    run = simulate(scenario_from_dict(d), shapes=False)
    assert "coupler carries an axial load" in run.metadata["validity_warning"]


@pytest.mark.parametrize("dt_out", [1e-2, 1e-3, 1e-4])
def test_a_tip_beyond_its_length_between_output_samples_is_refused(dt_out: float) -> None:
    """gravity_release pushed by 1e7 N·m: its tip passed its length within the first 0.1
    ms and came back as the spin stiffened the arm; at dt_out = 1 ms the run only warned
    (17% at the samples), at 0.1 ms it was refused. The integrator's steps are checked now:
    the same error at the same instant whatever dt_out."""
    with open(EXAMPLES / "gravity_release.toml", "rb") as file:
        d = tomllib.load(file)
    d["joints"][0]["torque"][0]["amplitude"] = 1e7
    d["simulation"].update(t_end=0.2, dt_out=dt_out)
    with pytest.raises(SimulationError, match=r"the tip deflection of arm exceeds its length "
                       r"\(0\.8 m\) at t = 4\.\d+e-05 s \(the end of the integrator's first "
                       r"step beyond it"):
        simulate(scenario_from_dict(d), shapes=False)


def _fast_swing(dt_out: float) -> dict[str, Any]:
    """A damped arm (ζ = 0.5) swung 90° in 20 ms, prescribed: its tip passes its length at
    t ≈ 0.0123 s and is back within 11% of it by 0.1 s."""
    return {"simulation": {"name": "swing", "t_end": 0.4, "dt_out": dt_out,
                           "geometric_stiffening": True},
            "links": [{"name": "arm", "length": 1.0, "mass_per_length": 0.8, "EI": 150.0,
                       "tip_mass": 0.3, "damping_ratio": 0.5, "modes": 3}],
            "joints": [{"motion": [{"profile": "cycloidal", "from_deg": 0.0, "to_deg": 90.0,
                                    "start": 0.0, "duration": 0.02}]}]}


@pytest.mark.parametrize("dt_out", [0.2, 0.1, 1e-3])
def test_a_prescribed_tip_beyond_its_length_between_output_samples_is_refused(
        dt_out: float) -> None:
    """Prescribed runs read the tips at their output samples only: at dt_out = 0.2 s (a
    Lawson run) the swing passed quietly (11% at the samples), at 0.1 s (Magnus: the move
    is too rough to tabulate at that sampling) it warned (59%), at 1 ms it was refused.
    Every integrator step is read now: the same error at the step beyond, whatever dt_out."""
    with pytest.raises(SimulationError, match=r"the tip deflection of arm exceeds its length "
                       r"\(1 m\) at t = 0\.012\d* s \(the end of the integrator's first step "
                       r"beyond it\): the first-order model is not valid here"):
        simulate(scenario_from_dict(_fast_swing(dt_out)), shapes=False)


def test_a_sampled_loop_with_prescribed_joints_refuses_a_tip_beyond_its_length() -> None:
    """examples/active_damping.toml (PPF at 1 kHz, first order: the closed-loop Lawson
    loop) with its moves done in 0.1 s and the links damped at ζ = 0.9: link 2's tip passes
    its length at t ≈ 0.154 s; sampled every 0.5 s the run passed quietly (11%)."""
    with open(EXAMPLES / "active_damping.toml", "rb") as file:
        d = tomllib.load(file)
    d["simulation"].update(t_end=1.0, dt_out=0.5, geometric_stiffening=True)
    for joint in d["joints"]:
        joint["motion"][0].update(start=0.1, duration=0.1)
    for link in d["links"]:
        link["damping_ratio"] = 0.9
    with pytest.raises(SimulationError, match=r"^closed loop unstable: the tip deflection of "
                       r"link2 exceeds its length \(0\.6 m\) at t = 0\.15\d* s \(the end of the "
                       r"integrator's first step beyond it\)"):
        simulate(scenario_from_dict(d), shapes=False)


@pytest.mark.parametrize("dt_out", [1e-2, 1e-3])
def test_a_sampled_controller_run_stopped_at_a_step_names_the_tip(dt_out: float) -> None:
    """The forward run of gravity_release pushed by 1e7 N·m (as above) under a sampled
    controller (a PPF loop from the tip deflection to a piezo patch, 1 kHz): the integrator
    stops at the first step whose tip passes its length, a stop the loop's runs take for a
    cart or slider leaving its travel; the error names the tip and the instant, as a closed
    loop that ran away, not the travel or a loop "growing without bound"."""
    with open(EXAMPLES / "gravity_release.toml", "rb") as file:
        d = tomllib.load(file)
    d["joints"][0]["torque"][0]["amplitude"] = 1e7
    d["simulation"].update(t_end=0.2, dt_out=dt_out)
    d["actuators"] = [{"name": "patch", "kind": "piezo", "link": "arm", "x_start": 0.02,
                       "x_end": 0.07, "width": 0.025, "thickness": 0.005, "E_p": 30.33e9,
                       "d31": 265e-12, "limit": 200.0}]
    d["controllers"] = [{"name": "ppf", "kind": "ppf", "sensor": "tip_deflection",
                         "actuator": "patch", "frequency_hz": 8.0, "damping": 0.3,
                         "gain": 10.0, "sample_rate": 1000.0}]
    with pytest.raises(SimulationError, match=r"^closed loop unstable: the tip deflection of "
                       r"arm exceeds its length \(0\.8 m\) at t = 4\.\d+e-05 s \(the end of the "
                       r"integrator's first step beyond it: the run stopped there\)"):
        simulate(scenario_from_dict(d), shapes=False)


@pytest.mark.parametrize(("field", "value", "named"), [
    ("torque", 1e300, r"joints\[0\]\.torque = 1e\+300 N·m"),
    ("gravity", 1e200, r"simulation\.gravity = \[0, -1e\+200\] m/s²")])
def test_an_absurd_load_is_named_as_the_cause(field: str, value: float, named: str) -> None:
    """A 1e300 N·m torque or 1e200 m/s² of gravity: "the time step collapsed … try method =
    "Radau"", a hint about the integrator for a load beyond any model."""
    with open(EXAMPLES / "gravity_release.toml", "rb") as file:
        d = tomllib.load(file)
    if field == "torque":
        d["joints"][0]["torque"][0]["amplitude"] = value
    else:
        d["simulation"]["gravity"] = [0.0, -value]
    with pytest.raises(SimulationError) as error:
        simulate(scenario_from_dict(d), shapes=False)
    message = str(error.value)
    assert re.search(r"under loads far beyond the first-order model's range: .* arm's tip .* "
                     r"its length if held steady \(.*" + named + r".*\); check their values "
                     r"and units", message), message
    assert "Radau" not in message


def test_a_stall_of_the_compiled_integrator_does_not_suggest_scipys_radau() -> None:
    """An absurd mass_per_length stalled the compiled Radau IIA at t = 0 and the advice was
    to try method = "Radau" (scipy's, the same family); explicit methods are the ones to
    leave."""
    from types import SimpleNamespace

    from flexlink.solvers.forward import _stall_message

    with open(EXAMPLES / "gravity_release.toml", "rb") as file:
        d = tomllib.load(file)
    d["links"][0]["mass_per_length"] = 1e-12
    with pytest.raises(SimulationError, match="stalled") as error:
        simulate(scenario_from_dict(d), shapes=False)
    message = str(error.value)
    assert "Radau" not in message and "check their values and units" in message, message
    stiffened = SimpleNamespace(geometric_stiffening=True)
    assert 'try the default "lawson"' in _stall_message(stiffened, 1.0, "x", "RK45")
    assert "try" not in _stall_message(stiffened, 1.0, "x", "Radau")


TORQUE_NAMED = (r"'s tip 3\.5\d*e\+299 times its length if held steady \(joints\[1\]\.torque "
                r"= 1e\+300 N·m")
GRAVITY_NAMED = (r" across its span 4\.6\d* times its length if held steady "
                 r"\(simulation\.gravity = \[0, -1e\+06\] m/s²")


@pytest.mark.parametrize(("field", "named"), [
    ("torque", TORQUE_NAMED), ("gravity", GRAVITY_NAMED)])
def test_an_absurd_load_on_a_closed_loop_is_named_not_taken_for_a_toggle(
        field: str, named: str) -> None:
    """The four-bar with 1e300 N·m on its coupler's pin (stalls at t = 0) or 1e6 m/s² of
    gravity (at 0.9 ms) was told the mechanism may have reached a toggle position: the loads
    are named as on an open chain, from the accelerations the closed loop allows and the
    largest deflection they would hold, across the span of the coupler the loop holds at
    both ends (its tip deflection is zero: 9.81 m/s² bends it 4.5e-5 of its length across
    its span, 1e6 m/s² 4.6 times)."""
    with open(EXAMPLES / "four_bar.toml", "rb") as file:
        d = tomllib.load(file)
    d["simulation"].update(t_end=0.3, dt_out=0.01)
    if field == "torque":
        d["joints"][1] = {"drive": "torque", "initial_angle_deg": -60.0,
                          "torque": [{"profile": "step", "amplitude": 1e300}]}
    else:
        d["simulation"]["gravity"] = [0.0, -1e6]
    with pytest.raises(SimulationError) as error:
        simulate(scenario_from_dict(d), shapes=False)
    message = str(error.value)
    assert re.search(r"under loads far beyond the first-order model's range: .* coupler"
                     + named + r"\); check their values and units", message), message
    assert "toggle" not in message


@pytest.mark.parametrize(("guess", "closed"), [(-20.0, -90.0), (20.0, 90.0),
                                               (-160.0, -90.0), (160.0, 90.0)])
def test_a_nonlinear_loop_with_a_slider_closes_on_the_branch_nearest_the_guess(
        guess: float, closed: float) -> None:
    """A slider in the chain of a closed loop (tests/validation/test_nonlinear_slider_loops
    .py's mechanism): the nonlinear model closes it on its own kinematics, where the
    nearest-branch rule did not apply: the rod guessed at -20° closed at 1350° (four turns
    away), at 20° at -1350°, at ±160° at ±1530°. Now as the first-order model: within half
    a turn of the guess, on the nearest branch."""
    import sys

    sys.path.insert(0, str(EXAMPLES.parent))
    from tests.validation.test_nonlinear_slider_loops import slider_loop_case

    d = slider_loop_case(t_end=0.004)
    d["joints"][2]["initial_angle_deg"] = guess
    run = simulate(scenario_from_dict(d), shapes=False)
    assert math.degrees(run["joint3_angle"][0]) == pytest.approx(closed, abs=1e-6)
    d["simulation"]["model"] = "first_order"
    twin = simulate(scenario_from_dict(d), shapes=False)
    assert math.degrees(twin["joint3_angle"][0]) == pytest.approx(closed, abs=1e-6)


@pytest.mark.parametrize(("guess", "closed"), [
    ((-60.0, 20.0), (-60.655, 98.857)), ((60.0, 100.0), (-60.655, 98.857)),
    ((-150.0, 100.0), (-60.655, 98.857)), ((300.0, 460.0), (299.345, 458.857)),
    ((-60.0, -100.0), (-156.215, -135.727))])
def test_a_loop_closes_on_the_branch_nearest_the_guesses(guess: tuple[float, float],
                                                        closed: tuple[float, float]) -> None:
    """The four-bar's coupler and rocker guessed far off: the loop closed 2 turns away
    ((-60°, 20°) → (-876°, -856°)) or on the other assembly branch though the guesses were
    nearer this one ((60°, 100°) → (204°, 224°)). The dependent angles now close within half
    a turn of their guesses, on the branch nearest them (the mirror branch (-156°, -136°)
    where the guesses are nearer it)."""
    d = _four_bar(initial_angle_deg=guess[1])
    d["joints"][1]["initial_angle_deg"] = guess[0]
    run = simulate(scenario_from_dict(d), shapes=False)
    angles = [math.degrees(run[f"joint{k}_angle"][0]) for k in (2, 3)]
    np.testing.assert_allclose(angles, closed, atol=1e-3)


@pytest.mark.parametrize("example", ["gravity_release.toml", "four_bar.toml"])
def test_a_nanosecond_run_keeps_its_two_ends(example: str) -> None:
    """t_end = dt_out = 1e-9 s: Radau IIA merged instants closer than 1e-9 s, so the run's
    two ends made one node and the forward run crashed with numpy's "cannot reshape array
    of size 0" (a ValueError: an input error's status)."""
    with open(EXAMPLES / example, "rb") as file:
        d = tomllib.load(file)
    d["simulation"].update(t_end=1e-9, dt_out=1e-9)
    run = simulate(scenario_from_dict(d), shapes=False)
    assert run.time.size == 2


def test_a_closed_loop_tip_beyond_its_length_is_refused_at_the_step() -> None:
    """The four-bar with a soft crank (EI 0.005 N·m², the paper's model) spun faster than
    the crank's first frequency: its tip diverges and passes the crank's length at t ≈
    0.354 s. With one output interval of 0.4 s the closed-loop run was refused only at the
    sample t = 0.4 s; the integrator's steps are checked now (as the open chain's)."""
    with open(EXAMPLES / "four_bar.toml", "rb") as file:
        d = tomllib.load(file)
    d["links"][0].update(rigid=False, EI=0.005, modes=2, damping_ratio=0.01)
    d["simulation"].update(t_end=0.4, dt_out=0.4, geometric_stiffening=False)
    with pytest.raises(SimulationError, match=r"the tip deflection of crank exceeds its length "
                       r"\(0\.1 m\) at t = 0\.35\d+ s \(the end of the integrator's first "
                       r"step beyond it"):
        simulate(scenario_from_dict(d), shapes=False)


def _four_bar_benchmark(rpm: float, coupler_ei: float) -> dict[str, Any]:
    """examples/four_bar_benchmark.toml spun up to ``rpm``, the coupler's EI times
    ``coupler_ei`` (its thickness scaled, its mass kept)."""
    with open(EXAMPLES / "four_bar_benchmark.toml", "rb") as file:
        d = tomllib.load(file)
    d["joints"][0]["motion"][0]["to_rate_deg_s"] = 6.0 * rpm
    d["links"][1]["thickness"] *= coupler_ei ** (1.0 / 3.0)
    return d


@pytest.mark.parametrize(("rpm", "coupler_ei", "link"),
                         [(200.0, 0.3, "coupler"), (300.0, 1.0, "follower")])
def test_a_soft_link_held_at_both_ends_by_a_loop_warns(rpm: float, coupler_ei: float,
                                                       link: str) -> None:
    """A link a closed loop holds at both ends has no tip deflection, so no tip-based check
    saw it: the benchmark four-bar with its coupler 0.3 times as stiff at 200 rpm was 7.3%
    of peak off the nonlinear model (mid-span deflections), at 300 rpm as built 11% (the
    closest to its first frequency), both without a warning. The span deflection per length
    over 1 − S (S the axial load over the buckling load) names the link, the measure, the
    limit and the fix."""
    run = simulate(scenario_from_dict(_four_bar_benchmark(rpm, coupler_ei)), shapes=False)
    warning = run.metadata["validity_warning"]
    assert re.search(rf"{link}, held at both ends by the closed loop, joined to another "
                     r"elastic link, deflected [\d.]+% of its length across its span under "
                     r"an axial load S = [\d.]+ of its buckling load .*δ_s/\(1 − S\) = "
                     r"0\.03\d+, beyond 0\.006, .*model = \"nonlinear\"", warning), warning
    assert run.metadata["loop_validity_link"] == link


def test_a_soft_rod_of_a_slider_crank_warns() -> None:
    """examples/slider_crank.toml spun up to 100 rad/s with its rod 0.1 times as stiff: the
    rod's axial load passes its buckling load (S > 1) and the run was 120% of peak off the
    nonlinear model without a warning; its crank is rigid, so the rod's limit is 0.05."""
    with open(EXAMPLES / "slider_crank.toml", "rb") as file:
        d = tomllib.load(file)
    d["joints"][0]["motion"][0]["to_rate_deg_s"] = math.degrees(100.0)
    d["links"][1]["EI"] *= 0.1
    run = simulate(scenario_from_dict(d), shapes=False)
    assert re.search(r"^rod, held at both ends by the closed loop, deflected [\d.]+% of its "
                     r"length .*δ_s/\(1 − S\) = inf, beyond 0\.05, .*model = \"nonlinear\"",
                     run.metadata["validity_warning"]), run.metadata["validity_warning"]


@pytest.mark.parametrize(("example", "link"), [
    ("four_bar.toml", "coupler"), ("four_bar_benchmark.toml", "follower"),
    ("slider_crank.toml", "rod"), ("slider_crank_benchmark.toml", "rod")])
def test_the_shipped_loops_within_their_validity_stay_quiet(example: str, link: str) -> None:
    """The shipped closed loops, measured within 1% of peak of the nonlinear model
    (scripts/forward_validity_calibration.py: four_bar 0.001% at 2880°/s, the benchmark
    four-bar 0.96%, slider_crank 0.95%), carry their held link's measure and no warning."""
    run = simulate(load_scenario(EXAMPLES / example), shapes=False)
    assert run.metadata["loop_validity_link"] == link
    assert 0.0 < run.metadata["loop_validity_measure"] < run.metadata["loop_validity_limit"]
    assert "validity_warning" not in run.metadata, run.metadata["validity_warning"]


def _unheld_start(example: str, model: str, joint: dict[str, Any] | None = None,
                  angle: float | None = None) -> dict[str, Any]:
    with open(EXAMPLES / example, "rb") as file:
        d = tomllib.load(file)
    d["simulation"].update(t_end=0.05, dt_out=0.01, model=model, initial="equilibrium",
                           gravity=[0.0, -9.81])
    if joint is not None:
        d["joints"][0] = joint
    if angle is not None:
        d["joints"][0]["initial_angle_deg"] = angle
    return d


_FREE_CRANK = {"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.0}],
               "initial_angle_deg": 90.0}


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
@pytest.mark.parametrize(("example", "joint", "angle", "rate"), [
    ("gravity_release.toml", None, 80.0, "2.6 rad/s²"),  # an arm 10° off upright, free pin
    ("four_bar.toml", _FREE_CRANK, None, "14.1 rad/s²")])  # a loop on an unheld crank
def test_an_equilibrium_start_with_a_joint_nothing_holds_is_refused(
        model: str, example: str, joint: dict[str, Any] | None, angle: float | None,
        rate: str) -> None:
    """initial = "equilibrium" with a torque-driven or free joint that the loads turn at
    t = 0 (an inverted arm on a free pin, a four-bar whose crank nothing holds under gravity)
    balanced only the links' deflection and started the run falling, without a word."""
    scenario = scenario_from_dict(_unheld_start(example, model, joint, angle))
    with pytest.raises(SimulationError, match=re.escape(
            'initial = "equilibrium": no static equilibrium at t = 0: joints[0], held by no '
            f"servo, spring or prescribed motion, starts accelerating at {rate}")):
        simulate(scenario)


def test_a_plant_about_a_start_an_unheld_joint_leaves_is_frozen_time_not_refused() -> None:
    """The linearisation of that start is still made, and says it is no equilibrium."""
    from flexlink.control import linearize

    scenario = scenario_from_dict(_unheld_start("gravity_release.toml", "first_order",
                                                angle=80.0))
    for at in (0.0, {"joint1": 80.0}):
        assert not linearize(scenario, at=at).equilibrium


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
@pytest.mark.parametrize("angle", [90.0, -90.0])
def test_an_unheld_joint_already_balanced_starts_in_equilibrium(model: str,
                                                               angle: float) -> None:
    """The free pin upright or hanging: an equilibrium, which stays put."""
    r = simulate(scenario_from_dict(_unheld_start("gravity_release.toml", model,
                                                  angle=angle)))
    assert np.ptp(r["joint1_angle"]) < 1e-12


def test_the_api_takes_the_path_of_a_scenario_file() -> None:
    """flexlink.simulate("arm.toml") (as flexlink.sweep takes a path) failed with
    "AttributeError: 'str' object has no attribute 'chain'"; a dict or None now gets a
    TypeError that says what to give."""
    from flexlink.control import frozen_modes, linearize, mode_convergence

    path = EXAMPLES / "gravity_release.toml"
    assert simulate(str(path), shapes=False).metadata["path"] == "forward"
    assert linearize(path).A.shape == linearize(load_scenario(path)).A.shape
    assert frozen_modes(path, times=[0.0]).frequency_hz.shape[0] == 1
    assert mode_convergence(path).modes == (4,)
    for call in (simulate, linearize, frozen_modes, mode_convergence):
        with pytest.raises(TypeError, match=f"{call.__name__}: expected a Scenario "
                           r"\(flexlink.load_scenario\(path\)\) or the path of a scenario "
                           "file, got dict"):
            call({"simulation": {}})
    with pytest.raises(TypeError, match="scenario_from_dict"):
        load_scenario({"simulation": {}})  # type: ignore[arg-type]


def test_an_unknown_channel_of_results_is_named_with_the_channels() -> None:
    """results["tip_deflexion"] raised a bare KeyError('tip_deflexion')."""
    r = simulate(load_scenario(EXAMPLES / "gravity_release.toml"), shapes=False)
    with pytest.raises(KeyError, match=r"no channel 'tip_deflexion' \(did you mean "
                       r"'tip_deflection'\?\); channels: tip_deflection, joint1_angle"):
        r["tip_deflexion"]


def test_measured_angles_inside_motion_are_sent_to_the_joint() -> None:
    """motion = [{csv = "angles.csv"}] (the README's "or measured angles: csv = …" read as a
    segment) was told only "missing required key 'profile'"."""
    d = _paper_dict()
    d["joints"][0]["motion"] = [{"csv": "angles.csv", "angle_column": "beta1"}]
    with pytest.raises(ScenarioError, match=re.escape(
            "joints[0].motion[0]: measured angles are not a motion segment: give csv (and "
            "time_column, angle_column, lowpass_hz) on joints[0] itself, in place of its "
            "motion")):
        scenario_from_dict(d)
