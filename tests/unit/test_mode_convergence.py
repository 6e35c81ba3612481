"""The default mode basis (mode_shapes = "auto") and the mode-convergence estimate
(control/convergence.py); their physics is checked in tests/validation/test_default_basis.py."""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

from flexlink.control.convergence import ModeConvergence, _order, levels, mode_convergence
from flexlink.dynamics.first_order import chain_modal_data, outboard_body
from flexlink.dynamics.forward import ForwardSystem
from flexlink.model import Base, Chain, Link, TorqueDrive
from flexlink.model.basis import chosen_mode_shapes
from flexlink.model.histories import ZERO
from flexlink.scenario import resolve_scenario_dict, scenario_from_dict
from tests.helpers import SmoothStep

HOLD = SmoothStep(0.0, 0.0, 0.0, 1.0)
LINK = '[[links]]\nname = "{}"\nlength = 1.0\nmass_per_length = 0.5\nEI = 20.0\n{}'
JOINT = '[[joints]]\nmotion = [{{ profile = "hold", angle_deg = 0.0 }}]\n{}'


def _text(*links: tuple[str, str], joints: tuple[str, ...] = ()) -> str:
    head = "[simulation]\nt_end = 0.5\ndt_out = 0.01\n"
    joints = joints or ("",) * len(links)
    return head + "".join(LINK.format(n, extra) for n, extra in links) + \
        "".join(JOINT.format(j) for j in joints)


def test_auto_basis_rule_and_the_resolved_scenario_states_it() -> None:
    text = _text(("a", ""), ("b", "tip_inertia = 0.01\n"), ("c", ""), ("d", "tip_mass = 0.2\n"),
                 joints=("", "", 'base_point = [0.0, 0.0]\n', ""))
    scenario = scenario_from_dict(tomllib.loads(text))
    # a carries b; b has a tip body and c starts a branch on the base; c carries d
    assert [k.mode_shapes for k in scenario.chain.links] == [
        "outboard_loaded", "tip_loaded", "outboard_loaded", "tip_loaded"]
    resolved = resolve_scenario_dict(tomllib.loads(text))
    assert [k["mode_shapes"] for k in resolved["links"]] == [
        "outboard_loaded", "tip_loaded", "outboard_loaded", "tip_loaded"]
    bare = scenario_from_dict(tomllib.loads(_text(("a", ""))))
    assert bare.chain.links[0].mode_shapes == "clamped_free"
    given = scenario_from_dict(tomllib.loads(_text(("a", 'mode_shapes = "clamped_free"\n'),
                                                   ("b", ""))))
    assert given.chain.links[0].mode_shapes == "clamped_free"


def test_a_link_on_a_free_hub_gets_hub_loaded_modes() -> None:
    torque = '[[joints]]\ndrive = "torque"\ntorque = [{ profile = "step", amplitude = 0.0 }]\n'
    text = _text(("a", "")).replace(JOINT.format(""), torque)
    assert scenario_from_dict(tomllib.loads(text)).chain.links[0].mode_shapes == "hub_loaded"
    pinned = '[base]\ntype = "pinned"\ninertia = 0.3\n' + _text(("a", ""), ("b", ""))
    kinds = [k.mode_shapes for k in scenario_from_dict(tomllib.loads(pinned)).chain.links]
    assert kinds == ["hub_loaded", "clamped_free"]
    # two branches on the pinned base: neither link is alone on its hub
    two = '[base]\ntype = "pinned"\ninertia = 0.3\n' + _text(
        ("a", ""), ("b", ""), joints=("", 'base_point = [0.0, 0.0]\n'))
    kinds = [k.mode_shapes for k in scenario_from_dict(tomllib.loads(two)).chain.links]
    assert kinds == ["clamped_free", "clamped_free"]


def test_python_auto_resolves_like_the_scenario_file() -> None:
    links = (Link("a", 1.0, 0.5, 20.0, mode_shapes="auto"),
             Link("b", 1.0, 0.5, 20.0, tip_mass=0.3, mode_shapes="auto"))
    chain = Chain(links, (HOLD, HOLD))
    assert chosen_mode_shapes(chain) == ("outboard_loaded", "tip_loaded")
    explicit = Chain(tuple(dataclasses.replace(k, mode_shapes=s)
                           for k, s in zip(links, ("outboard_loaded", "tip_loaded"))),
                     (HOLD, HOLD))
    for got, want in zip(chain_modal_data(chain), chain_modal_data(explicit)):
        np.testing.assert_array_equal(got.stiffness_matrix, want.stiffness_matrix)


def test_outboard_body_stops_at_a_branch_on_the_base() -> None:
    """Link 0's tip carries nothing when link 1 starts on the base (it took link 1's mass)."""
    links = (Link("a", 1.0, 0.5, 20.0, tip_mass=0.1), Link("b", 2.0, 0.5, 20.0))
    chain = Chain(links, (HOLD, HOLD))
    assert outboard_body(chain, 0) == pytest.approx((1.1, 2.0**3 * 0.5 / 3))
    branched = Base("fixed", attachments=((1, (0.0, 0.5)),))
    assert outboard_body(chain, 0, branched) == (0.1, 0.0)


def test_outboard_body_beyond_a_free_joint_adds_mass_and_motor_inertia_only() -> None:
    links = (Link("a", 1.0, 0.5, 20.0), Link("b", 2.0, 0.5, 20.0, tip_mass=0.3))
    chain = Chain(links, (HOLD, TorqueDrive(ZERO, motor_inertia=0.02)))
    assert outboard_body(chain, 0) == pytest.approx((1.3, 0.02))


def test_forward_system_builds_outboard_loaded_bases() -> None:
    """A driven outer joint with an outboard-loaded inner link (modal_data(link) refused it)."""
    links = (Link("a", 1.0, 0.5, 20.0, tip_mass=0.1, mode_shapes="auto"),
             Link("b", 1.0, 0.5, 20.0))
    chain = Chain(links, (HOLD, TorqueDrive(ZERO, motor_inertia=0.01)))
    system = ForwardSystem(chain, Base())
    assert system.modal[0].shapes.kind == "tip_loaded"  # outboard: tip-loaded shapes
    np.testing.assert_array_equal(system.modal[0].stiffness_matrix,
                                  chain_modal_data(chain, Base())[0].stiffness_matrix)


@pytest.mark.parametrize("p", [1.0, 2.0, 3.0, 6.0])
def test_richardson_recovers_an_algebraic_error(p: float) -> None:
    m = levels(4)
    f = 10.0 + 3.0 * np.array(m, dtype=float) ** -p  # converged value 10
    estimate = ModeConvergence(("clamped_free",), ("a",), (4,), f[:1], f[1:, None])
    assert _order((f[1] - f[2]) / (f[0] - f[1]), m) == pytest.approx(p, rel=1e-9)
    assert estimate.error[0] == pytest.approx((f[0] - 10.0) / 10.0, rel=1e-9)


def test_a_converged_frequency_has_no_error_and_no_warning() -> None:
    f = np.array([[1.0, 5.0]]).T
    estimate = ModeConvergence(("tip_loaded",), ("a",), (4,), f[:, 0],
                               np.array([[1.0, 5.0], [1.0, 5.0]]))
    assert np.all(estimate.error == 0) and estimate.warning() is None
    assert estimate.converged_below_hz == 5.0


def test_warning_names_basis_frequency_and_error() -> None:
    links = (Link("a", 1.0, 0.5, 20.0, tip_inertia=0.2, modes=4),)  # clamped_free: ~N⁻¹
    from flexlink.model import Scenario

    estimate = mode_convergence(Scenario(Chain(links, (HOLD,))))
    text = estimate.warning()
    assert text is not None and "a clamped_free ×4" in text and "4, 8, 12" in text
    worst = int(np.argmax(estimate.error))
    assert f"{100 * estimate.error[worst]:.3g}%" in text
    assert estimate.metadata()["mode_convergence_warning"] == text


@pytest.mark.parametrize("tip_mass, tip_inertia, hub, radius",
                         [(0.0, 0.0, 0.0, 0.0), (2.0, 0.1, 0.05, 0.0), (0.5, 0.0, 1.0, 0.3)])
def test_hub_loaded_modes(tip_mass: float, tip_inertia: float, hub: float, radius: float) -> None:
    """Clamped in the link frame, the hub–beam's roots (the independent determinant of
    tests/validation/hub_beam.py), normalised like the other kinds, finite for 20 modes."""
    from flexlink.modes import hub_loaded_modes
    from tests.validation.hub_beam import hub_beam_frequencies

    L, m, EI = 1.3, 2.7, 45.0
    shapes = hub_loaded_modes(L, 20, m, EI, tip_mass, tip_inertia, hub, radius)
    x = np.linspace(0.0, L, 2001)
    phi = shapes.evaluate(x)
    assert np.isfinite(phi).all() and np.all(shapes.evaluate(np.array([L]))[0] > 0)
    scale = np.abs(phi).max(axis=0)
    assert np.abs(shapes.evaluate(np.array([0.0]))[0]).max() < 1e-11 * scale.max()
    assert np.abs(shapes.evaluate(np.array([0.0]), 1)[0] * L).max() < \
        1e-12 * scale.max() * shapes.beta_l.max()
    exact = hub_beam_frequencies(6, EI, m, L, radius, hub, tip_mass, tip_inertia)
    np.testing.assert_allclose(shapes.beta_l[:6] ** 2 * np.sqrt(EI / (m * L**4)), exact,
                               rtol=1e-8)
    # ∫φ²/L + μφ(L)² + jL²φ'(L)² = 1 (trapezoid on a fine grid)
    tip, slope = shapes.evaluate(np.array([L]))[0], shapes.evaluate(np.array([L]), 1)[0]
    norm = (np.trapezoid(phi[:, :4] ** 2, x, axis=0) / L + tip_mass / (m * L) * tip[:4] ** 2
            + tip_inertia / (m * L**3) * L**2 * slope[:4] ** 2)
    np.testing.assert_allclose(norm, 1.0, rtol=1e-5)
    # derivatives agree with finite differences of the values
    for k in (1, 2, 3):
        d = np.gradient(shapes.evaluate(x, k - 1)[:, :3], x, axis=0)
        np.testing.assert_allclose(d[5:-5], shapes.evaluate(x, k)[5:-5, :3],
                                   atol=1e-3 * np.abs(d).max())


def test_hub_loaded_on_a_clamped_link_is_its_infinite_hub_limit() -> None:
    """On a prescribed joint (an infinitely heavy hub) hub_loaded modes are the clamped
    link's loaded ones."""
    links = (Link("a", 1.0, 0.5, 20.0, tip_mass=0.2, mode_shapes="hub_loaded"),
             Link("b", 1.0, 0.5, 20.0, tip_mass=0.3, mode_shapes="hub_loaded"))
    same = (dataclasses.replace(links[0], mode_shapes="outboard_loaded"),
            dataclasses.replace(links[1], mode_shapes="tip_loaded"))
    for got, want in zip(chain_modal_data(Chain(links, (HOLD, HOLD))),
                         chain_modal_data(Chain(same, (HOLD, HOLD)))):
        np.testing.assert_array_equal(got.stiffness_matrix, want.stiffness_matrix)


@pytest.mark.parametrize("at", [{"joint1": 30.0, "joint2": 20.0}, [30.0, 20.0, 80.0]])
def test_a_closed_loop_s_estimate_names_the_angles_the_loop_closed_at(at: object) -> None:
    """`flexlink linearize --at joint1=30,joint2=20` on a four-bar: joint2 is a dependent
    joint, its 20° only a guess; the line named the guess, not the configuration of the
    plant."""
    from pathlib import Path

    from flexlink.control.linearization import linearize

    path = Path(__file__).resolve().parents[2] / "examples" / "four_bar.toml"
    scenario = scenario_from_dict(resolve_scenario_dict(path))
    op = linearize(scenario, at=at, outputs=[]).operating_point  # type: ignore[arg-type]
    assert op["dependent_joints"] == "joint2 joint3"
    closed = [f"{np.degrees(op[f'joint{k}_angle']):.4g}°" for k in (2, 3)]
    assert closed[0] != "20°"
    where = mode_convergence(scenario, at).where  # type: ignore[arg-type]
    assert where == f"rest at joint1 = 30°; the loop closed at joint2 = {closed[0]}, " \
                    f"joint3 = {closed[1]}"
    only_guesses = {"joint2": 20.0}
    op = linearize(scenario, at=only_guesses, outputs=[]).operating_point
    closed = [f"{np.degrees(op[f'joint{k}_angle']):.4g}°" for k in (2, 3)]
    assert mode_convergence(scenario, only_guesses).where == \
        f"rest, the loop closed at joint2 = {closed[0]}, joint3 = {closed[1]}"


def _example(name: str):
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "examples" / name
    return resolve_scenario_dict(path)


def test_modes_are_paired_by_shape_not_by_rank() -> None:
    """The four-bar linkage with 4 crank modes: the coupler's and follower's new modes fall
    below the crank's top one (8930 Hz), which rank pairing compared with another mode
    ("572% above its converged value"). Paired by shape, every kept frequency moves by
    < 0.1% with 8 and 12 modes per link: no warning; the modes the kept basis lacks (the
    coupler's and follower's 5th, from 1190 Hz) end the band vouched for."""
    d = _example("four_bar_benchmark.toml")
    d["links"][0]["modes"] = 4
    estimate = mode_convergence(scenario_from_dict(d))
    assert estimate.frequency_hz[-1] == pytest.approx(8930.25, rel=1e-4)
    assert estimate.error.max() < 1e-3 and estimate.warning() is None
    assert estimate.missing_below_hz == pytest.approx(1189.6, rel=1e-3)
    assert estimate.converged_below_hz == pytest.approx(813.98, rel=1e-4)
    np.testing.assert_allclose(estimate.refined_hz[1], estimate.frequency_hz, rtol=1e-3)


def test_an_unconverged_top_mode_warns_with_its_own_error() -> None:
    """The paper's arm (4 clamped-free modes per link): its 8th frequency, 224.4 Hz, is
    1.57% above the same mode with 20 modes per link (220.9 Hz); the estimate says so within
    a factor 1.2 (rank pairing: 58%, against link1's 5th mode at 141.6 Hz)."""
    from flexlink.control.linearization import linearize
    from flexlink.scenario.builtin import paper_experiment_path

    d = resolve_scenario_dict(paper_experiment_path())
    estimate = mode_convergence(scenario_from_dict(d))
    for link in d["links"]:
        link["modes"] = 20
    fine = linearize(scenario_from_dict(d), outputs=[]).modes()[0]
    top = estimate.frequency_hz[-1]
    converged = fine[np.argmin(np.abs(fine - top))]
    assert converged == pytest.approx(220.91, rel=1e-3)
    true = top / converged - 1
    assert 1 / 1.2 < estimate.error[-1] / true < 1.2
    text = estimate.warning()
    assert text is not None and f"{top:.4g} Hz, is an estimated {100 * estimate.error[-1]:.3g}%" \
        in text
    assert estimate.missing_below_hz == pytest.approx(141.6, rel=1e-3)


def test_a_mode_that_rises_with_more_modes_is_named_not_estimated() -> None:
    """A link on an elastic joint without hub inertia: its top frequency (163 Hz with 4
    modes) rises with more modes (610, 1343 Hz); the structure's 5th mode (91.8 Hz) is what
    the basis lacks. Rank pairing called it 78% above its converged value."""
    from tests.validation.forward_fe_cases import CASES, flexlink_scenario

    estimate = mode_convergence(flexlink_scenario(CASES["elastic_joint"], modes=4))
    assert estimate.rising.tolist() == [False] * 4 + [True]
    assert estimate.error[-1] == 0.0 and estimate.highest_error < 0.01
    assert estimate.highest_hz == pytest.approx(54.64, rel=1e-3)
    assert estimate.missing_below_hz == pytest.approx(91.82, rel=1e-3)
    text = estimate.warning()
    assert text is not None and "163.2 Hz, has no converged counterpart" in text \
        and "above a mode at 91.82 Hz that this basis lacks" in text and "78" not in text
    meta = estimate.metadata()
    assert "163.2 Hz (610.4, 1343 Hz with 8, 12 modes per link)" in meta["mode_convergence_rising"]
    from flexlink.control.convergence import modes_line

    assert "rising with more modes" in modes_line(meta)


def test_a_link_with_initial_modal_rates_gets_an_estimate() -> None:
    """The slider-crank benchmark starts its rod with modal rates (one per mode): the finer
    bases had 4 rates for 8 and 12 modes, so the estimate failed and a run had none."""
    scenario = scenario_from_dict(_example("slider_crank_benchmark.toml"))
    assert len(scenario.chain.links[1].initial_modal_rates) == 4
    estimate = mode_convergence(scenario)
    assert estimate.modes == (0, 4) and estimate.warning() is None
    assert estimate.frequency_hz.size == 4 and estimate.error.max() < 1e-3


def test_a_free_base_s_modes_pair_by_the_links_deflections() -> None:
    """The satellite's two arrays on a free base: the eigenvectors of its modes that bend the
    arrays alike carry an ill-determined base translation (unit size against deflections of
    1e-8); pairing on the joint and base coordinates too paired 4.16 Hz with 11.07 Hz (277%)."""
    estimate = mode_convergence(scenario_from_dict(_example("satellite_slew.toml")))
    np.testing.assert_allclose(estimate.refined_hz[1], estimate.frequency_hz, rtol=1e-3)
    assert estimate.warning() is None


def test_a_rising_mode_the_output_cannot_show_does_not_warn() -> None:
    """examples/flexible_joint_arm.toml: its top mode (972 Hz with 4 modes; 3631, 3737 Hz
    with 8, 12) rises with more modes, above the 250 Hz the 2 ms output grid shows: named in
    the summary, no warning (rank pairing: "61.1% above its converged value")."""
    estimate = mode_convergence(scenario_from_dict(_example("flexible_joint_arm.toml")))
    assert estimate.nyquist_hz == pytest.approx(250.0)
    assert estimate.rising[-1] and estimate.frequency_hz[-1] > estimate.nyquist_hz
    assert estimate.warning() is None
    assert "972 Hz (3631, 3737 Hz" in estimate.metadata()["mode_convergence_rising"]


def test_a_failure_of_the_estimate_is_reported_not_hidden(monkeypatch: pytest.MonkeyPatch,
                                                           capsys: pytest.CaptureFixture[str]
                                                           ) -> None:
    """No linearisation about the operating point (a saturated servo) leaves no estimate
    quietly; any other failure of the estimate is a warning naming it, beside a run's
    results (`flexlink run`) and a plant's (`flexlink linearize`, `flexlink modes`)."""
    from pathlib import Path

    from flexlink.cli import _mode_convergence
    from flexlink.control import command, convergence
    from flexlink.control.operating_point import NotLinearizable
    from flexlink.scenario import load_scenario

    scenario = load_scenario(Path(__file__).resolve().parents[2] / "examples" / "four_bar.toml")

    def failing(error: Exception):  # type: ignore[no-untyped-def]
        def estimate(*_: object) -> None:
            raise error
        return estimate

    monkeypatch.setattr(convergence, "mode_convergence", failing(NotLinearizable("saturated")))
    assert convergence.estimate_for_command(scenario) == (None, None)
    assert _mode_convergence(scenario) == {}
    monkeypatch.setattr(convergence, "mode_convergence", failing(IndexError("out of range")))
    estimate, failure = convergence.estimate_for_command(scenario)
    assert estimate is None
    assert failure is not None and failure.startswith(
        "the mode-convergence estimate failed (IndexError: out of range)")
    assert _mode_convergence(scenario) == {"mode_convergence_warning": failure}
    command._print_estimate(estimate, failure)
    assert capsys.readouterr().err == f"warning: {failure}\n"


def test_a_closed_loop_of_rigid_links_has_no_estimate_and_no_failure() -> None:
    """Nothing to estimate: the estimate failed on it (an empty reduction) and was hidden."""
    from pathlib import Path

    from flexlink.control.convergence import estimate_for_command

    d = resolve_scenario_dict(Path(__file__).resolve().parents[2] / "examples"
                              / "slider_crank.toml")
    for link in d["links"]:
        for key in ("EI", "E", "width", "thickness", "damping_ratio", "modes", "mode_shapes"):
            link.pop(key, None)
        link["rigid"] = True
    assert estimate_for_command(scenario_from_dict(d)) == (None, None)
