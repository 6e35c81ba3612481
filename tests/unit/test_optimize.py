"""The trajectory optimiser (flexlink.shaping.optimize) on a cheap arm: gradient against
central differences, reproducibility, limits, infeasible requests."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from flexlink.model import Chain, Link, Scenario, SimulationSettings
from flexlink.motion import Cycloidal, Harmonic, Hold
from flexlink.shaping import Limits, optimize_move
from flexlink.shaping.optimize import InfeasibleMove, Problem, fd_gradient, joint_moves


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
                          stiffening="scenario") for w in (1, 2)]
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
    with pytest.raises(InfeasibleMove, match="joint 1 needs torque_Nm .* > limit 0.01"):
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
