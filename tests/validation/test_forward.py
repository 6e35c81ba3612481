"""Forward dynamics (free/pinned base, driven joints) against independent references:
the prescribed-joint model and its inverse dynamics, momentum conservation computed from the
kinematics, the exact free hub–beam frequencies, torque replay of a prescribed run."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.linalg import eigh

import flexlink
from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.dynamics.forward import ForwardSystem, momentum
from flexlink.dynamics.torques import joint_torques
from flexlink.errors import SimulationError
from flexlink.model import (
    BangBang,
    Base,
    BaseLoad,
    Chain,
    Link,
    PointSensor,
    Scenario,
    SimulationSettings,
    Step,
    Table,
    TorqueDrive,
)
from flexlink.motion import Cycloidal, Hold
from flexlink.solvers.forward import FAST_METHOD, integrate_forward
from tests.helpers import CubicMotion, paper_links
from tests.validation.hub_beam import hub_beam_frequencies


@pytest.mark.parametrize("stiffening", [False, True])
def test_prescribed_joints_reproduce_the_first_order_model(stiffening: bool) -> None:
    """With every joint prescribed on a fixed hub, the elastic block is FirstOrderSystem's and
    the joint rows are the inverse-dynamics torques of dynamics/torques.py (both written
    independently), and f is −M times a unit joint acceleration (f affine in p̈)."""
    chain = Chain(paper_links(3), (CubicMotion(0.3, 0.7, -0.4, 0.2),
                                   CubicMotion(1.2, -0.5, 0.8, -0.3)))
    first = FirstOrderSystem(chain, stiffening)
    forward = ForwardSystem(chain, Base(), stiffening)
    t = np.array([0.1, 0.7, 1.3])
    none = np.zeros((3, 0))
    p, pd, pdd = forward.rigid_state(t, none, none, none)
    M, C, K, f = forward.matrices(p, pd, pdd)
    zc = slice(forward.n_rigid, None)
    for ours, theirs in zip((M[:, zc, zc], C[:, zc, zc], K[:, zc, zc], f[:, zc]),
                            first.matrices(t)):
        np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12 * np.abs(theirs).max())
    rng = np.random.default_rng(1)
    z, zd, zdd = (1e-2 * rng.normal(size=(3, first.n)) for _ in range(3))
    expected = joint_torques(first, t, z, zd, zdd)
    np.testing.assert_allclose(forward.joint_torques(p, pd, pdd, z, zd, zdd), expected,
                               rtol=0, atol=1e-12 * np.abs(expected).max())
    pdd_unit = pdd.copy()
    pdd_unit[:, 0] += 1.0
    f_unit = forward.matrices(p, pd, pdd_unit)[3]
    np.testing.assert_allclose(f_unit - f, -M[:, :, 0], atol=1e-12)


@pytest.mark.parametrize("t_end", [2.0, pytest.param(10.0, marks=pytest.mark.slow)])
def test_free_body_momentum_is_conserved(t_end: float) -> None:
    """A free hub with two flexible appendages, one on a motor whose bang-bang torque is an
    internal load, drifting and spinning: linear and angular momentum (computed from the
    kinematics, not the equations) stay constant to 1e-8 of their size (10 s: slow)."""
    links = (Link("a", 2.0, 1.0, 50.0, tip_mass=0.3, tip_inertia=0.01, modes=2),
             Link("b", 1.5, 1.0, 40.0, modes=2))
    base = Base("free", mass=20.0, inertia=5.0, attachments=((0, (0.5, 0.0)), (1, (-0.5, 0.1))),
                position=(0.3, 0.2), velocity=(0.1, -0.05), rate=0.2)
    chain = Chain(links, (TorqueDrive(BangBang(2.0, 0.0, 4.0), initial_angle=0.2),
                          Hold(180.0)))
    system = ForwardSystem(chain, base, geometric_stiffening=True)
    t = np.linspace(0.0, t_end, 101)
    p_free, pd_free, z, zd, integral = _states(system, t)
    pdd_free, _, _ = system.accelerations(t, p_free, pd_free, z, zd, integral)
    p, pd, _ = system.rigid_state(t, p_free, pd_free, pdd_free)
    linear, angular = momentum(system, p, pd, z, zd)
    assert np.abs(z).max() > 0.005  # the appendages do vibrate
    assert np.abs(linear - linear[0]).max() < 1e-8 * np.linalg.norm(linear[0])
    assert np.abs(angular - angular[0]).max() < 1e-8 * abs(angular[0])


def _states(system: ForwardSystem, t: np.ndarray, compiled: bool = True
            ) -> tuple[np.ndarray, ...]:
    """p_free, ṗ_free, z, ż and the servo integrals of a tight-tolerance run (solve_ivp over
    the compiled kernel, or over the numpy ForwardSystem)."""
    solution = integrate_forward(system, t, rtol=1e-10, atol=1e-12, compiled=compiled)
    nu = len(system.free)
    return (solution.q[:, :nu], solution.q_dot[:, :nu], solution.q[:, nu:],
            solution.q_dot[:, nu:], solution.extra)


def test_momentum_check_detects_a_missing_term() -> None:
    """Mutation check: dropping the second-order stiffness (the Θ-terms that couple the
    deflection to the frame rotations, in the base's rows too) breaks the angular momentum
    balance at once (the numpy equations, the compiled kernel's reference)."""
    links = (Link("a", 2.0, 1.0, 50.0, modes=2),)
    base = Base("free", mass=20.0, inertia=5.0, attachments=((0, (0.5, 0.0)),), rate=0.5)
    chain = Chain(links, (TorqueDrive(BangBang(2.0, 0.0, 1.0)),))
    system = ForwardSystem(chain, base, geometric_stiffening=True)
    t = np.linspace(0.0, 1.0, 11)

    def drift(sys_: ForwardSystem) -> float:  # the mutation is in the numpy equations
        p_free, pd_free, z, zd, _integral = _states(sys_, t, compiled=False)
        p, pd, _ = sys_.rigid_state(t, p_free, pd_free, np.zeros_like(p_free))
        angular = momentum(sys_, p, pd, z, zd)[1]
        return float(np.abs(angular - angular[0]).max() / abs(angular[0]))

    assert drift(system) < 1e-8
    broken = ForwardSystem(chain, base, geometric_stiffening=True)
    broken._second_order_stiffness = (  # type: ignore[method-assign]
        lambda body, fr, k, outboard: np.zeros((fr.theta.shape[0], broken.n_x, broken.n_x)))
    assert drift(broken) > 1e-4


def test_a_blow_up_of_the_paper_model_ends_in_a_clear_error() -> None:
    """Regression: the paper's model (no stiffening) on a light link swung by a bang-bang
    torque on a free hub blows up at t ≈ 0.46 s; solve_ivp then ground on at 1e-12 s steps
    for ever. The run must stop with a message that points to geometric_stiffening."""
    links = (Link("a", 2.0, 1.0, 50.0, modes=2),)
    base = Base("free", mass=20.0, inertia=5.0, attachments=((0, (0.5, 0.0)),), rate=0.5)
    system = ForwardSystem(Chain(links, (TorqueDrive(BangBang(2.0, 0.0, 1.0)),)), base)
    with pytest.raises(SimulationError, match="stalled at t = 0.46.*geometric_stiffening"):
        integrate_forward(system, np.linspace(0.0, 0.55, 11), rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("eta, rho", [(0.05, 0.1), (1.0, 0.2), (0.3, 0.5)])
def test_free_hub_beam_frequencies(eta: float, rho: float) -> None:
    """Unconstrained modes of a pinned hub carrying a clamped beam, 6 assumed modes, against
    the exact frequency equation (tests/validation/hub_beam.py): the first six within 0.5%
    (measured: within 1e-4), approached from above as Rayleigh–Ritz must."""
    EI, m, L = 10.0, 1.0, 2.0
    exact = hub_beam_frequencies(6, EI, m, L, rho * L, eta * m * L**3)
    chain = Chain((Link("beam", L, m, EI, modes=6),), (Hold(0.0),))
    system = ForwardSystem(chain, Base("pinned", inertia=eta * m * L**3,
                                       attachments=((0, (rho * L, 0.0)),)))
    rest = np.zeros((1, system.n_rigid))
    M, _, K, _ = system.matrices(rest, rest, rest)
    keep = [0, *range(system.n_rigid, system.n_x)]  # hub attitude and the elastic coordinates
    omega2 = eigh(K[0][np.ix_(keep, keep)], M[0][np.ix_(keep, keep)], eigvals_only=True)
    assert abs(omega2[0]) < 1e-9 * omega2[1]  # the rigid rotation
    error = np.sqrt(omega2[1:7]) / exact - 1.0
    assert np.all(error > -1e-9) and np.all(error < 5e-3)


def test_free_flexible_beam_frequencies() -> None:
    """The first flexible link itself as the free body (a base of zero mass and inertia):
    three rigid modes and the free-free beam's cos μ cosh μ = 1 (μ = 4.7300, 7.8532, 10.9956),
    from above; 6 cantilever modes plus the root's rigid motion, measured 7e-5, 3.5e-4, 9e-4."""
    EI, m, L = 10.0, 1.0, 2.0
    chain = Chain((Link("beam", L, m, EI, modes=6),), (Hold(0.0),))
    system = ForwardSystem(chain, Base("free", mass=0.0, inertia=0.0))
    rest = np.zeros((1, system.n_rigid))
    M, _, K, _ = system.matrices(rest, rest, rest)
    keep = [0, 1, 2, *range(system.n_rigid, system.n_x)]
    omega2 = eigh(K[0][np.ix_(keep, keep)], M[0][np.ix_(keep, keep)], eigvals_only=True)
    assert np.all(np.abs(omega2[:3]) < 1e-9 * omega2[3])
    exact = np.array([4.730040745, 7.853204624, 10.99560784]) ** 2 * np.sqrt(EI / (m * L**4))
    error = np.sqrt(omega2[3:6]) / exact - 1.0
    assert np.all(error > -1e-9) and np.all(error < 2e-3)


def _replay_pair(t_end: float) -> tuple[flexlink.Results, flexlink.Results]:
    """The paper arm (3 modes) on prescribed cycloidal moves, then driven by the
    joint<k>_torque channels that run reported (linear interpolation between samples)."""
    links = paper_links(3)
    sensors = (PointSensor("acc", "acceleration", 0, 1.37),
               PointSensor("deflection", "deflection", 1, 0.6))
    settings = SimulationSettings(t_end=t_end, dt_out=5e-4, rtol=1e-8, geometric_stiffening=True)
    prescribed = Scenario(Chain(links, (Cycloidal(0, 90, 0.1, 1.0), Cycloidal(90, 170, 0.1, 1.0))),
                          sensors, settings)
    first = flexlink.simulate(prescribed)
    drives = tuple(TorqueDrive(Table(tuple(first.time), tuple(first[f"joint{k + 1}_torque"])),
                               initial_angle=math.radians(a)) for k, a in enumerate((0, 90)))
    replay = dataclasses.replace(prescribed, chain=Chain(links, drives),
                                 settings=dataclasses.replace(settings, rtol=1e-6, atol=1e-9))
    return first, flexlink.simulate(replay)


@pytest.mark.slow
def test_torque_replay_reproduces_the_prescribed_run() -> None:
    """Driving the joints with the torque a prescribed run reported reproduces its angles and
    sensors within 1% of each signal's peak (the difference is second order in the
    deflection plus the interpolation of the torque samples)."""
    first, second = _replay_pair(1.6)
    for name in ("joint1_angle", "joint2_angle", "acc", "deflection", "link2_tip_X"):
        peak = np.abs(first[name]).max()
        assert np.abs(second[name] - first[name]).max() < 0.01 * peak, name


@pytest.mark.slow
def test_servo_tracking_of_the_paper_manoeuvre() -> None:
    """examples/paper_servo.toml (P = 5, I = 0, D = 0.005, ±10 V): joint 1 lags its reference
    during the move and overshoots after it; the motor torque equals the servo law
    τ = K_v(k_v V − β̇) evaluated on the solution (equation row vs. control law)."""
    from pathlib import Path

    scenario = flexlink.load_scenario(Path(__file__).resolve().parents[2] / "examples"
                                      / "paper_servo.toml")
    results = flexlink.simulate(scenario)
    t = results.time
    angle, ref = results["joint1_angle"], results["joint1_reference"]
    moving = (t > 0.6) & (t < 1.4)
    assert np.all(angle[moving] < ref[moving])  # lag (measured: up to 11.2°)
    assert np.degrees(np.max(ref - angle)) > 5.0
    assert angle.max() > ref.max()  # overshoot (measured: 0.005°, a first-order loop)
    servo = scenario.chain.joints[0]
    law = servo.loop_gain * (servo.rate_per_volt * results["joint1_command"]
                             - results["joint1_rate"])
    np.testing.assert_allclose(results["joint1_torque"], law, atol=1e-6 * np.abs(law).max())


def test_a_blow_up_ends_in_a_clear_error_in_the_compiled_integrator() -> None:
    """The same blow-up through the compiled Radau IIA integrator (a run's default): the
    run stops at t ≈ 0.46 s, reported as the model's blow-up with the hint to
    geometric_stiffening, not as NaN or a tolerance failure."""
    links = (Link("a", 2.0, 1.0, 50.0, modes=2),)
    base = Base("free", mass=20.0, inertia=5.0, attachments=((0, (0.5, 0.0)),), rate=0.5)
    system = ForwardSystem(Chain(links, (TorqueDrive(BangBang(2.0, 0.0, 1.0)),)), base)
    with pytest.raises(SimulationError, match="stalled at t = 0.46.*geometric_stiffening"):
        integrate_forward(system, np.linspace(0.0, 0.55, 11), rtol=1e-6, atol=1e-12,
                          method=FAST_METHOD)


@pytest.mark.parametrize("rtol, drift", [(1e-8, 1e-8), (1e-6, 1e-8), (1e-4, 1e-8)])
def test_compiled_integrator_agrees_with_the_reference_and_keeps_momentum(
        rtol: float, drift: float) -> None:
    """The compiled Radau IIA integrator (a run's default) on a free hub with two appendages
    under a bang-bang base moment: within 1e3 rtol of peak of the tight-tolerance solve_ivp
    run (1e-5 at rtol 1e-8), and (the moment removed afterwards) momentum constant to
    ``drift`` of its size once the load is off at every tolerance: Radau IIA alone drifts
    (2e-4 at rtol 1e-4), the loop projects each step and output onto the momentum
    (dynamics/momentum_projection.py)."""
    links = (Link("a", 2.0, 1.0, 50.0, tip_mass=0.3, tip_inertia=0.01, modes=2),
             Link("b", 1.5, 1.0, 40.0, modes=2))
    base = Base("free", mass=20.0, inertia=5.0, attachments=((0, (0.5, 0.0)), (1, (-0.5, 0.1))),
                loads=(BaseLoad(moment=BangBang(1.0, 0.0, 1.0)),), position=(0.3, 0.2),
                velocity=(0.1, -0.05), rate=0.2)
    system = ForwardSystem(Chain(links, (Hold(0.0), Hold(180.0))), base, True)
    t = np.linspace(0.0, 3.0, 151)
    fast = integrate_forward(system, t, rtol=rtol, atol=1e-12, method=FAST_METHOD)
    reference = integrate_forward(system, t, rtol=1e-11, atol=1e-13)
    for a, b in ((fast.q, reference.q), (fast.q_dot, reference.q_dot)):
        assert np.abs(a - b).max() < 1e3 * rtol * np.abs(b).max()
    nu = len(system.free)
    after = t >= 1.0
    p, pd, _ = system.rigid_state(t, fast.q[:, :nu], fast.q_dot[:, :nu], fast.q_ddot[:, :nu])
    linear, angular = momentum(system, p[after], pd[after], fast.q[after, nu:],
                               fast.q_dot[after, nu:])
    assert np.abs(fast.q[:, nu:]).max() > 1e-3  # the appendages do vibrate
    assert np.abs(linear - linear[0]).max() < drift * np.linalg.norm(linear[0])
    assert np.abs(angular - angular[0]).max() < drift * abs(angular[0])


def _free_hub(loads: tuple = (), gravity: tuple = (0.0, 0.0), kind: str = "free"
              ) -> Scenario:
    """A hub with two appendages, one on a motor with a bang-bang torque (internal), 10 s at
    the default rtol of first-order forward runs."""
    links = (Link("a", 2.0, 1.0, 50.0, tip_mass=0.3, tip_inertia=0.01, modes=2),
             Link("b", 1.5, 1.0, 40.0, modes=2))
    free = kind == "free"
    base = Base(kind, mass=20.0 if free else 0.0, inertia=5.0,
                attachments=((0, (0.5, 0.0)), (1, (-0.5, 0.1))), loads=loads,
                position=(0.3, 0.2) if free else (0.0, 0.0),
                velocity=(0.1, -0.05) if free else (0.0, 0.0), rate=0.2)
    chain = Chain(links, (TorqueDrive(BangBang(2.0, 0.0, 4.0), initial_angle=0.2),
                          Hold(180.0)))
    settings = SimulationSettings(t_end=10.0, dt_out=0.01, geometric_stiffening=True,
                                  gravity=gravity)
    return Scenario(chain, (), settings, base=base)


def test_momentum_of_a_free_system_is_constant_at_the_default_tolerance() -> None:
    """10 s, default rtol (1e-4), an internal bang-bang torque and, over the first second, a
    bang-bang moment on the hub: linear momentum constant throughout, angular momentum
    once the moment is off, both to 1e-8 of their size (the channels, from the kinematics)."""
    results = flexlink.simulate(_free_hub((BaseLoad(moment=BangBang(1.0, 0.0, 1.0)),)),
                                shapes=False)
    assert results.metadata["rtol"] == 1e-4
    t = np.asarray(results.time)
    linear = np.column_stack([results["momentum_x"], results["momentum_y"]])
    angular = np.asarray(results["angular_momentum"])[t >= 1.0]
    assert np.ptp(np.asarray(results["joint1_angle"])) > 0.1  # rad: the motor turns it
    assert np.abs(linear - linear[0]).max() < 1e-8 * np.linalg.norm(linear[0])
    assert np.abs(angular - angular[0]).max() < 1e-8 * abs(angular[0])


def test_momentum_follows_the_known_impulse_of_the_loads() -> None:
    """Default rtol, 10 s. A pinned hub under a step moment: the angular momentum about the
    pin is the moment's impulse. A free hub pushed by a force at a point of the hub, in
    inertial axes, while falling: the linear momentum is the start value plus the force's
    impulse plus m g t (the angular momentum is not projected: the force's arm follows the
    motion). Both to 1e-8 of their size."""
    pinned = flexlink.simulate(_free_hub((BaseLoad(moment=Step(0.5, 2.0, 3.0)),),
                                         kind="pinned"), shapes=False)
    t = np.asarray(pinned.time)
    angular = np.asarray(pinned["angular_momentum"])
    impulse = 0.5 * np.clip(t - 2.0, 0.0, 3.0)
    np.testing.assert_allclose(angular - angular[0], impulse, rtol=0,
                               atol=1e-8 * np.abs(angular).max())
    g = (0.0, -9.81)
    push = BaseLoad(force_x=Step(3.0, 1.0, 2.0), point=(0.2, 0.3))
    free = flexlink.simulate(_free_hub((push,), gravity=g), shapes=False)
    total = 20.0 + 2.0 * 1.0 + 0.3 + 1.5 * 1.0
    expected_x = 3.0 * np.clip(t - 1.0, 0.0, 2.0)
    expected_y = -9.81 * total * t
    lx, ly = np.asarray(free["momentum_x"]), np.asarray(free["momentum_y"])
    size = np.abs(ly).max()
    np.testing.assert_allclose(lx - lx[0], expected_x, rtol=0, atol=1e-8 * size)
    np.testing.assert_allclose(ly - ly[0], expected_y, rtol=0, atol=1e-8 * size)


def test_projected_runs_keep_the_work_balance_of_the_reference() -> None:
    """The momentum projection corrects the rates: the energy of the exact kinematics
    (NonlinearForwardSystem.energy, from the point motion) minus the drive's work, along a
    free hub's first-order trajectory, stays within rtol of the energy of that balance along
    the tight-tolerance solve_ivp trajectory (the balance itself is the first-order model's
    own error, ~4e-3 here; measured over 10 s 3.7e-5 at rtol 1e-4, 1.5e-7 at 1e-6)."""
    from scipy.integrate import cumulative_simpson

    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem

    links = (Link("a", 2.0, 1.0, 200.0, tip_mass=0.3, tip_inertia=0.01, modes=2),
             Link("b", 1.5, 1.0, 150.0, modes=2))
    base = Base("free", mass=20.0, inertia=5.0, attachments=((0, (0.5, 0.0)), (1, (-0.5, 0.1))),
                position=(0.3, 0.2), velocity=(0.1, -0.05), rate=0.2)
    chain = Chain(links, (TorqueDrive(BangBang(2.0, 0.0, 4.0), initial_angle=0.2),
                          Hold(180.0)))
    system = ForwardSystem(chain, base, True)
    exact = NonlinearForwardSystem(chain, base)
    t = np.linspace(0.0, 4.0, 801)
    nu, n = len(system.free), system.n
    drive = system.free.index(system.joint_index(0))

    def balance(solution) -> np.ndarray:
        y, v = np.zeros((t.size, exact.n_y)), np.zeros((t.size, exact.n_y))
        y[:, :n], y[:, n:n + nu] = solution.q[:, nu:], solution.q[:, :nu]
        v[:, :n], v[:, n:n + nu] = solution.q_dot[:, nu:], solution.q_dot[:, :nu]
        energy = np.sum(exact.energy(t, y, v), axis=0)
        power = chain.joints[0].torque.value(t) * solution.q_dot[:, drive]
        work = cumulative_simpson(power, x=t, initial=0.0)
        return (energy - energy[0] - work) / np.abs(energy).max()

    reference = balance(integrate_forward(system, t, 1e-11, 1e-13))
    assert np.abs(reference).max() > 1e-3  # the first-order model's own error
    for rtol in (1e-4, 1e-6):
        fast = balance(integrate_forward(system, t, rtol, 1e-12, FAST_METHOD))
        assert np.abs(fast - reference).max() < rtol
