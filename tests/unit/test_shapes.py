"""The links' deformed shapes: every model path stores them, their tip is the tip channels,
they survive the run folder, and the rigid frame they carry is the undeformed link."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import flexlink
from flexlink.channels.shapes import POINTS
from flexlink.results import read_run
from flexlink.results.writers import RESULTS_CSV, write_run
from flexlink.scenario import paper_experiment_path, resolve_scenario_dict, scenario_from_dict

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def _paper(**simulation: object) -> dict:
    raw = tomllib.loads(paper_experiment_path().read_text())
    raw["simulation"].update(simulation)
    return raw


def _slew() -> dict:
    raw = tomllib.loads((EXAMPLES / "satellite_slew.toml").read_text())
    raw["simulation"].update(t_end=3.0)
    return raw


CASES = {
    "prescribed": lambda: _paper(t_end=2.0),
    "nonlinear": lambda: _paper(t_end=1.2, model="nonlinear"),
    "free base": _slew,
}


@pytest.mark.parametrize("case", list(CASES))
def test_the_last_shape_point_is_the_tip_channel(case: str) -> None:
    raw = CASES[case]()
    results = flexlink.simulate(scenario_from_dict(raw, base_dir=EXAMPLES))
    assert [s.link for s in results.shapes] == [link["name"] for link in raw["links"]]
    for shape in results.shapes:
        assert shape.X.shape == (results.time.size, POINTS)
        scale = shape.length
        np.testing.assert_allclose(shape.X[:, -1], results[f"{shape.link}_tip_X"],
                                   rtol=0, atol=1e-12 * scale)
        np.testing.assert_allclose(shape.Y[:, -1], results[f"{shape.link}_tip_Y"],
                                   rtol=0, atol=1e-12 * scale)
        # at rest at t = 0 the shape is the rigid link
        rx, ry = shape.rigid()
        np.testing.assert_allclose(shape.X[0], rx[0], atol=1e-12)
        np.testing.assert_allclose(shape.Y[0], ry[0], atol=1e-12)
        # points are a link length apart along the deformed arc, to first order
        arc = np.hypot(np.diff(shape.X, axis=1), np.diff(shape.Y, axis=1)).sum(axis=1)
        assert np.all(np.abs(arc - shape.length) < 0.05 * shape.length)


def test_a_free_base_moves_the_shapes_with_it() -> None:
    results = flexlink.simulate(scenario_from_dict(_slew(), base_dir=EXAMPLES))
    right = results.shapes[0]
    # the right appendage hangs on the hub at 0.5 m from its centre, turned with the hub
    att = results["base_attitude"]
    root = np.column_stack([results["base_x"] + 0.5 * np.cos(att),
                            results["base_y"] + 0.5 * np.sin(att)])
    np.testing.assert_allclose(right.origin, root, atol=1e-12)


def test_magnification_scales_the_deflection_only() -> None:
    results = flexlink.simulate(scenario_from_dict(_paper(t_end=1.5)))
    shape = results.shapes[1]
    rx, ry = shape.rigid()
    mx, my = shape.magnified(10.0)
    np.testing.assert_allclose(mx - rx, 10.0 * (shape.X - rx), atol=1e-12)
    np.testing.assert_allclose(my - ry, 10.0 * (shape.Y - ry), atol=1e-12)
    assert shape.magnified(1.0)[0] is shape.X


def test_shapes_survive_the_run_folder_and_stay_out_of_the_csv(tmp_path: Path) -> None:
    raw = _paper(t_end=1.0)
    results = flexlink.simulate(scenario_from_dict(raw))
    write_run(results, tmp_path / "run", resolve_scenario_dict(raw), figures=False)
    header = (tmp_path / "run" / RESULTS_CSV).read_text().splitlines()[0].split(",")
    assert header == ["t", *results.names]
    back = read_run(tmp_path / "run")
    assert back.names == results.names
    for a, b in zip(results.shapes, back.shapes, strict=True):
        assert (a.link, a.length) == (b.link, b.length)
        np.testing.assert_allclose(b.fraction, a.fraction)
        # stored as 32-bit floats: 0.1 µm at a metre
        np.testing.assert_allclose(b.X, a.X, rtol=0, atol=2e-7)
        np.testing.assert_allclose(b.Y, a.Y, rtol=0, atol=2e-7)
        np.testing.assert_array_equal(b.angle, a.angle)
        np.testing.assert_array_equal(b.origin, a.origin)
    dataset = back.to_xarray()
    assert dataset["link1_shape_X"].dims == ("time", "point")
    assert dataset["link1_shape_X"].attrs["kind"] == "shape"
