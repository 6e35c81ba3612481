"""A slider's line through a point of its parent other than the tip (`PrismaticJoint.at`,
scenario key `line_at`; docs/prismatic_joints.md): compiled against numpy on both models,
rigid links on both models against each other and against the tip case shifted along the
line, the tip given as a point against the default, the nonlinear model's Lagrangian and
energy, and the refusals of the scenario key. The first-order model's linearisation of the
exact kinematics with such a line: tests/validation/test_prismatic.py."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from flexlink.dynamics import forward_kernel
from flexlink.dynamics.forward import ForwardSystem
from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
from flexlink.model import Base, Chain, Step, TorqueDrive
from tests.unit._slider_cases import telescope, telescoping_arm
from tests.unit.test_nonlinear_prismatic import _random_states, assert_rigid_models_agree

AT = 0.55  # m, on the 0.9 m parent


def _at(chain: Chain, at: float | None, axis: float | None = None) -> Chain:
    """``chain`` with its slider (joint 1) on a line through the parent's section ``at``
    (and, if given, along ``axis``, rad)."""
    slider = replace(chain.joints[1], at=at)
    if axis is not None:
        slider = replace(slider, axis_angle=axis)
    return Chain(chain.links, (chain.joints[0], slider, *chain.joints[2:]))


def _first_order_states(system: ForwardSystem, seed: int = 3, nt: int = 8):
    rng = np.random.default_rng(seed)
    nu, n = len(system.free), system.n
    return (rng.uniform(0.0, 1.5, nt), rng.uniform(-1.0, 1.0, (nt, nu)),
            rng.normal(size=(nt, nu)), 1e-2 * rng.normal(size=(nt, n)),
            0.3 * rng.normal(size=(nt, n)), np.zeros((nt, len(system.servos))))


@pytest.mark.parametrize("drive", ["force", "prescribed", "servo"])
def test_first_order_kernel_matches_the_numpy_equations(drive: str) -> None:
    """Flexible links, stiffened, under gravity: the compiled accelerations and joint rows
    equal ForwardSystem's to the tolerances of the tip case (test_prismatic.py)."""
    system = ForwardSystem(_at(telescope(drive), AT), Base(), True, gravity=(0.0, -9.81))
    assert system.hang[0].x == AT and system.hang[1].x == system.modal[1].length
    args = _first_order_states(system)
    expected = system.accelerations(*args)
    got = forward_kernel.accelerations(system, *args)
    for ours, theirs in zip(got, expected):
        np.testing.assert_allclose(ours, theirs, rtol=0,
                                   atol=1e-9 * np.abs(theirs).max(initial=0.0))
    rng = np.random.default_rng(4)
    nt, nr, n = 8, system.n_rigid, system.n
    rigid = [rng.uniform(-1.0, 1.0, (nt, nr)), rng.normal(size=(nt, nr)),
             rng.normal(size=(nt, nr))]
    z, zd, zdd = (rng.normal(size=(nt, n)) * s for s in (1e-2, 0.3, 1.0))
    expected = system.joint_torques(*rigid, z, zd, zdd)
    got = forward_kernel.joint_torques(system, *rigid, z, zd, zdd)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-11 * np.abs(expected).max())


@pytest.mark.parametrize("drive", ["force", "prescribed", "servo"])
def test_nonlinear_kernel_matches_the_numpy_equations(drive: str) -> None:
    system = NonlinearForwardSystem(_at(telescope(drive), AT), Base(), gravity=(0.0, -9.81))
    t, y, v, _ = _random_states(system)
    expected = system.accelerations(t, y, v, compiled=False)
    got = system.accelerations(t, y, v, compiled=True)
    np.testing.assert_allclose(got, expected, rtol=0, atol=1e-9 * np.abs(expected).max())


@pytest.mark.parametrize("gravity", [(0.0, 0.0), (3.0, -9.81)])
@pytest.mark.parametrize("drive", ["force", "prescribed", "servo"])
def test_rigid_links_both_models_agree(drive: str, gravity) -> None:
    """Rigid links (both models exact): free accelerations and every joint's torque or force
    agree to round-off with the line through the parent's section at 0.55 m."""
    assert_rigid_models_agree(_at(telescope(drive, modes=0), AT), gravity)


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_rigid_parent_line_inside_is_the_tip_line_shifted(model: str) -> None:
    """A line along a rigid parent (axis 0) through its section at x_a is the line through
    its tip with the travel shifted by L − x_a: with s_tip = s − (L − x_a) the free
    accelerations and every joint's torque or force are the same to round-off."""
    chain = telescope("force", modes=0)
    inside, tip = _at(chain, AT, 0.0), _at(chain, None, 0.0)
    shift = chain.links[0].length - AT
    rng = np.random.default_rng(9)
    t = rng.uniform(0.0, 1.5, 6)
    p = rng.uniform(-0.5, 0.5, (6, 3))
    p[:, 1] += 0.5  # travel from the section at 0.55 m, 0 … 1 m
    pd = rng.normal(size=(6, 3))
    none = np.zeros((6, 0))
    shifted = p.copy()
    shifted[:, 1] -= shift
    if model == "first_order":
        a, b = ForwardSystem(inside, Base()), ForwardSystem(tip, Base())
        acc_a = a.accelerations(t, p, pd, none, none, none)[0]
        acc_b = b.accelerations(t, shifted, pd, none, none, none)[0]
        rows_a = a.joint_torques(p, pd, acc_a, none, none, none)
        rows_b = b.joint_torques(shifted, pd, acc_b, none, none, none)
    else:
        a, b = NonlinearForwardSystem(inside, Base()), NonlinearForwardSystem(tip, Base())
        acc_a = a.accelerations(t, p, pd, compiled=True)
        acc_b = b.accelerations(t, shifted, pd, compiled=True)
        rows_a = a.joint_torques(t, p, pd, acc_a)
        rows_b = b.joint_torques(t, shifted, pd, acc_b)
    np.testing.assert_allclose(acc_a, acc_b, rtol=0, atol=1e-12 * np.abs(acc_b).max())
    np.testing.assert_allclose(rows_a, rows_b, rtol=0, atol=1e-12 * np.abs(rows_b).max())


def test_the_tip_given_as_a_point_is_the_default_bit_for_bit() -> None:
    """``at`` = the parent's length takes the tip's own arrays: accelerations identical to
    the bit on both models (flexible links, gravity)."""
    chain = telescope("force")
    tip, given = _at(chain, None), _at(chain, chain.links[0].length)
    a, b = (ForwardSystem(c, Base(), True, gravity=(0.0, -9.81)) for c in (tip, given))
    args = _first_order_states(a)
    for x, y in zip(forward_kernel.accelerations(a, *args),
                    forward_kernel.accelerations(b, *args)):
        np.testing.assert_array_equal(x, y)
    for x, y in zip(a.accelerations(*args), b.accelerations(*args)):
        np.testing.assert_array_equal(x, y)
    a, b = (NonlinearForwardSystem(c, Base(), gravity=(0.0, -9.81)) for c in (tip, given))
    t, y, v, _ = _random_states(a)
    np.testing.assert_array_equal(a.accelerations(t, y, v, compiled=True),
                                  b.accelerations(t, y, v, compiled=True))


def test_nonlinear_equations_are_the_lagrangian_of_the_point_masses() -> None:
    """The nonlinear residual's inertia part equals d/dt ∂T/∂ẏ − ∂T/∂y of the kinetic energy
    of the exact positions (`energy`), by central differences, with the line inside the
    parent (test_nonlinear_prismatic.py's check for the tip)."""
    chain = _at(telescope("force", torques=(0.0, 0.0, 0.0)), AT)
    chain = Chain(tuple(replace(link, damping_ratio=0.0) for link in chain.links), chain.joints)
    system = NonlinearForwardSystem(chain, Base())
    rng = np.random.default_rng(7)
    m = system.n + system.nu
    y0, v0, a0 = 0.2 * rng.normal(size=m), rng.normal(size=m), rng.normal(size=m)
    y0[system.line_col[0]] = 0.3
    t0 = 0.9

    def kinetic(y: np.ndarray, v: np.ndarray) -> float:
        return float(system.energy(np.array([t0]), y[None], v[None])[0][0])

    h, dt = 1e-5, 1e-4

    def grad_v(y: np.ndarray, v: np.ndarray) -> np.ndarray:
        return np.array([(kinetic(y, v + h * e) - kinetic(y, v - h * e)) / (2 * h)
                         for e in np.eye(m)])

    def y_at(tau: float) -> np.ndarray:
        return y0 + v0 * tau + 0.5 * a0 * tau**2

    ddt = (grad_v(y_at(dt), v0 + a0 * dt) - grad_v(y_at(-dt), v0 - a0 * dt)) / (2 * dt)
    grad_y = np.array([(kinetic(y0 + h * e, v0) - kinetic(y0 - h * e, v0)) / (2 * h)
                       for e in np.eye(m)])
    t = np.array([t0])
    residual = system.residual(t, y0[None], v0[None], a0[None], system.stage_inputs(t))[0]
    elastic = np.zeros(m)
    elastic[:system.n] = system.K @ y0[:system.n]
    lagrange = ddt - grad_y
    np.testing.assert_allclose(residual - elastic, lagrange, rtol=0,
                               atol=1e-5 * np.abs(lagrange).max())


def test_nonlinear_energy_equals_the_drives_work() -> None:
    """Undamped flexible links under gravity, constant torques and slider force, the line
    through the parent's section at 0.55 m: kinetic + elastic + gravitational energy
    changes by the drives' work to the integration tolerance."""
    from flexlink.solvers.gauss_forward import solve_nonlinear_forward

    tau, force, tau3 = 0.8, 1.5, -0.1
    chain = telescope("force", torques=(tau, force, tau3))
    links = tuple(replace(link, damping_ratio=0.0) for link in chain.links)
    joints = (TorqueDrive(Step(tau), 0.2, 0.3),
              replace(chain.joints[1], drive=TorqueDrive(Step(force), 0.1, 0.2), at=AT),
              chain.joints[2])
    system = NonlinearForwardSystem(Chain(links, joints), Base(), gravity=(0.0, -9.81))
    t = np.linspace(0.0, 1.5, 301)
    solution = solve_nonlinear_forward(system, t, rtol=1e-8)
    y, v, a = system.from_solution(solution)
    kinetic, strain = system.energy(t, y, v)
    energy = kinetic + strain + system.potential(t, y)
    p = system.rigid_state(t, y, v, a)[0]
    work = tau * (p[:, 0] - p[0, 0]) + force * (p[:, 1] - p[0, 1]) + tau3 * (p[:, 2] - p[0, 2])
    assert np.ptp(p[:, 1]) > 0.3 and strain.max() > 1e-2  # J: the links bend
    np.testing.assert_allclose(energy - energy[0], work, rtol=0,
                               atol=1e-6 * np.abs(kinetic).max())


# --- scenario key -------------------------------------------------------------------------------

def _example() -> dict:
    return telescoping_arm(t_end=0.4)


def test_line_at_reads_and_writes_back() -> None:
    import tomllib

    from flexlink.scenario import scenario_from_dict
    from flexlink.scenario.toml_writer import dump_toml

    d = _example()
    d["joints"][1]["line_at"] = 0.6
    joint = scenario_from_dict(d).chain.joints[1]
    assert joint.at == 0.6
    assert scenario_from_dict(tomllib.loads(dump_toml(d))).chain.joints[1] == joint
    d = _example()
    assert d["joints"][1]["line_at"] == 1.0  # the example names its tip
    del d["joints"][1]["line_at"]
    assert scenario_from_dict(d).chain.joints[1].at is None  # the default: the tip


@pytest.mark.parametrize("change, message", [
    (lambda d: d["joints"][1].update(line_at=1.2),
     r"joints\[1\].line_at: 1.2 m is beyond the parent link's length 1 m \(links\[0\].length\)"),
    (lambda d: d["joints"][1].update(line_at=-0.1), r"joints\[1\].line_at"),
    (lambda d: d["joints"][1].update(line_at="tip"), r"joints\[1\].line_at"),
    (lambda d: d["joints"][0].update(line_at=0.5), r"joints\[0\]: unknown key 'line_at'"),
    (lambda d: (d["joints"][1].update(line_at=0.5), d["joints"].reverse()),
     r"joints\[0\]: a slider rides on"),
])
def test_bad_line_point_is_refused_at_load(change, message: str) -> None:
    from flexlink.scenario import ScenarioError, scenario_from_dict

    d = _example()
    change(d)
    with pytest.raises(ScenarioError, match=message):
        scenario_from_dict(d)


def test_a_model_line_point_off_the_parent_is_refused() -> None:
    from flexlink.model import PrismaticJoint, Scenario, SimulationSettings
    from flexlink.motion import Hold

    chain = telescope("force")
    with pytest.raises(ValueError, match=r"joints\[1\].line_at: 1.3 m is beyond"):
        Scenario(_at(chain, 1.3), settings=SimulationSettings(t_end=1.0, dt_out=0.01))
    with pytest.raises(ValueError, match=r"prismatic joint at: need a point ≥ 0 m"):
        PrismaticJoint(Hold(0.0), at=-0.2)


def test_flexible_parent_both_models_agree_at_small_deflection() -> None:
    """examples/telescoping_arm.toml (shortened) with the line through the boom's section at
    0.6 m: the nonlinear run and the stiffened first-order run agree on the hub torque, the
    boom's and the arm's tips within 0.5% of their peaks (the deflection is small), and
    both differ from the tip case by far more."""
    from flexlink import simulate
    from flexlink.scenario import scenario_from_dict

    runs = {}
    for model, at in (("nonlinear", 0.6), ("first_order", 0.6), ("first_order", None)):
        d = _example()
        d["simulation"].update(t_end=0.5, model=model)
        if at is not None:
            d["joints"][1]["line_at"] = at
        runs[model, at] = simulate(scenario_from_dict(d), shapes=False)
    exact, first, tip = runs["nonlinear", 0.6], runs["first_order", 0.6], runs["first_order", None]
    for name in ("joint1_torque", "boom_tip_Y", "arm_tip_X", "arm_tip_Y"):
        scale = np.abs(first[name]).max()
        error = np.abs(exact[name] - first[name]).max()
        assert error < 5e-3 * scale, (name, error / scale)
        assert np.abs(tip[name] - first[name]).max() > 10 * error, name


# --- the joint figure --------------------------------------------------------------------------

def test_the_joint_figure_shows_the_slider_travel_and_force() -> None:
    """The example's joint figure: the hub's angle, the slider's travel (m, its servo
    reference dashed), the hub's torque and the slider's force (N), each panel with data;
    the frame prepared from the channel records alone is the one drawn."""
    from flexlink import simulate
    from flexlink.results import plotting
    from flexlink.results.figures import ChannelRecords, figure_stems, split_figures
    from flexlink.scenario import scenario_from_dict

    d = _example()
    slider = {k: v for k, v in d["joints"][1].items() if k != "motion"}
    slider.update(drive="servo", servo="position", reference=d["joints"][1]["motion"],
                  bandwidth=30.0, rate_limit=1.0, loop_gain=200.0, line_at=0.6)
    d["joints"][1] = slider
    results = simulate(scenario_from_dict(d), shapes=False)
    fig = plotting.plot_joint_angles(results)
    assert [ax.get_ylabel() for ax in fig.axes] == [
        "joint angle [deg]", "slider travel [m]", "joint torque [N·m]", "slider force [N]"]
    legends = [[t.get_text() for t in ax.get_legend().get_texts()] for ax in fig.axes]
    assert legends == [["β₁"], ["s₂", "s₂ reference"], ["τ₁"], ["F₂"]]
    travel = fig.axes[1].get_lines()[0].get_ydata()
    np.testing.assert_array_equal(travel, results["joint2_position"])
    np.testing.assert_array_equal(fig.axes[3].get_lines()[0].get_ydata(), results["joint2_force"])
    records = ChannelRecords(results.channels.values())
    width, height = fig.get_size_inches()
    specs = plotting.frame_specs(records, "joint_angles")
    assert any(s[:3] == (width, height, 4) for s in specs)
    assert figure_stems(records) == figure_stems(results) and "joint_angles" in figure_stems(
        results)
    assert split_figures(records) == split_figures(results)
