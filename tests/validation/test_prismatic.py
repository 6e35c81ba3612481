"""Sliders inside a chain (dynamics/prismatic.py): the work of the drives equals the change of
the energy of the exact kinematics on the simulated first-order trajectory.

The exact kinematics are written down here, sharing only the mode shapes with flexlink
(as tests/validation/brute_force.py does for revolute chains): link a on the hub, the
block at tip_a + s A(θ_a + w_a'(L)) u, link b from the block at θ_a + w_a'(L) + γ. As in
test_energy.py, the balance of the first-order model holds to third order in the deflection:
a fraction ~ w/L of the elastic energy; with rigid links it holds to the integration
tolerance.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.integrate import cumulative_simpson, simpson

from flexlink.dynamics.forward import ForwardSystem
from flexlink.model import (
    BangBang,
    Chain,
    Link,
    PrismaticJoint,
    Scenario,
    SimulationSettings,
    TorqueDrive,
)
from flexlink.motion import Cycloidal
from flexlink.simulation.forward import run_forward
from tests.validation.brute_force import _link_positions

AXIS, GAMMA, BLOCK = np.radians(30.0), np.radians(-20.0), 0.4


def _scenario(modes: int, stiffening: bool, hub_deg: float | None = None,
              at: float | None = None) -> Scenario:
    """Two links, a slider between them driven by a bang-bang force; the hub torque-driven
    (bang-bang) or, with ``hub_deg``, prescribed (a cycloidal move of that many degrees);
    ``at`` the line's point on link a (m, None: its tip)."""
    links = (Link("a", 1.0, 1.5, 60.0, modes=modes),
             Link("b", 0.6, 0.7, 20.0, tip_mass=0.15, modes=modes))
    scale = 1.0 if hub_deg is None else hub_deg / 20.0
    hub = (TorqueDrive(BangBang(1.2, 0.0, 0.6), 0.0, 0.5) if hub_deg is None
           else Cycloidal(0.0, hub_deg, 0.0, 0.8))
    joints = (hub, PrismaticJoint(TorqueDrive(BangBang(-scale, 0.1, 0.5), 0.2, 0.1), AXIS,
                                  GAMMA, mass=BLOCK, at=at))
    return Scenario(Chain(links, joints), settings=SimulationSettings(
        t_end=1.0, dt_out=1e-3, geometric_stiffening=stiffening, rtol=1e-9, atol=1e-13))


def _points(modal, beta, s, z, stiffening, at=None):
    """Grid points of both links (2, G) each, the block's position (2,); ``at`` the line's
    point on link a (m, None: its tip)."""
    na = modal[0].n
    xa, pa, slope = _link_positions(modal[0], np.zeros(2), beta, z[:na], stiffening)
    line = pa[:, -1]
    if at is not None:  # the section at x = at of the same exact kinematics
        _, pc, slope = _link_positions(replace(modal[0], length=at), np.zeros(2), beta,
                                       z[:na], stiffening)
        line = pc[:, -1]
    turn = beta + slope
    block = line + s * np.array([np.cos(turn + AXIS), np.sin(turn + AXIS)])
    xb, pb, _ = _link_positions(modal[1], block, turn + GAMMA, z[na:], stiffening)
    return (xa, pa), (xb, pb), block


def _energy(links, modal, p, pd, z, zd, stiffening, h=1e-5, at=None):
    """Kinetic energy of the exact kinematics (differences in time of the points) plus the
    bending energy (J), and the bending energy."""
    samples = [_points(modal, p[0] + pd[0] * tau, p[1] + pd[1] * tau, z + zd * tau, stiffening,
                       at) for tau in (-2 * h, -h, h, 2 * h)]

    def speed2(get):
        a, b, c, d = (get(smp) for smp in samples)
        v = (a - 8 * b + 8 * c - d) / (12 * h)
        return np.sum(v**2, axis=0)

    kinetic = 0.0
    for k, link in enumerate(links):
        v2 = speed2(lambda smp, k=k: smp[k][1])
        kinetic += 0.5 * link.mass_per_length * simpson(v2, x=samples[0][k][0])
        kinetic += 0.5 * link.tip_mass * v2[-1]
    kinetic += 0.5 * BLOCK * speed2(lambda smp: smp[2])
    offsets = np.cumsum([0] + [d.n for d in modal])
    strain = sum(0.5 * z[o:o + d.n] @ d.stiffness_matrix @ z[o:o + d.n]
                 for o, d in zip(offsets, modal))
    return kinetic + strain, strain


def _balance(modes: int, stiffening: bool, hub_deg: float | None = None,
             at: float | None = None) -> tuple[float, float, float]:
    """(max |work − ΔE|, peak bending energy, peak energy) of a 1 s run."""
    scenario = _scenario(modes, stiffening, hub_deg, at)
    t = np.linspace(0.0, 1.0, 2001)
    run = run_forward(scenario, t, lambda _: None, with_shapes=False)
    system = ForwardSystem(scenario.chain, _fixed(), stiffening)
    nu = len(system.free)
    z, zd = run.solution.q[:, nu:], run.solution.q_dot[:, nu:]
    p = np.stack([run.values["joint1_angle"], run.values["joint2_position"]], 1)
    pd = np.stack([run.values["joint1_rate"], run.values["joint2_velocity"]], 1)
    # A bang-bang drive is constant between switches, which are output times: its work over
    # an output interval is the constant times the coordinate's change, exactly. A
    # prescribed hub's smooth power τ β̇ is integrated by Simpson's rule.
    mid = 0.5 * (t[1:] + t[:-1])
    work = np.zeros(t.size)
    for k, joint in enumerate(scenario.chain.joints):
        drive = joint.drive if isinstance(joint, PrismaticJoint) else joint
        if isinstance(drive, TorqueDrive):
            work[1:] += np.cumsum(drive.torque.value(mid) * np.diff(p[:, k]))
        else:
            work += cumulative_simpson(run.values[f"joint{k + 1}_torque"] * pd[:, k], x=t,
                                       initial=0.0)
    every = slice(None, None, 10)
    energy, strain = np.array([
        _energy(scenario.chain.links, system.modal, a, b, c, d, stiffening, at=at)
        for a, b, c, d in zip(p[every], pd[every], z[every], zd[every])]).T
    error = np.abs(work[every] - (energy - energy[0])).max()
    return float(error), float(strain.max()), float(energy.max())


def _fixed():
    from flexlink.model import Base

    return Base()


@pytest.mark.parametrize("at", [None, 0.45], ids=["tip", "inside"])
def test_rigid_chain_energy_is_the_work_of_the_drives(at: float | None) -> None:
    """Rigid links, hub and slider each under a bang-bang drive, the slider's line through
    link a's tip or through its section at 0.45 m: the drives' work equals the kinetic
    energy's change to 1e-6 of it (the integration tolerance)."""
    error, _, kinetic = _balance(0, False, at=at)
    assert error < 1e-6 * kinetic


def test_flexible_chain_energy_balance_is_third_order() -> None:
    """Flexible links, a prescribed hub move of 20°, 10° and 5° with the slider's force
    scaled alike: the balance's error, a fraction of the peak bending energy, falls with the
    amplitude as a third-order error does (measured 15.6%, 8.8%, 5.3%): a wrong or missing
    first-order coupling leaves a fraction that does not fall."""
    fractions = []
    for degrees in (20.0, 10.0, 5.0):
        error, strain, _ = _balance(3, True, degrees)
        assert strain > 1e-3
        fractions.append(error / strain)
    assert fractions[0] > 1.5 * fractions[1] > 1.5 * 1.1 * fractions[2]
    assert fractions[2] < 0.06


def _exact_forces(system: ForwardSystem, links, rigid, z, zd, zdd, stiffening, h=1e-3,
                  dx=1e-6, at=None) -> np.ndarray:
    """Σ m (∂r/∂x_i)·r̈ + (K_e z)_i over x = [β, s, z], from the exact kinematics with
    differences in time (the trajectory p + ṗτ + ½p̈τ², z + żτ + ½z̈τ²) and in x."""
    p0, pd0, pdd0 = rigid
    n, modal = system.n, system.modal

    def points(tau, dp=None, dz=None):
        dp = np.zeros(2) if dp is None else dp
        dz = np.zeros(n) if dz is None else dz
        p = p0 + pd0 * tau + 0.5 * pdd0 * tau**2 + dp
        return _points(modal, p[0], p[1], z + zd * tau + 0.5 * zdd * tau**2 + dz, stiffening,
                       at)

    samples = [points(tau) for tau in (-2 * h, -h, 0.0, h, 2 * h)]

    def second(get):
        a, b, c, d, e = (get(smp) for smp in samples)
        return (-a + 16 * b - 30 * c + 16 * d - e) / (12 * h * h)

    acc = [second(lambda smp: smp[0][1]), second(lambda smp: smp[1][1]),
           second(lambda smp: smp[2])]
    out = np.zeros(2 + n)
    for i in range(2 + n):
        dp, dz = np.zeros(2), np.zeros(n)
        (dp if i < 2 else dz)[i if i < 2 else i - 2] = dx
        plus, minus = points(0.0, dp, dz), points(0.0, -dp, -dz)
        for k in range(2):
            dr = (plus[k][1] - minus[k][1]) / (2 * dx)
            out[i] += links[k].mass_per_length * simpson(np.sum(dr * acc[k], 0),
                                                         x=samples[2][k][0])
            out[i] += links[k].tip_mass * dr[:, -1] @ acc[k][:, -1]
        out[i] += BLOCK * (plus[2] - minus[2]) / (2 * dx) @ acc[2]
    o = 0
    for d in modal:
        out[2 + o:2 + o + d.n] += d.stiffness_matrix @ z[o:o + d.n]
        o += d.n
    return out


@pytest.mark.parametrize("at", [None, 0.45], ids=["tip", "inside"])
@pytest.mark.parametrize("stiffening", [False, True])
def test_equations_are_the_linearisation_of_the_exact_kinematics(stiffening: bool,
                                                                 at: float | None) -> None:
    """At a moving rigid state (β, s, their rates and accelerations), the rows of every
    coordinate — hub, slider and elastic — of M z̈ + C ż + K z − f equal the exact
    generalized forces' part linear in z, ż, z̈ (symmetric differences of size 3e-4 leave
    third-order terms) to 1e-4 of their size; the slider's line through link a's tip or
    through its section at 0.45 m (where the outboard load and the line's turn act)."""
    scenario = _scenario(3, stiffening, at=at)
    system = ForwardSystem(scenario.chain, _fixed(), stiffening)
    links, n = scenario.chain.links, system.n
    rigid = (np.array([0.3, 0.25]), np.array([1.1, 0.4]), np.array([0.7, -0.5]))
    M, C, K, _ = (a[0] for a in system.matrices(*(r[None] for r in rigid)))
    zc = slice(2, 2 + n)
    rng = np.random.default_rng(1)
    eps = 3e-4
    for which, matrix in enumerate((K, C, M)):
        v = rng.normal(size=n)
        args = [np.zeros(n)] * 3
        args[which] = eps * v
        plus = _exact_forces(system, links, rigid, *args, stiffening, at=at)
        args[which] = -eps * v
        minus = _exact_forces(system, links, rigid, *args, stiffening, at=at)
        exact = (plus - minus) / (2 * eps)
        ours = matrix[:, zc] @ v
        np.testing.assert_allclose(ours, exact, rtol=0, atol=1e-4 * np.abs(exact).max())


# --- against a geometrically exact model ---------------------------------------------------

def slider_fe_case(modes: int = 6, gamma_deg: float = 0.0, EI: float = 12.0,
                   moment_amplitude: float = 0.6):
    """The case of the Exudyn comparison (and of benchmarks/slider_vs_fe.py): a rigid link
    (0.5 m, 2 kg/m) turned by a ±0.6 N·m bang-bang moment for 1 s, a 0.5 kg block sliding
    along its axis from 0.1 m at its tip under a ±1.5 N bang-bang force from 0.2 s to 1 s,
    carrying a beam (0.8 m, 0.6 kg/m, EI = 12 N·m², tip mass 0.2 kg) at ``gamma_deg`` from
    the line; 2 s, undamped, rtol 1e-6. Returns the flexlink scenario (first order, stiffened) and the
    arguments of exudyn_slider_reference.simulate_slider_exudyn but the element count.
    ``EI`` (N·m²) and ``moment_amplitude`` (N·m) change the beam and the moment (the
    nonlinear model's large-deflection case: tests/validation/test_nonlinear_prismatic.py)."""
    from flexlink.model import PointSensor

    beam = Link("beam", 0.8, 0.6, EI, tip_mass=0.2, thickness=0.01, modes=modes)
    moment, force = BangBang(moment_amplitude, 0.0, 1.0), BangBang(1.5, 0.2, 0.8)
    gamma, block, s0 = np.radians(gamma_deg), 0.5, 0.1
    scenario = Scenario(
        Chain((Link("link", 0.5, 2.0, 1.0, modes=0), beam),
              (TorqueDrive(moment), PrismaticJoint(TorqueDrive(force, s0), 0.0, gamma,
                                                   mass=block))),
        (PointSensor("tip", "deflection", 1, beam.length),),
        SimulationSettings(2.0, 0.002, geometric_stiffening=True, rtol=1e-6))
    args = {"link_length": 0.5, "link_inertia": 2.0 * 0.5**3 / 3, "beam": beam,
            "block": block, "axis": 0.0, "gamma": gamma, "s0": s0,
            "moment": lambda t: float(moment.value(np.array([t]))[0]),
            "force": lambda t: float(force.value(np.array([t]))[0]), "t_end": 2.0,
            "dt_out": 0.002}
    return scenario, args


@pytest.mark.slow
@pytest.mark.parametrize("gamma_deg", [0.0, 30.0], ids=["telescoping", "inclined"])
def test_beam_on_a_slider_at_a_rotating_link_against_exudyn(gamma_deg: float) -> None:
    """slider_fe_case against Exudyn's geometrically exact beam (16 elements) on a block held
    to the line by a prismatic joint: the link's angle and the slider's travel within 1e-3
    of their peaks, the beam's tip deflection within 3% of its peak (stiffened first order,
    6 modes; measured 0.07% / 0.04% / 0.8% telescoping, 0.05% / 0.03% / 1.1% inclined)."""
    from flexlink import simulate

    from .exudyn_slider_reference import simulate_slider_exudyn

    pytest.importorskip("exudyn")
    scenario, args = slider_fe_case(gamma_deg=gamma_deg)
    exact = simulate_slider_exudyn(**args, elements=16)
    r = simulate(scenario, shapes=False)
    for ours, theirs, bound in (("joint1_angle", "angle", 1e-3),
                                ("joint2_position", "travel", 1e-3),
                                ("tip", "tip_deflection", 0.03)):
        reference = exact[theirs]
        assert np.abs(np.asarray(r[ours]) - reference).max() < bound * np.abs(reference).max()
