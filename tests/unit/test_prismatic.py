"""Sliders inside a chain (dynamics/prismatic.py): the compiled kernel against the numpy
equations, and the rigid limit against the exact two-body equations."""

from __future__ import annotations

import numpy as np
import pytest

from flexlink.dynamics import forward_kernel
from flexlink.dynamics.forward import ForwardSystem
from flexlink.model import (
    Base,
    Chain,
    Link,
    PrismaticJoint,
    Step,
    TorqueDrive,
)
from flexlink.motion import Cycloidal, Spinup, Travel
from tests.unit._slider_cases import telescope, telescoping_arm


def _telescope(stiffening: bool, drive: str = "force", gravity=(0.0, 0.0),
               modes: int = 2) -> ForwardSystem:
    """`telescope` on a fixed base."""
    return ForwardSystem(telescope(drive, modes), Base(), stiffening, gravity=gravity)


@pytest.mark.parametrize("gravity", [(0.0, 0.0), (0.0, -9.81)])
@pytest.mark.parametrize("drive", ["force", "prescribed", "servo"])
@pytest.mark.parametrize("stiffening", [False, True])
def test_kernel_matches_the_numpy_equations(stiffening: bool, drive: str, gravity) -> None:
    """Random rigid states and deflections: the joint rows (torques, the slider's force:
    frames, residual and mass matrix) agree with ForwardSystem to 1e-11 of their size;
    p̈_free and z̈ to 1e-9, the round-off of the two solves (LAPACK and the kernel's
    elimination) on these stiff short links: the same chain on revolute joints differs as
    much."""
    system = _telescope(stiffening, drive, gravity)
    rng = np.random.default_rng(3)
    nt, nu, n, ns = 10, len(system.free), system.n, len(system.servos)
    t = rng.uniform(0.0, 1.5, nt)
    p_free, pd_free = rng.uniform(-1.0, 1.0, (nt, nu)), rng.normal(size=(nt, nu))
    z, zd = 1e-2 * rng.normal(size=(nt, n)), 0.3 * rng.normal(size=(nt, n))
    integral = np.zeros((nt, ns))
    expected = system.accelerations(t, p_free, pd_free, z, zd, integral)
    got = forward_kernel.accelerations(system, t, p_free, pd_free, z, zd, integral)
    for ours, theirs in zip(got, expected):
        np.testing.assert_allclose(ours, theirs, rtol=0,
                                   atol=1e-9 * np.abs(theirs).max(initial=0.0))
    nr = system.n_rigid
    p, pd, pdd = (rng.uniform(-1.0, 1.0, (nt, nr)), rng.normal(size=(nt, nr)),
                  rng.normal(size=(nt, nr)))
    zdd = rng.normal(size=(nt, n))
    expected = system.joint_torques(p, pd, pdd, z, zd, zdd)
    got = forward_kernel.joint_torques(system, p, pd, pdd, z, zd, zdd)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-11 * np.abs(expected).max())


@pytest.mark.parametrize("gamma_deg", [0.0, 25.0])
def test_rigid_limit_is_the_exact_two_body_equation(gamma_deg: float) -> None:
    """A rigid link spun at a constant rate ω carries a slider along its axis; on the
    block, a rigid link at γ. Along the rotating line the exact equation is
    m (s̈ − ω² (L1 + s + x_c)) = F (x_c the centre of mass of link and block ahead of the
    block, along the line): the numpy equations and the kernel give s̈ to round-off."""
    L1, L2, rho, ms, F, w0 = 0.8, 0.5, 1.2, 0.3, 2.0, 1.5
    gamma = np.radians(gamma_deg)
    links = (Link("a", L1, 2.0, 50.0, modes=0), Link("b", L2, rho, 30.0, modes=0))
    joints = (Spinup(np.degrees(w0), 0.0, 1e-6),
              PrismaticJoint(TorqueDrive(Step(F), 0.1), 0.0, gamma, mass=ms))
    system = ForwardSystem(Chain(links, joints), Base())
    m = rho * L2 + ms
    xc = rho * L2 * L2 / 2 * np.cos(gamma) / m
    t = np.array([1.0, 2.0])
    s, sd = np.array([[0.25], [-0.1]]), np.array([[0.7], [0.0]])
    expect = F / m + w0**2 * (L1 + s[:, 0] + xc)
    none = np.zeros((2, 0))
    for solve in (system.accelerations, lambda *a: forward_kernel.accelerations(system, *a)):
        sdd = solve(t, s, sd, none, none, none)[0][:, 0]
        np.testing.assert_allclose(sdd, expect, rtol=1e-12)


def test_a_slider_outside_its_travel_is_refused_at_load() -> None:
    """A start or a prescribed travel outside the travel: a ValueError naming the joint's
    travel key and the time."""
    from flexlink.model import Scenario, SimulationSettings
    from flexlink.motion import Hold

    links = (Link("a", 0.9, 1.4, 40.0), Link("b", 0.6, 0.8, 25.0))

    def scenario(drive) -> Scenario:
        return Scenario(Chain(links, (Hold(0.0), PrismaticJoint(drive, travel=(0.0, 0.3)))),
                        settings=SimulationSettings(t_end=2.0, dt_out=0.01))

    with pytest.raises(ValueError, match=r"joints\[1\].*starts at s = 0.5 m.*joints\[1\].travel"):
        scenario(TorqueDrive(Step(0.0), 0.5))
    with pytest.raises(ValueError, match=r"joints\[1\].motion.*leaves its travel.*t = 1.13"):
        scenario(Travel(Cycloidal(0.0, 0.4, 0.5, 1.0)))


# --- scenario keys, channels and travel, end to end ------------------------------------------

def _example() -> dict:
    return telescoping_arm(t_end=0.4)


def test_the_example_reads_runs_and_names_its_slider_channels() -> None:
    """examples/telescoping_arm.toml (shortened): the slider is joint 2 with its keys in
    radians and metres; its channels are position, velocity and force, the position the
    prescribed travel; the resolved table reads back to the same joint."""
    from flexlink import simulate
    from flexlink.scenario import scenario_from_dict

    d = _example()
    scenario = scenario_from_dict(d)
    joint = scenario.chain.joints[1]
    assert isinstance(joint, PrismaticJoint)
    assert joint.travel == (0.0, 0.7) and joint.mass == 0.5
    import tomllib

    from flexlink.scenario.toml_writer import dump_toml

    assert scenario_from_dict(tomllib.loads(dump_toml(d))).chain.joints[1] == joint
    r = simulate(scenario, shapes=False)
    for name, unit in (("joint2_position", "m"), ("joint2_velocity", "m s-1"),
                       ("joint2_force", "N")):
        assert r.channels[name].unit == unit
    assert "joint2_angle" not in r.channels
    expected = joint.evaluate(r.time)[0]
    np.testing.assert_allclose(r["joint2_position"], expected, atol=1e-12)


@pytest.mark.parametrize("change, message", [
    (lambda d: d["joints"][1].update(rail_angle_deg=10.0),
     r"joints\[1\]: unknown key 'rail_angle_deg'"),
    (lambda d: d["joints"][1].update(travel=[0.2, 0.7]),
     r"joints\[1\]: the slider starts at s = 0.1 m, outside its travel .*joints\[1\].travel"),
    (lambda d: d["joints"][1].update(travel=[0.0, 0.5]),
     (r"joints\[1\].motion: the prescribed slider travel leaves its travel \[0, 0.5\] m "
      r"\(joints\[1\].travel\) at t = 1.3275 s")),
    (lambda d: d["joints"][1].update(mass=-1.0), r"joints\[1\].mass"),
    # a misspelt key of the slider is matched against the slider's keys, not the cart's rail
    (lambda d: d["joints"][1].update(axis_angle=10.0),
     r"joints\[1\]: unknown key 'axis_angle' \(did you mean 'axis_angle_deg'\?\)"),
    (lambda d: d["joints"][1].update(masss=0.5),
     r"joints\[1\]: unknown key 'masss' \(did you mean 'mass'\?\)"),
    (lambda d: d["joints"].reverse(), r"joints\[0\]: a slider rides on the tip"),
])
def test_bad_slider_input_is_refused_at_load(change, message: str) -> None:
    from flexlink.scenario import ScenarioError, scenario_from_dict

    d = _example()
    d["simulation"]["t_end"] = 3.0
    change(d)
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(d)


def test_a_driven_slider_that_leaves_its_travel_ends_the_run() -> None:
    """A force-driven slider pushed past its travel: the run ends with an error naming
    joints[1].travel and the first output time outside, not a clipped travel."""
    from flexlink import simulate
    from flexlink.errors import SimulationError
    from flexlink.scenario import scenario_from_dict

    d = _example()
    slider = {k: v for k, v in d["joints"][1].items() if k not in ("motion",)}
    slider.update(drive="force", force=[{"profile": "step", "amplitude": 5.0}],
                  initial_position=0.1, initial_velocity=0.0, travel=[0.0, 0.15])
    d["joints"][1] = slider
    with pytest.raises(SimulationError, match=r"joints\[1\].travel\): s = 0.15\d* m at t = 0.1"):
        simulate(scenario_from_dict(d), shapes=False)


def test_a_position_servo_brings_the_slider_to_its_reference() -> None:
    """The example's slider on a position servo following the same travel while the boom
    slews: its reference channel is the travel profile (m), and it holds the reference
    within 2 mm once the move has ended (the servo against the arm's centrifugal pull)."""
    from flexlink import simulate
    from flexlink.scenario import scenario_from_dict

    d = _example()
    d["simulation"]["t_end"] = 3.0
    slider = {k: v for k, v in d["joints"][1].items() if k != "motion"}
    slider.update(drive="servo", servo="position", reference=d["joints"][1]["motion"],
                  bandwidth=30.0, rate_limit=1.0, loop_gain=200.0)
    d["joints"][1] = slider
    r = simulate(scenario_from_dict(d), shapes=False)
    reference = np.asarray(r["joint2_reference"])
    assert r.channels["joint2_reference"].unit == "m"
    np.testing.assert_allclose(reference[-1], 0.6)
    late = r.time >= 2.5
    assert np.abs(np.asarray(r["joint2_position"])[late] - reference[late]).max() < 2e-3


def test_linearised_plant_of_a_force_driven_slider() -> None:
    """The example with rigid links and a force-driven slider, linearised at t = 0 (the boom
    at rest): states and outputs are named by the slider's channels with their units, and
    the force enters the slider's acceleration as 1/m, m the block, the arm and its tip
    mass (exact)."""
    from flexlink.control import linearize
    from flexlink.scenario import scenario_from_dict

    d = _example()
    for link in d["links"]:
        for key in ("EI", "modes", "damping_ratio", "mode_shapes"):
            link.pop(key, None)
        link["rigid"] = True
    slider = {k: v for k, v in d["joints"][1].items() if k != "motion"}
    slider.update(drive="force", force=[{"profile": "step", "amplitude": 1.0}],
                  initial_position=0.3, initial_velocity=0.0)
    d["joints"][1] = slider
    plant = linearize(scenario_from_dict(d), 0.0)
    assert plant.state_names == ("joint2_position", "joint2_velocity")
    assert plant.input_names == ("joint2_force",) and plant.input_units == ("N",)
    units = dict(zip(plant.output_names, plant.output_units))
    assert units["joint2_position"] == "m" and units["joint2_force"] == "N"
    mass = 0.5 + 0.6 * 0.8 + 0.2
    np.testing.assert_allclose(plant.B[1, 0], 1.0 / mass, rtol=1e-12)
