"""The flexible four-bar of examples/four_bar_benchmark.toml (docs/validation.md, Case 32):
the experimental linkage of G. H. Sutherland (ASME J. Eng. Ind. 98, 1976, 788–794), the test
linkage of D. A. Turcic, A. Midha and J. R. Bosnik (ASME J. Dyn. Syst. Meas. Control 106,
1984, 255–260): crank 4.25 in, coupler 11.0 in, follower 10.65 in, ground pivots 10.0 in
apart, aluminium strips 1 in wide (crank 0.167 in thick, coupler and follower 0.063 in),
E = 10.3e6 psi, 2714 kg/m³, 0.042 kg on each moving pin; all three links bend.

The publications give the linkage's midspan strains as curves only, so this checks flexlink on
the published linkage against two independent models: frame elements (the linearised
frequencies, tests/validation/loop_fe.py) and Exudyn's geometrically exact beams (the run:
the example's crank spun up to 200 rpm, no damping; slow, skipped without Exudyn).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from flexlink import simulate
from flexlink.scenario import resolve_scenario_dict, scenario_from_dict

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "four_bar_benchmark.toml"
INCH = 0.0254  # m
PIVOTS = 10.0 * INCH  # m, the ground pivots' distance
THIN = 0.063 * INCH  # m, the coupler's and the follower's thickness
E = 10.3e6 * 4.4482216152605 / INCH**2  # Pa: 10.3e6 psi
JOINT_MASS = 0.042  # kg, on each moving pin


def closed_angles(crank: float) -> tuple[float, float, float]:
    """The absolute angles (rad) of crank, coupler and follower that close the rigid loop at
    crank angle ``crank`` (rad), the coupler above the ground line (the example's branch)."""
    L1, L2, L3 = 4.25 * INCH, 11.0 * INCH, 10.65 * INCH
    a = L1 * np.array([math.cos(crank), math.sin(crank)])
    to_a = a - np.array([PIVOTS, 0.0])
    rho = math.hypot(*to_a)
    follower = math.atan2(to_a[1], to_a[0]) - math.acos((L3**2 + rho**2 - L2**2)
                                                         / (2 * L3 * rho))
    b = np.array([PIVOTS, 0.0]) + L3 * np.array([math.cos(follower), math.sin(follower)])
    return crank, math.atan2(b[1] - a[1], b[0] - a[0]), follower


def test_the_example_is_the_published_linkage() -> None:
    """Lengths, sections (EI = E w t³/12, mass per length ρ w t) and joint masses from the
    published inch values."""
    d = resolve_scenario_dict(EXAMPLE)
    assert d["joints"][2]["base_point"] == pytest.approx([PIVOTS, 0.0], rel=1e-12)
    scenario = scenario_from_dict(d)
    crank, coupler, follower = scenario.chain.links
    for link, inches, thickness in ((crank, 4.25, 0.167 * INCH), (coupler, 11.0, THIN),
                                    (follower, 10.65, THIN)):
        assert link.length == pytest.approx(inches * INCH, rel=1e-4)
        assert link.EI == pytest.approx(E * INCH * thickness**3 / 12, rel=1e-4)
        assert link.mass_per_length == pytest.approx(2714.0 * INCH * thickness, rel=1e-4)
    assert (crank.tip_mass, coupler.tip_mass) == (JOINT_MASS, JOINT_MASS)
    assert [link.mode_shapes for link in (coupler, follower)] == ["pinned_pinned"] * 2


def _frequencies(crank_deg: float, modes: int | None = None, crank_basis: str | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The linkage at rest with its crank free at ``crank_deg``: `loop_frequencies`, the
    frame elements' (80 per link, EA = 1e8 N: inextensible as flexlink's links; the joint
    masses lumped on the pins) and the eigenvalues of `reduced_jacobian` (1/s); ``modes``
    per link and the crank's ``crank_basis`` (default: the example's)."""
    from flexlink.dynamics.forward import ForwardSystem
    from flexlink.dynamics.loops import LoopSystem, loop_frequencies, reduced_jacobian
    from tests.validation.loop_fe import four_bar_frequencies

    angles = closed_angles(math.radians(crank_deg))
    d = resolve_scenario_dict(EXAMPLE)
    d["joints"][0] = {"drive": "free", "initial_angle_deg": crank_deg}
    d["joints"][1]["initial_angle_deg"] = math.degrees(angles[1] - angles[0])
    d["joints"][2]["initial_angle_deg"] = math.degrees(angles[2])
    for link in d["links"]:
        link["modes"] = modes or link["modes"]
    if crank_basis:
        d["links"][0]["mode_shapes"] = crank_basis
    scenario = scenario_from_dict(d)
    loops = LoopSystem(ForwardSystem(scenario.chain, scenario.base, True), scenario.closures)
    crank, coupler, follower = ((link.length, link.mass_per_length, link.EI)
                                for link in scenario.chain.links)
    fe = four_bar_frequencies(crank, coupler, follower, (PIVOTS, 0.0), angles, EA=1e8,
                              elements=80, count=6, coupler_tip=(JOINT_MASS, 0.0),
                              crank_tip=JOINT_MASS)
    return loop_frequencies(loops), fe, np.linalg.eigvals(reduced_jacobian(loops, 0.0)[0])


@pytest.mark.parametrize("crank_deg", [0.0, 90.0])
def test_linearised_frequencies_match_frame_elements(crank_deg: float) -> None:
    """The linkage at rest with its crank free (one mechanism motion), the example's bases
    (crank 2 modes, coupler and follower 4), against frame elements: the five lowest
    frequencies (48.1, 53.2, 192.1, 205.5, 428.9 Hz at crank 0°) within 5e-5, measured
    1.9e-5."""
    model, fe, _ = _frequencies(crank_deg)
    assert model[0] < 1e-3 and fe[0] < 1.0  # the mechanism's motion
    assert fe[1] > 45.0
    assert np.abs(model[1:6] / fe[1:6] - 1).max() < 5e-5


@pytest.mark.parametrize("crank_basis", ["outboard_loaded", "clamped_free"])
def test_eight_modes_per_link_keep_the_frequencies(crank_basis: str) -> None:
    """8 modes on every link, the crank's clamped-type: the crank's high modes with its
    joint angle nearly cancel in the kinetic energy, so the rates are nonlinear in their
    coordinates on the scale that turns the crank's axis by β_i q_i (`difference_steps`).
    Every eigenvalue stays oscillatory (no real pair: one stepped 1e-6 m in every elastic
    coordinate had ±1.5e6 /s, an extra zero frequency) and the five lowest frequencies match
    the frame elements as with fewer modes (measured 1.7e-5)."""
    model, fe, eigenvalues = _frequencies(0.0, 8, crank_basis)
    assert np.abs(eigenvalues.real).max() < 1e-6 * np.abs(eigenvalues).max()
    assert model[0] < 1e-3 and model[1] > 45.0
    assert np.abs(model[1:6] / fe[1:6] - 1).max() < 5e-5


@pytest.mark.slow
def test_the_run_matches_the_geometrically_exact_model() -> None:
    """The example (first order, stiffened; 2 + 4 + 4 modes; default rtol) and the same on
    the nonlinear model against Exudyn's Simo–Reissner beams (64 elements per link, steps
    1.25e-5 s; 128 elements and 6.25e-6 s move its channels by ≤ 0.27% of their peaks) over
    the whole run: the coupler's and follower's midspan deflections (peaks 0.80, 1.08 mm)
    and bending strains (peaks 78, 114 µε; Exudyn's from the section angles of the nodes
    beside the midspan). Measured: nonlinear within 0.38–0.73% of each peak, first order
    stiffened within 0.55–1.41%; the follower's angle within 2.3e-5 rad. Without geometric
    stiffening (the pin's force along the coupler and the follower, up to 12 N, is 15% of
    their buckling loads π²EI/L² ≈ 80 N): 20–30%; with the crank rigid: 14% and 23% (the
    strains)."""
    pytest.importorskip("exudyn")
    from tests.validation.exudyn_loops_reference import simulate_four_bar_exudyn

    d = resolve_scenario_dict(EXAMPLE)
    scenario = scenario_from_dict(d)
    crank, coupler, follower = scenario.chain.links
    ref = simulate_four_bar_exudyn(
        crank.length, coupler, follower, (PIVOTS, 0.0), scenario.chain.joints[0],
        closed_angles(0.0), E * INCH * THIN, scenario.settings.t_end, scenario.settings.dt_out,
        elements=64, dt=1.25e-5, crank_mass_per_length=crank.mass_per_length,
        crank_tip_mass=crank.tip_mass, crank_EI=crank.EI, crank_EA=E * INCH * 0.167 * INCH)
    half = THIN / 2
    expected = {"coupler_mid": ref["mid_deflection"],
                "follower_mid": ref["rocker_mid_deflection"],
                "coupler_strain": -half * ref["mid_curvature"],
                "follower_strain": -half * ref["rocker_mid_curvature"]}
    assert np.abs(expected["follower_strain"]).max() > 1e-4

    def errors(run) -> dict[str, float]:
        return {k: float(np.abs(run[k] - v).max() / np.abs(v).max())
                for k, v in expected.items()}

    first_order = simulate(scenario)
    d["simulation"]["model"] = "nonlinear"
    del d["simulation"]["geometric_stiffening"]
    nonlinear = simulate(scenario_from_dict(d))
    d["simulation"]["model"] = "first_order"
    d["simulation"]["geometric_stiffening"] = False
    unstiffened = simulate(scenario_from_dict(d))
    assert max(errors(nonlinear).values()) < 0.01
    assert max(errors(first_order).values()) < 0.02
    assert min(errors(unstiffened).values()) > 0.15
    for run in (first_order, nonlinear):
        assert np.abs(np.unwrap(run["joint3_angle"]) - ref["rocker_angle"]).max() < 1e-4
