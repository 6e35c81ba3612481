"""Rigid bodies on links (model.Body: mass, centre offset along the section's tangent,
inertia about the centre, at the tip or inside the span) against independent values
(docs/validation.md, Case 17):

* the natural frequencies of a cantilever carrying an offset tip body — exact with the
  offset-tip basis — and a body inside the span (clamped–free modes, converging with their
  number), against cubic-Hermite finite elements (tests/validation/body_beam.py);
* the static tip deflection under gravity against the closed form of the body's weight
  acting at its centre;
* the small-amplitude period of a rigid link carrying an offset body, a physical pendulum;
* the tip mass and tip inertia as the body at the tip without offset: the same equations
  (first order), the same run bit for bit (nonlinear);
* the nonlinear model (its own point-mass description of a body, dynamics/nonlinear_bodies.py)
  against the first-order model: the difference falls as the deflection squared; an offset
  body on a rigid link swings as the physical pendulum in both models, and the nonlinear
  forward model conserves its energy with bodies in gravity;
* the compiled assemblies with bodies against the numpy equations (tests/unit:
  test_prescribed_kernel, test_forward_kernel), and the momentum of a free base with
  appendages carrying bodies conserved through a forward run.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.linalg import eigh

from flexlink import simulate
from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.dynamics.forward import ForwardSystem, momentum
from flexlink.model import BangBang, Base, Body, Chain, Link, TorqueDrive
from flexlink.motion import Hold
from flexlink.scenario.errors import ScenarioError
from flexlink.scenario.load import scenario_from_dict
from flexlink.solvers.forward import integrate_forward
from tests.validation.body_beam import (
    fe_frequencies,
    hanging_tip_deflection,
    static_tip_deflection,
)

G = 9.81
L, RHO, EI = 1.2, 1.5, 40.0  # m, kg/m, N·m²
TIP = Body(L, 0.6, (0.15, 0.0), 0.02)  # kg, m, kg·m²: centre 15 cm beyond the tip
BRACKET = Body(L, 0.6, (0.15, 0.08), 0.02)  # … and 8 cm across the link
INNER = Body(0.7, 0.8, (-0.1, 0.0), 0.01)  # on a node of the FE mesh (L/120 spacing)
INNER_ACROSS = Body(0.7, 0.8, (-0.1, -0.06), 0.01)


def _frequencies(link: Link) -> np.ndarray:
    """Natural frequencies (Hz) of the first-order model of the link clamped to a held
    joint, no gravity: the eigenvalues of its K, M at rest."""
    system = FirstOrderSystem(Chain((link,), (Hold(0.0),)))
    _, _, K, _ = system.matrices(np.array([0.0]))
    M = system.matrices(np.array([0.0]))[0]
    return np.sqrt(eigh(K[0], M[0], eigvals_only=True)) / (2 * np.pi)


def _link(bodies: tuple[Body, ...], modes: int, shapes: str, **extra) -> Link:
    return Link("arm", L, RHO, EI, modes=modes, mode_shapes=shapes, bodies=bodies, **extra)


def test_the_fe_reference_is_converged() -> None:
    coarse = fe_frequencies(L, RHO, EI, [(TIP.at, TIP.mass, TIP.offset, TIP.inertia)])[:4]
    fine = fe_frequencies(L, RHO, EI, [(TIP.at, TIP.mass, TIP.offset, TIP.inertia)],
                          elements=240)[:4]
    np.testing.assert_allclose(coarse, fine, rtol=1e-7)


@pytest.mark.parametrize("tip", [TIP, BRACKET], ids=["along", "across"])
def test_offset_tip_body_frequencies_are_exact_in_its_basis(tip: Body) -> None:
    """The offset-tip modes (coupled shear and moment conditions) give the exact frequencies
    with 4 modes; clamped–free modes approach them slowly (the moment they cannot carry)."""
    exact = fe_frequencies(L, RHO, EI, [(tip.at, tip.mass, tip.offset, tip.inertia)])[:4]
    np.testing.assert_allclose(_frequencies(_link((tip,), 4, "tip_loaded")), exact, rtol=1e-6)
    errors = [abs(_frequencies(_link((tip,), n, "clamped_free"))[1] / exact[1] - 1)
              for n in (3, 6, 12)]
    assert errors[0] > errors[1] > errors[2] > 1e-6
    # the offset matters: the tip body without it is another beam
    centred = Body(L, tip.mass, (0.0, 0.0), tip.inertia)
    assert abs(_frequencies(_link((centred,), 4, "tip_loaded"))[0] / exact[0] - 1) > 0.05


@pytest.mark.parametrize("inner", [INNER, INNER_ACROSS], ids=["along", "across"])
def test_body_inside_the_span_converges_with_modes(inner: Body) -> None:
    exact = fe_frequencies(L, RHO, EI, [(inner.at, inner.mass, inner.offset,
                                         inner.inertia)])[:2]
    errors = np.array([np.abs(_frequencies(_link((inner,), n, "clamped_free"))[:2] / exact - 1)
                       for n in (4, 8, 16)])
    assert np.all(np.diff(errors, axis=0) < 0)  # each frequency converges from above
    assert errors[-1].max() < 3e-3


@pytest.mark.parametrize("body, shapes, modes, rtol", [
    (TIP, "tip_loaded", 4, 1e-4), (BRACKET, "tip_loaded", 4, 1e-4),
    (INNER, "clamped_free", 8, 1e-3)])
def test_static_deflection_under_gravity(body: Body, shapes: str, modes: int,
                                         rtol: float) -> None:
    """A horizontal cantilever in gravity: the body's weight acts at its centre x_b + c."""
    system = FirstOrderSystem(Chain((_link((body,), modes, shapes),), (Hold(0.0),)),
                              gravity=(0.0, -G))
    z = system.equilibrium()
    tip = float(system.modal[0].tip_value @ z)
    exact = static_tip_deflection(L, RHO, EI, G, body.at, body.mass, body.offset[0])
    assert tip == pytest.approx(exact, rel=rtol)


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
@pytest.mark.parametrize("body", [TIP, BRACKET], ids=["along", "across"])
def test_rigid_link_with_offset_body_swings_as_a_physical_pendulum(model: str,
                                                                    body: Body) -> None:
    """A rigid link on a free joint carrying an offset body, released 2° from hanging (its
    centre of mass below the joint): period 2π√(J_O/(M g d)), J_O = ρL³/3 + m|X|² + J and
    M d = |ρL²/2 e_x + m X|, X = [L + c_x, c_y] the body's centre in the link's frame."""
    centre = np.array([L + body.offset[0], body.offset[1]])
    moment = np.array([RHO * L**2 / 2, 0.0]) + body.mass * centre  # M × centre of mass
    hanging = -90.0 - math.degrees(math.atan2(moment[1], moment[0]))
    scenario = scenario_from_dict({
        "simulation": {"t_end": 3.0, "dt_out": 0.002, "gravity": [0.0, -G], "rtol": 1e-8,
                       "model": model},
        "links": [{"name": "arm", "length": L, "mass_per_length": RHO, "rigid": True,
                   "bodies": [{"at": body.at, "mass": body.mass, "offset": list(body.offset),
                               "inertia": body.inertia}]}],
        "joints": [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.0}],
                    "initial_angle_deg": hanging + 2.0}]})
    r = simulate(scenario, shapes=False)
    J_O = RHO * L**3 / 3 + body.mass * float(centre @ centre) + body.inertia
    small = 2 * math.pi * math.sqrt(J_O / (float(np.hypot(*moment)) * G))
    exact = small * (1 + math.radians(2.0) ** 2 / 16)  # amplitude correction, θ0 = 2°
    t, a = np.asarray(r.time), np.asarray(r["joint1_angle"]) - math.radians(hanging)
    i = np.flatnonzero((a[1:-1] > a[:-2]) & (a[1:-1] >= a[2:])) + 1
    dt = t[1] - t[0]
    peaks = t[i] + 0.5 * dt * (a[i - 1] - a[i + 1]) / (a[i - 1] - 2 * a[i] + a[i + 1])
    assert peaks.size >= 1
    assert peaks[0] == pytest.approx(exact, rel=1e-5)
    assert a.max() == pytest.approx(math.radians(2.0), rel=1e-4)  # swings about the vertical


@pytest.mark.parametrize("body, rtol", [(BRACKET, 1e-4), (INNER_ACROSS, 2e-3)],
                         ids=["tip", "inside"])
def test_hanging_link_is_bent_by_the_moment_of_a_body_across_it(body: Body,
                                                                 rtol: float) -> None:
    """A cantilever hanging in gravity: its weight pulls along it, a body whose centre is c_y
    across the link bends it by the moment −m g c_y (the linear model: no stiffening)."""
    system = FirstOrderSystem(Chain((_link((body,), 8, "tip_loaded"),), (Hold(-90.0),)),
                              gravity=(0.0, -G))
    tip = float(system.modal[0].tip_value @ system.equilibrium())
    exact = hanging_tip_deflection(L, EI, G, body.at, body.mass, body.offset[1])
    assert tip == pytest.approx(exact, rel=rtol)


def test_tip_mass_is_the_tip_body_without_offset() -> None:
    """tip_mass and tip_inertia and the same body given as [[links.bodies]] at the tip give the
    same equations, moving and in gravity."""
    a = Chain((Link("a", L, RHO, EI, tip_mass=0.4, tip_inertia=0.03, modes=3,
                    mode_shapes="tip_loaded"),), (Hold(0.0),))
    b = Chain((Link("a", L, RHO, EI, modes=3, mode_shapes="tip_loaded",
                    bodies=(Body(L, 0.4, (0.0, 0.0), 0.03),)),), (Hold(0.0),))
    t = np.array([0.0])
    for ours, theirs in zip(FirstOrderSystem(b, True, gravity=(1.0, -G)).matrices(t),
                            FirstOrderSystem(a, True, gravity=(1.0, -G)).matrices(t)):
        np.testing.assert_allclose(ours, theirs, rtol=1e-13, atol=1e-13 * np.abs(theirs).max())


def test_free_base_with_bodies_keeps_its_momentum() -> None:
    """A free hub with two appendages carrying bodies (offset at the tip, inside the span),
    one on a motor whose bang-bang torque is an internal load: linear and angular momentum
    (from the kinematics, bodies included) constant to 1e-8 of their size."""
    links = (Link("a", 2.0, 1.0, 50.0, modes=2, mode_shapes="tip_loaded",
                  bodies=(Body(2.0, 0.3, (0.2, 0.1), 0.01), Body(1.1, 0.2, (0.05, 0.0), 0.004))),
             Link("b", 1.5, 1.0, 40.0, modes=2, bodies=(Body(0.9, 0.25, (-0.1, -0.07), 0.0),)))
    base = Base("free", mass=20.0, inertia=5.0, attachments=((0, (0.5, 0.0)), (1, (-0.5, 0.1))),
                position=(0.3, 0.2), velocity=(0.1, -0.05), rate=0.2)
    chain = Chain(links, (TorqueDrive(BangBang(2.0, 0.0, 1.0), initial_angle=0.2),
                          Hold(180.0)))
    system = ForwardSystem(chain, base, geometric_stiffening=True)
    t = np.linspace(0.0, 2.0, 101)
    solution = integrate_forward(system, t, rtol=1e-10, atol=1e-12, compiled=True)
    nu = len(system.free)
    p_free, pd_free = solution.q[:, :nu], solution.q_dot[:, :nu]
    z, zd = solution.q[:, nu:], solution.q_dot[:, nu:]
    pdd_free, _, _ = system.accelerations(t, p_free, pd_free, z, zd, solution.extra)
    p, pd, _ = system.rigid_state(t, p_free, pd_free, pdd_free)
    linear, angular = momentum(system, p, pd, z, zd)
    assert np.abs(z).max() > 0.005
    assert np.abs(linear - linear[0]).max() < 1e-8 * np.linalg.norm(linear[0])
    assert np.abs(angular - angular[0]).max() < 1e-8 * abs(angular[0])


def _scenario(body: dict, model: str = "first_order") -> dict:
    return {"simulation": {"t_end": 0.1, "dt_out": 0.01, "model": model},
            "links": [{"name": "arm", "length": 1.0, "mass_per_length": 1.0, "EI": 10.0,
                       "bodies": [body]}],
            "joints": [{"motion": [{"profile": "hold", "angle_deg": 0.0}]}]}


@pytest.mark.parametrize("body, model, words", [
    ({"mass": -1.0}, "first_order", "links[0].bodies[0].mass"),
    ({"mass": 1.0, "inertia": -0.1}, "first_order", "links[0].bodies[0].inertia"),
    ({"mass": 1.0, "at": 1.5}, "first_order", "links[0].bodies[0].at"),
    ({"at": 0.5}, "first_order", "needs a mass or an inertia"),
    ({"mass": 1.0, "colour": "red"}, "first_order", "colour"),
])
def test_bad_bodies_are_refused_naming_the_field(body: dict, model: str, words: str) -> None:
    with pytest.raises(ScenarioError, match=None) as info:
        scenario_from_dict(_scenario(body, model))
    assert words in str(info.value)


def test_a_body_at_the_tip_is_the_default() -> None:
    scenario = scenario_from_dict(_scenario({"mass": 0.5, "offset": [0.1, 0.0]}))
    (body,) = scenario.chain.links[0].bodies
    assert body == Body(1.0, 0.5, (0.1, 0.0), 0.0)
    assert scenario.chain.links[0].mass == pytest.approx(1.5)


def _moving(model: str, EI_: float, link: dict) -> dict:
    return {"simulation": {"t_end": 1.0, "dt_out": 0.01, "model": model, "rtol": 1e-8,
                           "geometric_stiffening": True},
            "links": [{"name": "arm", "length": L, "mass_per_length": RHO, "EI": EI_,
                       "modes": 4, "mode_shapes": "tip_loaded", **link}],
            "joints": [{"motion": [{"profile": "cycloidal", "from_deg": 0.0, "to_deg": 60.0,
                                    "start": 0.1, "duration": 0.5}]}]}


BODIES = {"bodies": [{"mass": BRACKET.mass, "offset": list(BRACKET.offset),
                      "inertia": BRACKET.inertia},
                     {"at": INNER_ACROSS.at, "mass": INNER_ACROSS.mass,
                      "offset": list(INNER_ACROSS.offset), "inertia": INNER_ACROSS.inertia}]}


def test_nonlinear_tip_mass_is_the_tip_body_bit_for_bit() -> None:
    runs = [simulate(scenario_from_dict(_moving("nonlinear", 400.0, link)), shapes=False)
            for link in ({"tip_mass": 0.4, "tip_inertia": 0.03},
                         {"bodies": [{"mass": 0.4, "inertia": 0.03}]})]
    for channel in ("arm_tip_X", "arm_tip_Y", "joint1_torque"):
        assert np.array_equal(np.asarray(runs[0][channel]), np.asarray(runs[1][channel]))


def test_nonlinear_and_first_order_bodies_agree_as_the_deflection_falls() -> None:
    """Two independent descriptions of the bodies (the first order's modal integrals, the
    nonlinear model's point masses and rotary rows) on a slewed arm carrying a bracket at its
    tip and a body inside the span, both off the axis: their tip deflections and joint torques
    differ by what the first-order model leaves out, second order in the deflection (relative
    to the peak: at least as fast as the deflection falls)."""
    gaps, peaks = [], []
    for EI_ in (400.0, 4000.0):
        runs = [simulate(scenario_from_dict(_moving(model, EI_, BODIES)), shapes=False)
                for model in ("nonlinear", "first_order")]
        angle = np.asarray(runs[1]["joint1_angle"])
        across = [np.asarray(r["arm_tip_Y"]) * np.cos(angle)
                  - np.asarray(r["arm_tip_X"]) * np.sin(angle) for r in runs]
        torque = [np.asarray(r["joint1_torque"]) for r in runs]
        peaks.append(np.abs(across[1]).max())
        gaps.append(max(np.abs(across[0] - across[1]).max() / peaks[-1],
                        np.abs(torque[0] - torque[1]).max() / np.abs(torque[1]).max()))
    assert peaks[1] / L < 0.01 and gaps[1] < 2e-4
    ratio = peaks[0] / peaks[1]
    assert gaps[0] / gaps[1] > 0.7 * ratio  # the difference is second order in the deflection


def test_nonlinear_forward_conserves_energy_with_bodies() -> None:
    """A flexible pendulum carrying an offset tip body and a body inside the span, released
    70° from hanging (nonlinear forward model): kinetic + elastic + gravitational energy
    constant, with bodies' rotary inertias and offset centres in every term."""
    from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
    from flexlink.solvers.gauss_forward import solve_nonlinear_forward

    scenario = scenario_from_dict({
        "simulation": {"t_end": 1.5, "dt_out": 0.005, "gravity": [0.0, -G],
                       "model": "nonlinear"},
        "links": [{"name": "arm", "length": 1.0, "mass_per_length": 1.0, "EI": 5.0,
                   "modes": 3, **BODIES}],
        "joints": [{"drive": "torque", "torque": [{"profile": "step", "amplitude": 0.0}],
                    "initial_angle_deg": -20.0}]})
    system = NonlinearForwardSystem(scenario.chain, gravity=scenario.settings.gravity)
    t = np.linspace(0.0, 1.5, 301)
    y, v, _ = system.from_solution(solve_nonlinear_forward(system, t, 1e-5))
    kinetic, elastic = system.energy(t, y, v)
    potential = system.potential(t, y)
    total = kinetic + elastic + potential
    assert np.abs(elastic).max() > 1e-3 * np.abs(kinetic).max()
    assert np.ptp(potential) > 1.0
    assert np.ptp(total) < 1e-6 * np.ptp(potential)


def test_offset_payload_example_round_trips_and_starts_in_equilibrium() -> None:
    """examples/offset_payload.toml: its resolved form loads to the same chain, and its run
    starts at rest in the static deflection of the closed form (two bodies, superposed)."""
    import tomllib
    from pathlib import Path

    from flexlink.scenario.load import load_scenario, resolve_scenario_dict
    from flexlink.scenario.toml_writer import dump_toml

    path = Path(__file__).resolve().parents[2] / "examples" / "offset_payload.toml"
    scenario = load_scenario(path)
    again = scenario_from_dict(tomllib.loads(dump_toml(resolve_scenario_dict(path))))
    assert again.chain == scenario.chain
    raw = tomllib.loads(path.read_text())
    raw["simulation"]["t_end"] = 0.2
    frame = simulate(scenario_from_dict(raw), shapes=False).to_pandas()
    link = scenario.chain.links[0]
    payload, housing = link.bodies
    exact = (static_tip_deflection(link.length, link.mass_per_length, link.EI, G, payload.at,
                                   payload.mass, payload.offset[0])
             + static_tip_deflection(link.length, 0.0, link.EI, G, housing.at, housing.mass,
                                     housing.offset[0]))
    assert frame["tip_deflection"].iloc[0] == pytest.approx(exact, rel=2e-3)
