"""The animation draws a run's bodies at their centre of mass, its closing pins and sliders
and its ground pivots where the run puts them (results/mechanism_parts.py)."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import flexlink
from flexlink.results import read_run
from flexlink.results.animation import _Scene
from flexlink.results.arm_tracks import run_track
from flexlink.results.mechanism_parts import KEY
from flexlink.results.writers import write_run
from flexlink.scenario import resolve_scenario_dict, scenario_from_dict

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
OFFSET = (0.1, 0.05)


def _body_run() -> flexlink.Results:
    raw = {"simulation": {"name": "body", "t_end": 1.0, "dt_out": 0.01},
           "links": [{"name": "arm", "length": 0.5, "mass_per_length": 1.0, "rigid": True,
                      "bodies": [{"mass": 0.2, "offset": list(OFFSET), "inertia": 1e-4}]}],
           "joints": [{"motion": [{"profile": "cycloidal", "from_deg": 0.0, "to_deg": 120.0,
                                   "start": 0.0, "duration": 1.0}]}]}
    return flexlink.simulate(scenario_from_dict(raw)), raw


def test_a_body_is_drawn_at_its_centre_of_mass_and_the_run_folder_keeps_it(
        tmp_path: Path) -> None:
    results, raw = _body_run()
    assert results.channels["joint1_angle"].unit == "rad"
    angle = results["joint1_angle"]
    tip = np.column_stack([results["arm_tip_X"], results["arm_tip_Y"]])
    c, s = np.cos(angle), np.sin(angle)
    centre = tip + np.column_stack([c * OFFSET[0] - s * OFFSET[1],
                                    s * OFFSET[0] + c * OFFSET[1]])
    anchor, drawn = run_track(results).parts.bodies[0]
    assert np.abs(anchor - tip).max() < 1e-12
    assert np.abs(drawn - centre).max() < 1e-9
    folder = write_run(results, tmp_path / "run", resolve_scenario_dict(raw), figures=False)
    again = read_run(folder)
    assert again.metadata[KEY] == results.metadata[KEY]
    assert np.abs(run_track(again).parts.bodies[0][1] - centre).max() < 1e-6  # float32 shapes

    # the disc's pixels are centred on the body's centre in the frame
    track = run_track(results)
    scene = _Scene(np.asarray(results.time), [track], [], 1.0, 1.0, "body", True)
    for index in (0, 50, 100):
        frame = scene.frame(index, float(results.time[index]), 10)
        rows, cols = np.nonzero(np.abs(frame.astype(int) - [0x4a, 0x6f, 0xa5]).sum(-1) < 12)
        assert rows.size > 20
        col = scene.origin_px[0] + centre[index, 0] / scene.metres_per_pixel
        row = scene.origin_px[1] - centre[index, 1] / scene.metres_per_pixel
        assert abs(cols.mean() + 0.5 - col) < 1.0 and abs(rows.mean() + 0.5 - row) < 1.0


@pytest.mark.parametrize("example", ["slider_crank", "four_bar"])
def test_closing_pins_sliders_and_ground_pivots_sit_where_the_loop_closes(example: str) -> None:
    raw = tomllib.loads((EXAMPLES / f"{example}.toml").read_text())
    raw["simulation"]["t_end"] = 0.05
    results = flexlink.simulate(scenario_from_dict(raw))
    parts = run_track(results).parts
    if example == "slider_crank":
        (point, angle, ends), = parts.sliders
        tip = np.column_stack([results["rod_tip_X"], results["rod_tip_Y"]])
        assert angle == 0.0 and np.abs(point - tip).max() < 1e-12
        # on the line y = 0 but for the bent rod's shortening, which the tip channels leave
        # out (docs/scenario.md, closures): far below a pixel
        assert np.abs(point[:, 1]).max() < 1e-4
        assert ends[0, 0] < point[:, 0].min() and ends[1, 0] > point[:, 0].max()
        assert not parts.pins and parts.pivots is None
    else:
        pin, = parts.pins
        coupler = np.column_stack([results["coupler_tip_X"], results["coupler_tip_Y"]])
        rocker = np.column_stack([results["rocker_tip_X"], results["rocker_tip_Y"]])
        assert np.abs(pin - coupler).max() < 1e-12 and np.abs(pin - rocker).max() < 1e-4
        assert np.allclose(parts.pivots, [[0.3, 0.0]])
        assert not parts.sliders


def test_a_run_without_parts_carries_no_parts_metadata() -> None:
    raw = {"simulation": {"name": "plain", "t_end": 0.1, "dt_out": 0.01},
           "links": [{"name": "arm", "length": 0.5, "mass_per_length": 1.0, "rigid": True}],
           "joints": [{"motion": [{"profile": "hold", "angle_deg": 0.0}]}]}
    results = flexlink.simulate(scenario_from_dict(raw))
    assert KEY not in results.metadata
    assert run_track(results).parts.bodies == ()


@pytest.mark.parametrize("model", ["first_order", "nonlinear"])
def test_a_slider_inside_the_chain_is_a_block_on_a_line_turning_with_its_parent(
        model: str) -> None:
    """examples/telescoping_arm.toml: the block sits at the arm's root, on the line through
    the boom's tip along its tip section (axis 0), at the travel the run reports; the line
    reaches past both ends of the travel, and every frame draws the block's pixels there."""
    raw = tomllib.loads((EXAMPLES / "telescoping_arm.toml").read_text())
    raw["simulation"].update(t_end=2.0, dt_out=0.02, model=model)
    results = flexlink.simulate(scenario_from_dict(raw))
    (point, angle, ends), = run_track(results).parts.sliders
    root = np.column_stack([results["arm_tip_X"], results["arm_tip_Y"]])  # for the length
    tip = np.column_stack([results["boom_tip_X"], results["boom_tip_Y"]])
    direction = np.column_stack([np.cos(angle), np.sin(angle)])
    travel = np.sum((point - tip) * direction, axis=1)
    # read off the drawn polylines (tangents by differences): within 0.5 mm, a quarter pixel
    np.testing.assert_allclose(travel, results["joint2_position"], atol=5e-4)
    across = (point - tip) @ np.array([[0.0, 1.0], [-1.0, 0.0]])
    assert np.abs(np.sum(across * direction, axis=1)).max() < 5e-4  # on the line
    assert np.abs(angle - results["joint1_angle"]).max() < 0.05  # the boom's tip section
    along = np.einsum("tei,ti->te", ends - tip[:, None], direction)
    assert np.all(along[:, 0] < 0.0) and np.all(along[:, 1] > travel)
    assert np.abs(root - point).max() > 0.5  # the arm's tip is not its root
    track = run_track(results)
    scene = _Scene(np.asarray(results.time), [track], [], 1.0, 1.0, "slider", True)
    for index in (0, 50, 100):
        frame = scene.frame(index, float(results.time[index]), 10)
        rows, cols = np.nonzero(np.abs(frame.astype(int) - [0xc8, 0xd0, 0xe0]).sum(-1) < 12)
        assert rows.size > 10
        col = scene.origin_px[0] + point[index, 0] / scene.metres_per_pixel
        row = scene.origin_px[1] - point[index, 1] / scene.metres_per_pixel
        assert abs(cols.mean() + 0.5 - col) < 2.0 and abs(rows.mean() + 0.5 - row) < 2.0


def test_a_slider_line_inside_its_parent_is_drawn_through_that_section() -> None:
    """examples/telescoping_arm.toml with the line through the boom's section at 0.6 m
    (`line_at`): the block sits at the travel the run reports from that section, not from
    the tip (the boom nearly rigid: within its tip's deflection plus 0.5 mm)."""
    raw = tomllib.loads((EXAMPLES / "telescoping_arm.toml").read_text())
    raw["simulation"].update(t_end=2.0, dt_out=0.02)
    raw["joints"][1]["line_at"] = 0.6
    results = flexlink.simulate(scenario_from_dict(raw))
    (point, angle, _), = run_track(results).parts.sliders
    beta = np.asarray(results["joint1_angle"])
    axis = np.column_stack([np.cos(beta), np.sin(beta)])
    bend = np.abs(np.column_stack([results["boom_tip_X"], results["boom_tip_Y"]])
                  - axis).max()
    direction = np.column_stack([np.cos(angle), np.sin(angle)])
    travel = np.sum((point - 0.6 * axis) * direction, axis=1)
    np.testing.assert_allclose(travel, results["joint2_position"], atol=bend + 5e-4)
    assert np.abs(travel - results["joint2_position"] - 0.4).min() > 0.3  # not the tip's
