"""The trajectory optimiser (flexlink.shaping.optimize) on a cheap arm: gradient against
central differences, reproducibility, limits, infeasible requests."""

from __future__ import annotations

import dataclasses
import json
import math
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from flexlink.errors import SimulationError
from flexlink.model import Chain, Link, Scenario, SimulationSettings
from flexlink.motion import Cycloidal, Harmonic, Hold
from flexlink.shaping import Limits, optimize_move
from flexlink.shaping.optimize import (
    InfeasibleMove,
    Problem,
    continuous_peaks,
    fd_gradient,
    grid_margin,
    grid_size,
    joint_moves,
)


def _arm(duration: float = 0.6) -> Scenario:
    """One flexible link (two assumed modes) slewed 30°, plus a held rigid link."""
    links = (Link("beam", 1.0, 0.5, 40.0, damping_ratio=0.01, modes=2),
             Link("stub", 0.2, 0.3, 1.0, modes=0))
    joints = (Cycloidal(0.0, 30.0, 0.1, duration), Hold(0.0))
    # Magnus: the Lawson integrator's table would hand this small system to Magnus anyway
    return Scenario(Chain(links, joints), settings=SimulationSettings(t_end=2.0, dt_out=0.01,
                                                                      method="magnus"))


def test_gradient_matches_central_differences() -> None:
    scenario = _arm()
    problem = Problem(scenario, joint_moves(scenario), 2, [(1.0, False)], 0.005)
    x = np.array([0.1, -0.05, 0.08, 0.02])

    def many(points):
        return [problem.evaluate(p)[0] for p in points]

    r0, plus, _ = fd_gradient(many, x, 1e-5)
    forward = np.stack([(p - r0).ravel() / 1e-5 for p in plus], axis=1)
    _, plus, minus = fd_gradient(many, x, 1e-3, central=True)
    central = np.stack([(p - m).ravel() / 2e-3 for p, m in zip(plus, minus, strict=True)], axis=1)
    np.testing.assert_allclose(forward, central, rtol=0, atol=1e-3 * np.abs(central).max())
    # and the energy gradient 2 Jᵀ r against central differences of the energy itself
    energy = lambda y: float(np.sum(problem.evaluate(y)[0] ** 2))
    grad = 2.0 * forward.T @ r0.ravel()
    h = 1e-4
    fd = [(energy(x + h * e) - energy(x - h * e)) / (2 * h) for e in np.eye(x.size)]
    np.testing.assert_allclose(grad, fd, rtol=2e-3, atol=1e-3 * np.abs(fd).max())


def test_optimised_move_is_reproducible_within_limits_and_cancels_vibration() -> None:
    scenario = _arm()
    limits = Limits(rate_deg_s=[110.0, 10.0], acceleration_deg_s2=600.0, torque_Nm=5.0)
    runs = [optimize_move(scenario, limits=limits, harmonics=2, seed=3, workers=w,
                          stiffening="scenario", robust=0.0) for w in (1, 2)]
    a, b = runs  # same seed, one process or two: the same answer
    np.testing.assert_allclose(np.ravel(list(a.coefficients.values())),
                               np.ravel(list(b.coefficients.values())), atol=1e-9)
    assert list(a.coefficients) == [0]  # the held joint is left alone
    assert a.energy[0] < 1e-3 * a.energy_cycloidal[0]
    motion = a.scenario.chain.joints[0]
    assert isinstance(motion, Harmonic) and (motion.from_deg, motion.to_deg) == (0.0, 30.0)
    t = np.linspace(0.0, 1.0, 20001)
    angle, rate, acc = motion.evaluate(t)
    assert math.degrees(np.abs(rate).max()) <= 110.0 * (1 + 1e-3)
    assert math.degrees(np.abs(acc).max()) <= 600.0 * (1 + 1e-3)
    assert max(a.peaks["torque_Nm"]) <= 5.0 * (1 + 1e-3)
    assert angle[-1] == pytest.approx(math.radians(30.0), abs=1e-12)


@pytest.mark.parametrize(("kwargs", "message"), [
    ({"duration": 0.2, "limits": Limits(rate_deg_s=100.0)},
     (r"joint 1: duration 0.2 s is shorter than its rate limit allows: 30° at ≤ 100°/s "
      r"takes at least 0.3 s")),
    ({"duration": 0.2, "limits": Limits(acceleration_deg_s2=1000.0)},
     "shorter than its acceleration limit allows"),
    ({"limits": Limits(torque_Nm=0.0)}, "torque_Nm of joint 1 must be > 0"),
    ({"limits": Limits(rate_deg_s=[100.0, -1.0])}, "rate_deg_s of joint 2 must be > 0"),
    ({"limits": Limits(rate_deg_s=[1.0, 2.0, 3.0])}, "one limit for all joints or one per joint"),
    ({"duration": -1.0}, "duration must be > 0 s"),
    ({"robust": 0.7}, r"robust must be in \[0, 0.5\)"),
    ({"stiffening": "maybe"}, "stiffening must be one of"),
])
def test_infeasible_requests_name_the_limit(kwargs: dict, message: str) -> None:
    with pytest.raises(InfeasibleMove, match=message):
        optimize_move(_arm(), workers=1, **kwargs)


def test_an_unreachable_torque_limit_is_reported() -> None:
    with pytest.raises(InfeasibleMove, match="the torque limit binds: joint 1 needs a torque "
                                             r"of .* N·m > torque limit 0.01 N·m"):
        optimize_move(_arm(), limits=Limits(torque_Nm=0.01), harmonics=1, workers=1,
                      max_iterations=5, stiffening="scenario")


ARM_TOML = """
[simulation]
t_end = 1.5
dt_out = 0.01
[[links]]
name = "beam"
length = 1.0
mass_per_length = 0.5
EI = 40.0
damping_ratio = 0.01
modes = 2
[[joints]]
motion = [{ profile = "cycloidal", from_deg = 0, to_deg = 30, start = 0.1, duration = 0.6 }]
"""


def test_optimize_command_writes_a_scenario_that_reproduces_the_move(tmp_path: Path) -> None:
    from flexlink.cli import main
    from flexlink.scenario import load_scenario

    path = tmp_path / "arm.toml"
    path.write_text(ARM_TOML)
    out = tmp_path / "opt"
    status = main(["optimize", str(path), "-o", str(out), "--harmonics", "1", "--workers", "1",
                   "--stiffening", "scenario", "--rate-limit", "120", "--no-figures"])
    assert status == 0
    summary = json.loads((out / "summary.json").read_text())
    residual = summary["residual_tip_deflection_m"]["first_order"]
    assert residual["optimised"] < 0.1 * residual["cycloidal"]
    joint = load_scenario(out / "optimized.toml").chain.joints[0]
    assert isinstance(joint, Harmonic)
    assert [*joint.cosine, *joint.sine] == summary["optimiser"]["coefficients"][0]
    table = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True)
    assert np.abs(table["joint1_rate_deg_s"]).max() <= 120.0 * (1 + 1e-3)


def test_optimize_command_refuses_an_infeasible_duration(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    from flexlink.cli import main

    path = tmp_path / "arm.toml"
    path.write_text(ARM_TOML)
    status = main(["optimize", str(path), "-o", str(tmp_path / "x"), "--duration", "0.1",
                   "--rate-limit", "100"])
    assert status == 2
    assert "shorter than its rate limit allows" in capsys.readouterr().err
    assert not (tmp_path / "x").exists()


def test_rate_and_acceleration_limits_hold_in_continuous_time() -> None:
    """The acceleration limit binds (the cycloid's peak is 524°/s²): the answer's maxima,
    evaluated on 200 001 instants, are within every limit without tolerance."""
    limits = Limits(rate_deg_s=[105.0, 10.0], acceleration_deg_s2=500.0)
    result = optimize_move(_arm(), limits=limits, harmonics=3, workers=1, robust=0.0,
                           stiffening="scenario")
    motion = result.scenario.chain.joints[0]
    _, rate, acc = motion.evaluate(np.linspace(0.1, 0.7, 200001))
    assert math.degrees(np.abs(rate).max()) <= 105.0
    assert math.degrees(np.abs(acc).max()) <= 500.0
    assert math.degrees(np.abs(acc).max()) >= 0.98 * 500.0  # the limit is active
    assert result.peaks["acceleration_deg_s2"][0] == pytest.approx(
        math.degrees(np.abs(acc).max()), rel=1e-5)


def test_grid_margin_bounds_the_maximum_between_instants() -> None:
    """A trigonometric polynomial of degree n exceeds its largest value on the check instants
    by at most the margin: checked on random coefficients (densely evaluated)."""
    scenario = _arm()
    problem = Problem(scenario, joint_moves(scenario), 4, [(1.0, False)], 0.005)
    rng = np.random.default_rng(1)
    worst = 0.0
    for _ in range(200):
        x = rng.uniform(-1.0, 1.0, problem.size)
        R, r0, A, a0 = problem.kinematic_rows()
        coarse = max(np.abs(R @ x + r0).max(), 1e-300), max(np.abs(A @ x + a0).max(), 1e-300)
        dense = continuous_peaks(problem, x, refine=50)
        worst = max(worst, dense[0][0] / coarse[0] - 1.0, dense[1][0] / coarse[1] - 1.0)
    assert grid_size(4) == 375
    assert 0.0 <= worst <= grid_margin(4) / (1.0 - grid_margin(4))


def test_a_failed_trial_is_a_rejected_step(monkeypatch: pytest.MonkeyPatch) -> None:
    """Trials beyond |x| = 0.02 'diverge': the search goes on inside that region and ends
    without an exception, with a lower residual than the cycloid's."""
    evaluate = Problem.evaluate

    def diverging(self: Problem, x: np.ndarray):
        if np.abs(x).max() > 0.02:
            raise SimulationError("the tip deflection of beam exceeds its length")
        return evaluate(self, x)

    monkeypatch.setattr(Problem, "evaluate", diverging)
    result = optimize_move(_arm(), limits=Limits(rate_deg_s=120.0), harmonics=2, workers=1,
                           robust=0.0, stiffening="scenario")
    assert max(abs(v) for c in result.coefficients.values() for v in (*c[0], *c[1])) <= 0.02
    assert result.energy[0] < 0.9 * result.energy_cycloidal[0]


def test_infeasible_kinematics_name_the_binding_limit() -> None:
    """30° in 0.33 s: rate ≥ 90.9°/s for any profile, so 95°/s passes the bang-bang bound,
    but the cycloid-plus-harmonics profiles need more: the rate limit is named, with the
    shortest duration it allows; the acceleration limit alone (2000°/s²) would allow it."""
    with pytest.raises(InfeasibleMove, match=r"joint 1: 30° in 0.33 s needs, with the "
                                             r"optimiser's profiles \(cycloid plus 4 "
                                             r"harmonics\), a peak rate of at least 109.1°/s > "
                                             r"rate limit 95°/s: the rate limit binds; the "
                                             r"shortest such move within it takes 0.3793 s"):
        optimize_move(_arm(), duration=0.33, limits=Limits(rate_deg_s=[95.0, 10.0],
                                                           acceleration_deg_s2=2000.0),
                      workers=1)


def test_rate_and_acceleration_binding_together_are_named() -> None:
    """30° in 0.5 s: rate ≤ 80°/s alone and acceleration ≤ 600°/s² alone each allow the
    move, together they do not; the message says so with the shortest duration, which is
    feasible (and 1 % shorter is not)."""
    limits = Limits(rate_deg_s=[80.0, 10.0], acceleration_deg_s2=600.0)
    for alone in (Limits(rate_deg_s=[80.0, 10.0]), Limits(acceleration_deg_s2=600.0)):
        optimize_move(_arm(), duration=0.5, limits=alone, workers=1, max_iterations=1,
                      robust=0.0, stiffening="scenario")
    with pytest.raises(InfeasibleMove, match="the rate and acceleration limits bind together; "
                                             "the shortest move within both takes 0.5508 s"
                       ) as info:
        optimize_move(_arm(), duration=0.5, limits=limits, workers=1)
    shortest = float(str(info.value).split("takes ")[1].split(" s")[0])
    optimize_move(_arm(), duration=shortest * 1.0001, limits=limits, workers=1,
                  max_iterations=1, robust=0.0, stiffening="scenario")
    with pytest.raises(InfeasibleMove, match="bind together"):
        optimize_move(_arm(), duration=shortest * 0.99, limits=limits, workers=1)


SOFT_TOML = """
[simulation]
t_end = 1.5
dt_out = 0.01
geometric_stiffening = {stiffening}
[[links]]
name = "beam"
length = 1.0
mass_per_length = 0.5
EI = 0.5
damping_ratio = 0.01
modes = 2
[[joints]]
motion = [{{ profile = "cycloidal", from_deg = 0, to_deg = 60, start = 0.1, duration = 0.5 }}]
"""


def _cli(tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, *options: str
         ) -> tuple[int, str, str, Path]:
    from flexlink.cli import main

    path = tmp_path / "arm.toml"
    path.write_text(text)
    out = tmp_path / "opt"
    try:
        status = main(["optimize", str(path), "-o", str(out), "--workers", "1", "--no-figures",
                       *options])
    except SystemExit as exc:  # an option's value refused by the parser (flexlink.options)
        status = exc.code
    captured = capsys.readouterr()
    assert "Traceback" not in captured.out + captured.err
    return status, captured.out, captured.err, out


def test_a_plant_that_diverges_on_the_cycloid_is_left_out(monkeypatch: pytest.MonkeyPatch
                                                           ) -> None:
    """The second plant of --stiffening both diverging on the cycloid is left out and the
    result says so; the other plants are optimised as usual."""
    rows = Problem.plant_rows

    def paper_model_diverges(self: Problem, i: int, x: np.ndarray):
        if not self.plant_scenarios[i].settings.geometric_stiffening:
            raise SimulationError("the tip deflection of beam exceeds its length")
        return rows(self, i, x)

    monkeypatch.setattr(Problem, "plant_rows", paper_model_diverges)
    scenario = _arm()
    stiff = dataclasses.replace(scenario, settings=dataclasses.replace(
        scenario.settings, geometric_stiffening=True))
    result = optimize_move(stiff, limits=Limits(rate_deg_s=120.0), harmonics=1, workers=1)
    assert result.plants == [(1.0, True), (0.9, True), (1.1, True)]
    assert len(result.notes) == 3
    assert result.notes[0].startswith("left out the first-order model without geometric "
                                      "stiffening: it diverges on the cycloidal move")


def test_the_scenario_model_diverging_on_the_cycloid_is_refused(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """A soft link spun faster than its first frequency in the paper's model: exit 2, the
    message names the model and the fix, no folder."""
    status, _, err, folder = _cli(tmp_path, capsys, SOFT_TOML.format(stiffening="false"),
                                    "--harmonics", "2")
    assert status == 2
    assert "already fails in the scenario's model (first-order model without geometric " \
           "stiffening)" in err
    assert "geometric_stiffening = true" in err
    assert not folder.exists()


def test_robustness_band_is_reported_in_the_scenario_model(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]
                                                           ) -> None:
    """The band is computed in the model the scenario chose (here stiffened): its +10 %
    entry equals an independent run of the optimised scenario on that plant; the iteration
    limit is stated."""
    from flexlink.scenario import load_scenario
    from flexlink.shaping.compare import run_residual
    from flexlink.shaping.plants import scale_frequencies

    text = ARM_TOML.replace("dt_out = 0.01", "dt_out = 0.01\ngeometric_stiffening = true")
    status, out, err, folder = _cli(tmp_path, capsys, text, "--harmonics", "1",
                                    "--max-iterations", "1")
    assert status == 0, err
    assert "robustness (first-order model with geometric stiffening), every frequency " \
           "-10 … +10 %" in out
    assert "stopped at the iteration limit (1)" in out
    summary = json.loads((folder / "summary.json").read_text())
    band = summary["robustness_band"]["first_order"]
    assert band["errors_pct"] == [-10.0, -5.0, 0.0, 5.0, 10.0]
    assert summary["optimiser"]["stopped_at_iteration_limit"] is True
    optimised = load_scenario(folder / "optimized.toml")
    assert optimised.settings.geometric_stiffening
    end = summary["residual_window_s"][0]
    _, peak = run_residual(scale_frequencies(optimised, 1.1), end)
    assert band["optimised_m"][-1] == pytest.approx(peak, rel=1e-9)
    assert band["ratio"][2] == pytest.approx(
        band["cycloidal_m"][2] / band["optimised_m"][2], rel=1e-12)


@pytest.mark.parametrize(("options", "message"), [
    (["--workers", "-3"], "--workers: must be an integer >= 1"),
    (["--workers", "0"], "--workers: must be an integer >= 1"),
    (["--duration", "1e5"], "more than the 100,000 allowed"),
    (["--duration", "nan"], "--duration: must be a finite number"),
    (["--robust", "60"], "--robust must be a percentage in [0, 50)"),
    (["--max-iterations", "0"], "--max-iterations must be ≥ 1"),
    (["--torque-limit", "0.01"], "the torque limit binds: joint 1 needs a torque of"),
])
def test_optimize_command_refuses_bad_requests_with_a_message(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], options: list[str],
        message: str) -> None:
    status, _, err, folder = _cli(tmp_path, capsys, ARM_TOML, "--harmonics", "1",
                                  "--max-iterations", "3", *options)
    assert status == 2
    assert message in err
    assert not folder.exists()


PAPER_CASES = [  # the requests that ended in a traceback: the README's command without a
    # torque limit, a stiffened arm with rate and acceleration limits only, a feasible
    # per-joint rate limit, an unreachable torque limit
    ([], ["--rate-limit", "200", "--acceleration-limit", "1000"], 0, ""),
    (["geometric_stiffening"], ["--rate-limit", "200", "--acceleration-limit", "1000"], 0, ""),
    ([], ["--rate-limit", "200,120"], 0, ""),
    ([], ["--rate-limit", "200", "--acceleration-limit", "1000", "--torque-limit", "2,0.05"], 2,
     "the torque limit binds: joint 1 needs a torque of"),
]


@pytest.mark.slow
@pytest.mark.parametrize(("edits", "options", "status", "message"), PAPER_CASES)
def test_paper_requests_end_with_an_answer_or_a_message(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], edits: list[str],
        options: list[str], status: int, message: str) -> None:
    from flexlink.cli import main
    from flexlink.scenario import paper_experiment_path

    text = paper_experiment_path().read_text()
    if "geometric_stiffening" in edits:
        text = text.replace("geometric_stiffening = false", "geometric_stiffening = true")
        assert "geometric_stiffening = true" in text
    path = tmp_path / "arm.toml"
    path.write_text(text)
    out = tmp_path / "opt"
    code = main(["optimize", str(path), "-o", str(out), "--duration", "1.2", "--no-figures",
                 *options])
    captured = capsys.readouterr()
    assert "Traceback" not in captured.out + captured.err
    assert code == status, captured.err
    if status:
        assert message in captured.err and not out.exists()
        return
    summary = json.loads((out / "summary.json").read_text())
    assert "robustness (first-order model" in captured.out
    residual = summary["residual_tip_deflection_m"]["first_order"]
    assert residual["optimised"] < 0.2 * residual["cycloidal"]
    limits = [float(v) for v in options[1].split(",")]
    table = np.genfromtxt(out / "trajectory.csv", delimiter=",", names=True)
    for k in range(2):
        assert np.abs(table[f"joint{k + 1}_rate_deg_s"]).max() <= limits[min(k, len(limits) - 1)]


def test_an_output_path_under_a_file_is_a_message(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    from flexlink.cli import main

    path = tmp_path / "arm.toml"
    path.write_text(ARM_TOML)
    (tmp_path / "file").write_text("")
    status = main(["optimize", str(path), "-o", str(tmp_path / "file" / "opt"), "--workers",
                   "1", "--harmonics", "1", "--max-iterations", "1", "--no-figures"])
    captured = capsys.readouterr()
    assert status == 2 and "Traceback" not in captured.out + captured.err
    assert "flexlink optimize:" in captured.err and "file" in captured.err


def test_differences_run_on_the_discretisation_of_their_point() -> None:
    """With the Lawson integrator, a point evaluated with error control keeps every plant's
    discretisation; differences on it are those of one smooth map (equal at steps 1e-4 and
    1e-6) and agree with central differences of runs at a tight tolerance."""
    base = _arm()
    scenario = dataclasses.replace(base, settings=dataclasses.replace(base.settings,
                                                                      method="lawson"))
    problem = Problem(scenario, joint_moves(scenario), 2, [(1.0, False), (1.1, True)], 0.005)
    x = np.array([0.1, -0.05, 0.08, 0.02])
    assert problem.discretisations(x) is None
    r0 = problem.evaluate(x)[0]
    on = problem.discretisations(x)
    assert on is not None and all(d is not None for d in on)
    assert np.array_equal(problem.evaluate(x, on)[0], r0)

    def forward(h: float) -> np.ndarray:
        return np.stack([(problem.evaluate(x + h * e, on)[0] - r0).ravel() / h
                         for e in np.eye(x.size)], axis=1)

    coarse, fine = forward(1e-4), forward(1e-6)
    np.testing.assert_allclose(fine, coarse, rtol=0, atol=1e-5 * np.abs(coarse).max())
    tight = Problem(dataclasses.replace(scenario, settings=dataclasses.replace(
        scenario.settings, rtol=1e-10)), joint_moves(scenario), 2, [(1.0, False), (1.1, True)],
        0.005)
    tight.plant_scenarios = [dataclasses.replace(sc, settings=dataclasses.replace(
        sc.settings, rtol=1e-10)) for sc in tight.plant_scenarios]
    central = np.stack([(tight.evaluate(x + 1e-4 * e)[0] - tight.evaluate(x - 1e-4 * e)[0])
                        .ravel() / 2e-4 for e in np.eye(x.size)], axis=1)
    np.testing.assert_allclose(fine, central, rtol=0, atol=1e-2 * np.abs(central).max())


def test_runs_without_channels_keep_the_solution_and_the_divergence_check() -> None:
    from flexlink.simulation.common import output_times
    from flexlink.simulation.prescribed import run_prescribed

    scenario = _arm()
    t = output_times(scenario.settings.t_end, scenario.settings.dt_out)
    full = run_prescribed(scenario, t, lambda _t: None, False)
    bare = run_prescribed(scenario, t, lambda _t: None, False, channels=False)
    assert not bare.values
    np.testing.assert_array_equal(bare.solution.q, full.solution.q)
    np.testing.assert_array_equal(bare.solution.q_dot, full.solution.q_dot)
    # a soft link spun far above its first frequency without stiffening diverges
    soft = dataclasses.replace(scenario, chain=Chain(
        (Link("beam", 1.0, 0.5, 0.05, modes=2), Link("stub", 0.2, 0.3, 1.0, modes=0)),
        (Cycloidal(0.0, 3600.0, 0.0, 1.0), Hold(0.0))))
    for channels in (True, False):
        with pytest.raises(SimulationError, match="exceeds its length"):
            run_prescribed(soft, t, lambda _t: None, False, channels=channels)


def _ran_in_a_fresh_process(test: str) -> bool:
    """Run ``test`` of this file in a new pytest process when this one runs threads (a
    whole suite's earlier tests leave some): the pools under test fork only from a process
    without threads. True when it ran there (and passed)."""
    if threading.active_count() == 1 or os.environ.get("FLEXLINK_TEST_FRESH_PROCESS"):
        return False
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", f"{__file__}::{test}"],
        env={**os.environ, "FLEXLINK_TEST_FRESH_PROCESS": "1"}, capture_output=True,
        text=True, timeout=600, check=False)
    assert done.returncode == 0 and " passed" in done.stdout, done.stdout + done.stderr
    return True


def test_a_point_split_over_the_pool_equals_its_evaluation_here(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A single point's plants run half here, half in the pool: the same residuals, torques
    and kept discretisations as `Problem.evaluate` here, bit for bit; a plant failing on
    either side makes the point a failed trial."""
    if _ran_in_a_fresh_process("test_a_point_split_over_the_pool_equals_its_evaluation_here"):
        return
    from flexlink.shaping.optimize import Evaluator

    base = _arm()
    scenario = dataclasses.replace(base, settings=dataclasses.replace(base.settings,
                                                                      method="lawson"))
    plants = [(1.0, False), (1.0, True), (0.9, False), (1.1, True)]
    problem = Problem(scenario, joint_moves(scenario), 2, plants, 0.005)
    x = np.array([0.1, -0.05, 0.08, 0.02])
    rows, torques = problem.evaluate(x)
    here = problem.discretisations(x)
    split = Problem(scenario, joint_moves(scenario), 2, plants, 0.005)
    evaluator = Evaluator(split, 2)
    try:
        value = evaluator.many([x])[0]
        assert value is not None
        np.testing.assert_array_equal(value[0], rows)
        np.testing.assert_array_equal(value[1], torques)
        kept = split.discretisations(x)
        assert kept is not None and len(kept) == len(plants)
        for a, b in zip(kept, here, strict=True):
            assert a is not None and b is not None
            np.testing.assert_array_equal(split.evaluate(x, kept)[0], problem.evaluate(x, here)[0])
    finally:
        evaluator.close()
    run = Problem.plant_run

    def third_plant_fails(self: Problem, i: int, x: np.ndarray, on=None):
        if i == 2:
            raise SimulationError("diverged")
        return run(self, i, x, on)

    def second_plant_fails(self: Problem, i: int, x: np.ndarray, on=None):
        if i == 1:
            raise SimulationError("diverged")
        return run(self, i, x, on)

    from flexlink.batch.executors import start_context

    if start_context().get_start_method() != "fork":
        pytest.skip("this process runs threads: the pool would not inherit the failure")
    for failing in (third_plant_fails, second_plant_fails):  # here, in the pool
        monkeypatch.setattr(Problem, "plant_run", failing)  # before the pool forks
        evaluator = Evaluator(Problem(scenario, joint_moves(scenario), 2, plants, 0.005), 2)
        try:
            assert evaluator.many([x]) == [None]
            assert evaluator.count == 1
        finally:
            evaluator.close()


def test_report_runs_on_the_pool_equal_runs_here() -> None:
    """`compare.residual_runs` on two forked processes: the peaks and kept traces of
    `run_residual` here, bit for bit, in order; a run that fails is a NaN with its message."""
    if _ran_in_a_fresh_process("test_report_runs_on_the_pool_equal_runs_here"):
        return
    from flexlink.shaping import compare
    from flexlink.shaping.plants import scale_frequencies

    scenario = _arm()
    soft = dataclasses.replace(scenario, chain=Chain(
        (Link("beam", 1.0, 0.5, 0.05, modes=2), Link("stub", 0.2, 0.3, 1.0, modes=0)),
        (Cycloidal(0.0, 3600.0, 0.0, 1.0), Hold(0.0))))
    checks = [(scenario, "first_order", True), (scale_frequencies(scenario, 1.1),
                                                 "first_order", False),
              (soft, "first_order", False), (scenario, "first_order", False)]
    if threading.active_count() > 1:
        pytest.skip("this process runs threads: residual_runs would not fork")
    assert compare._fork_pool(2) is not None
    done = compare.residual_runs(checks, 0.7, workers=2)
    here = compare.residual_runs(checks, 0.7, workers=1)
    for a, b, (sc, _, keep) in zip(done, here, checks, strict=True):
        if sc is soft:
            assert math.isnan(a.peak) and "exceeds its length" in a.error
            continue
        assert a.peak == b.peak == compare.run_residual(sc, 0.7)[1] and a.error is None
        assert (a.time is not None) == keep
        if keep:
            np.testing.assert_array_equal(a.time, b.time)
            np.testing.assert_array_equal(a.tip, b.tip)
    assert done[0].peak == done[3].peak


def test_a_diverging_robustness_run_is_null_in_summary_json(
        tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    """A plant of the robustness band that diverges has a NaN residual: summary.json held
    the bare token NaN, which is not JSON (strict readers, jq, JavaScript refuse the file)."""
    from flexlink.shaping import compare

    runs = compare.residual_runs

    def last_diverges(checks, move_end, workers=1, window=compare.DEFAULT_WINDOW_S):  # type: ignore[no-untyped-def]
        done = runs(checks, move_end, workers, window)
        return [*done[:-1], compare.Residual(math.nan, error="diverged")]

    monkeypatch.setattr(compare, "residual_runs", last_diverges)
    status, out, err, folder = _cli(tmp_path, capsys, ARM_TOML, "--harmonics", "1",
                                    "--max-iterations", "1")
    assert status == 0, err

    def refuse(token: str) -> None:
        raise AssertionError(f"{token} in summary.json")

    summary = json.loads((folder / "summary.json").read_text(), parse_constant=refuse)
    assert summary["robustness_band"]["first_order"]["optimised_m"][-1] is None
    assert "+10 %: diverges" in out


def test_the_pools_workers_leave_ctrl_c_to_the_command() -> None:
    """Ctrl-C reached every worker of the optimiser's and the report's pools, each printing
    its own KeyboardInterrupt traceback over "flexlink: interrupted"; they ignore it now
    and the command stops them."""
    if _ran_in_a_fresh_process("test_the_pools_workers_leave_ctrl_c_to_the_command"):
        return
    import signal

    from flexlink.shaping.compare import _fork_pool
    from flexlink.shaping.optimize import Evaluator

    pool = _fork_pool(2)  # first: it forks only from a process without threads
    assert pool is not None
    with pool:
        assert pool.submit(signal.getsignal, signal.SIGINT).result() == signal.SIG_IGN
    scenario = _arm()
    evaluator = Evaluator(Problem(scenario, joint_moves(scenario), 1, [(1.0, False)], 0.005), 2)
    try:
        assert evaluator._pool is not None
        assert evaluator._pool.submit(signal.getsignal, signal.SIGINT).result() \
            == signal.SIG_IGN
    finally:
        evaluator.close(stop=True)


def test_an_earlier_optimize_folder_is_replaced_with_overwrite(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The refusal of a non-empty folder said "overwrite it (--overwrite)", an option
    optimize did not have; its folder now holds scenario.resolved.toml, by which
    --overwrite recognises it."""
    options = ("--harmonics", "1", "--max-iterations", "1", "--robust", "0")
    assert _cli(tmp_path, capsys, ARM_TOML, *options)[0] == 0
    status, _, err, folder = _cli(tmp_path, capsys, ARM_TOML, *options)
    assert status == 2 and "(--overwrite)" in err
    status, out, err, folder = _cli(tmp_path, capsys, ARM_TOML, *options, "--overwrite")
    assert status == 0, err
    assert (folder / "scenario.resolved.toml").is_file() and "scenario.resolved.toml" in out


def test_idle_work_runs_on_the_pool_between_evaluations() -> None:
    """`Evaluator.idle` hands the pool one item of idle work per worker; `idle_results`
    gives each item's result in order, None for those never handed over or that raised."""
    if _ran_in_a_fresh_process("test_idle_work_runs_on_the_pool_between_evaluations"):
        return
    import functools

    from flexlink.shaping.optimize import Evaluator

    scenario = _arm()
    problem = Problem(scenario, joint_moves(scenario), 1, [(1.0, False)], 0.005)
    work = [functools.partial(math.sqrt, v) for v in (4.0, -1.0, 9.0)]
    evaluator = Evaluator(problem, 2, work)
    try:
        evaluator.idle()  # two workers: the first two items
        assert evaluator.many([np.zeros(problem.size)])[0] is not None
        assert evaluator.idle_results() == [2.0, None, None]  # sqrt(-1) raised
    finally:
        evaluator.close()
    here = Evaluator(problem, 1, work)  # no pool: nothing runs
    here.idle()
    assert here.idle_results() == [None, None, None]


def test_early_report_runs_leave_bad_input_to_the_optimiser_and_raise_a_defect(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The optional early runs caught every exception, a defect included; bad input still
    gives none (the optimiser then names it)."""
    from flexlink.shaping import optimize
    from flexlink.shaping.command import early_report_runs

    def failing(error: Exception):  # type: ignore[no-untyped-def]
        def joint_moves(*_: object) -> None:
            raise error
        return joint_moves

    monkeypatch.setattr(optimize, "joint_moves", failing(optimize.InfeasibleMove("no move")))
    assert early_report_runs(_arm(), 0.5, "zv", ["first_order"], True) == ([], [])
    monkeypatch.setattr(optimize, "joint_moves", failing(IndexError("out of range")))
    with pytest.raises(IndexError, match="out of range"):
        early_report_runs(_arm(), 0.5, "zv", ["first_order"], True)


def test_early_report_runs_equal_the_report_runs_of_any_answer() -> None:
    """The report's runs of the cycloidal and shaped moves made before the optimiser answers
    (`early_report_runs`, from the scenario with its moves as harmonic profiles) are those
    the report makes of the answer, whatever its coefficients: the same plan keys, and the
    same residual peaks and traces bit for bit."""
    from flexlink.shaping import compare
    from flexlink.shaping.command import (
        early_report_runs,
        reference_versions,
        report_plan,
    )
    from flexlink.shaping.plants import scale_frequencies

    scenario = _arm()
    moves = joint_moves(scenario, 0.5)
    answer = compare.with_moves(scenario, {0: Harmonic(0.0, 30.0, 0.1, 0.5, (0.3, -0.2),
                                                       (0.1, 0.05))})
    keys, calls = early_report_runs(scenario, 0.5, "zv", ["first_order"], True)
    versions, _, _ = reference_versions(answer, moves, "zv")
    plan = report_plan([*versions, "optimised"], ["first_order"], True)
    assert keys == [k[:3] for k in plan if k[1] != "optimised"]
    assert len(keys) == 2 * 17
    for i in (0, 1, 5, len(keys) - 1):  # the nominal plants (traces kept) and off them
        model, label, e = keys[i]
        keep = e == 0.0
        sc = versions[label] if e == 0.0 else scale_frequencies(versions[label], 1 + e / 100)
        expected = compare.check_residual((sc, model, keep), max(m.end for m in moves))
        got = calls[i]()
        assert got.peak == expected.peak
        if keep:
            np.testing.assert_array_equal(got.tip, expected.tip)
