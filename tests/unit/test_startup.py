"""What the start-up work changed must not change outputs: the report's decimation, the
figures drawn in forked processes, their PNG files and pinned titles, the mode eigenvalues
found without scipy.optimize."""

from __future__ import annotations

import itertools
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from flexlink.modes.shapes import _frequency_function, clamped_free_modes, tip_loaded_modes
from flexlink.results.report_html import decimate


def _decimate_loop(t: np.ndarray, ys: list[np.ndarray], points: int
                   ) -> tuple[np.ndarray, list[np.ndarray]]:
    """The earlier implementation, bucket by bucket."""
    n = t.size
    if n <= points:
        return t, list(ys)
    buckets = np.linspace(0, n, points // 2 + 1).astype(int)
    keep = {0, n - 1}
    for y in ys:
        for a, b in itertools.pairwise(buckets):
            if b > a:
                seg = y[a:b]
                keep.update((a + int(np.nanargmin(seg)), a + int(np.nanargmax(seg))))
    index = np.array(sorted(keep))
    return t[index], [y[index] for y in ys]


@pytest.mark.parametrize("n", [2999, 3001, 5001, 10007])
@pytest.mark.parametrize("points", [3000, 101, 6])
def test_vectorised_decimation_keeps_the_same_samples(n: int, points: int) -> None:
    rng = np.random.default_rng(n + points)
    t = np.linspace(0.0, 5.0, n)
    ys = [rng.standard_normal(n), np.round(rng.standard_normal(n), 1), np.zeros(n)]
    ys[0][3] = np.nan
    expected_t, expected = _decimate_loop(t, ys, points)
    got_t, got = decimate(t, ys, points)
    np.testing.assert_array_equal(got_t, expected_t)
    for a, b in zip(got, expected, strict=True):
        np.testing.assert_array_equal(a, b)


def test_eigenvalues_by_bisection_match_brent() -> None:
    eps = np.finfo(float).eps
    lam = clamped_free_modes(1.0, 10).beta_l
    ref = [brentq(_frequency_function, (i - 1) * np.pi, i * np.pi, args=(0.0, 0.0),
                  xtol=1e-15, rtol=4 * eps) for i in range(1, 11)]
    np.testing.assert_allclose(lam, ref, rtol=4 * eps, atol=0)
    loaded = tip_loaded_modes(1.37, 5, 0.53, 300.0, 0.3, 0.01)
    mu, j = 0.3 / (0.53 * 1.37), 0.01 / (0.53 * 1.37**3)
    for value in loaded.beta_l:
        assert abs(_frequency_function(value, mu, j)) < 1e-12
        ref = brentq(_frequency_function, value - 0.01, value + 0.01, args=(mu, j),
                     xtol=1e-15, rtol=4 * eps)
        assert value == pytest.approx(ref, rel=4 * eps, abs=0)


needs_fork = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="the figure worker forks on Linux only")

# In a fresh interpreter: the suite's own process runs threads by then (the worker is then not
# forked, rightly), and a fork of the test process is best avoided anyway.
_WORKER_CHECK = """
import os, signal, sys
from pathlib import Path
sys.path[:0] = {paths!r}
from flexlink.results import writers
from flexlink.results.figure_worker import FigureWorker
from flexlink.scenario import resolve_scenario_dict
from tests.unit.test_writers import fake_results, scenario_dict

tmp = Path({tmp!r})
worker = FigureWorker.start()
assert worker is not None, "not forked"
results = fake_results()
worker.hint(results.channels.values())  # frames prepared before the job
worker.submit(results, tmp / "worker")
assert worker.wait(), "the worker did not draw"
here = writers.write_figures(results, tmp / "here")
assert [p.name for p in here] == ["joint_angles.png", "sensors.png", "tip_paths.png"]
for path in here:
    assert (tmp / "worker" / path.name).read_bytes() == path.read_bytes(), path.name
# the second drawing process fails: the worker's child draws its figures too
from flexlink.results import figures
draw = figures.write_figures
parent = os.getpid()

def failing_in_the_grandchild(results, folder, stems=None):
    if os.getppid() != parent:
        raise RuntimeError("grandchild fails")
    return draw(results, folder, stems)

figures.write_figures = failing_in_the_grandchild
half = FigureWorker.start()
figures.write_figures = draw
half.submit(results, tmp / "half")
assert half.wait(), "the worker did not draw"
for path in here:
    assert (tmp / "half" / path.name).read_bytes() == path.read_bytes(), path.name
# the worker's child fails while its partner draws: the partner is stopped and write_run
# draws every figure itself
def failing_in_the_child(results, folder, stems=None):
    if os.getppid() == parent and os.getpid() != parent:
        raise RuntimeError("child fails")
    return draw(results, folder, stems)

figures.write_figures = failing_in_the_child
broken = FigureWorker.start()
figures.write_figures = draw
broken.hint(results.channels.values())
out = writers.write_run(results, tmp / "broken", resolve_scenario_dict(scenario_dict()),
                        figure_worker=broken)
for path in here:
    assert (out / "figures" / path.name).read_bytes() == path.read_bytes(), path.name
dead = FigureWorker.start()
os.kill(dead._pid, signal.SIGKILL)
out = writers.write_run(results, tmp / "run", resolve_scenario_dict(scenario_dict()),
                        figure_worker=dead)
assert sorted(p.name for p in (out / "figures").iterdir()) == [
    "joint_angles.png", "sensors.png", "tip_paths.png"]
assert (out / "report.html").is_file()
print("ok")
"""


@needs_fork
def test_figure_worker_draws_what_write_figures_draws_and_falls_back(tmp_path: Path) -> None:
    """Figures drawn by the forked worker (two processes, given the channel records ahead)
    are byte for byte those drawn in-process; when its second process fails its first draws
    them all; when its first fails, or the worker died, write_run draws them itself."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    code = _WORKER_CHECK.format(paths=[str(root), str(root / "src")], tmp=str(tmp_path))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]


@pytest.mark.parametrize("mode_shapes", ["clamped_free", "tip_loaded"])
@pytest.mark.parametrize("EI", [308.7, 55.0, 4.2e3])
def test_modal_data_from_the_cache_equals_a_fresh_computation(mode_shapes: str,
                                                              EI: float) -> None:
    import dataclasses

    from flexlink.model import Link
    from flexlink.modes import modal_data, modal_data_for_stiffness

    other = Link("other", 1.37, 0.5292, 2 * EI, tip_mass=0.129, tip_inertia=2e-4,
                 damping_ratio=0.05, modes=4, mode_shapes=mode_shapes)
    modal_data_for_stiffness(other)  # the cache now holds this link's EI-free part
    link = dataclasses.replace(other, name="arm", EI=EI, damping_ratio=0.02)
    fresh, cached = modal_data(link), modal_data_for_stiffness(link)
    for field in dataclasses.fields(fresh):
        a, b = getattr(fresh, field.name), getattr(cached, field.name)
        if isinstance(a, np.ndarray):
            np.testing.assert_array_equal(b, a, err_msg=field.name)  # bit for bit
            assert not b.flags.writeable
        elif field.name != "shapes":
            assert b == a, field.name
    np.testing.assert_array_equal(cached.shapes.beta_l, fresh.shapes.beta_l)


def test_warmup_scenarios_take_every_path() -> None:
    from flexlink.cli import build_parser, warmup_scenarios
    from flexlink.dynamics.forward import is_driven
    from flexlink.simulation import PATHS, model_path

    scenarios = warmup_scenarios()
    assert {name: model_path(s) for name, s in scenarios.items()} == {
        **{name: name for name in PATHS}, "free_base": "forward",
        "nonlinear_step": "nonlinear", "nonlinear_forward_step": "nonlinear_forward",
        "four_bar": "forward", "nonlinear_four_bar": "nonlinear_forward",
        "sensitivities": "prescribed", "batched": "prescribed"}
    assert scenarios["four_bar"].closures  # the closed-loop kernels (dynamics/_loops_numba.py)
    # … and on the nonlinear model (dynamics/_nonlinear_loops_numba.py)
    assert scenarios["nonlinear_four_bar"].closures
    # the nonlinear paths with adaptive steps and with a fixed step (their two loops)
    assert scenarios["nonlinear"].settings.step is None
    assert scenarios["nonlinear_forward"].settings.step is None
    assert scenarios["nonlinear_step"].settings.step == 1e-3
    assert scenarios["nonlinear_forward_step"].settings.step == 1e-3
    # the forward path with driven joints, and with a base moved by its loads and every
    # joint prescribed (inputs from the base loads only)
    assert all(map(is_driven, scenarios["forward"].chain.joints))
    assert not any(map(is_driven, scenarios["free_base"].chain.joints))
    assert all(s.settings.t_end <= 0.05 for s in scenarios.values())
    assert build_parser().parse_args(["warmup"]).command == "warmup"


def test_warmup_reports_a_failing_path_and_goes_on(monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    """Regression: the first failure ended the command although it said it went on."""
    import flexlink._compiled_cache
    import flexlink.simulation
    import flexlink.simulation.sensitivities
    from flexlink.cli import main, warmup_scenarios

    paths = [flexlink.simulation.model_path(s) for s in warmup_scenarios().values()]
    monkeypatch.setattr(flexlink._compiled_cache, "cache_root", lambda: None)  # none installed
    ran: list[str] = []

    def fake(scenario, progress=False, shapes=True, sensitivities=None):
        ran.append(flexlink.simulation.model_path(scenario))
        if ran[-1] == "prescribed":
            raise RuntimeError("boom")

    monkeypatch.setattr(flexlink.simulation, "simulate", fake)
    monkeypatch.setattr(flexlink.simulation.sensitivities, "simulate_with_sensitivities",
                        lambda scenario, fields, **options: fake(scenario))
    assert main(["warmup"]) == 1
    assert ran == paths
    out = capsys.readouterr()
    assert "prescribed: failed: RuntimeError: boom" in out.err
    assert "nonlinear runs ready" in out.out and "forward runs ready" in out.out


def test_warmup_does_nothing_where_the_installation_compiled_every_loop(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str],
        tmp_path: Path) -> None:
    import flexlink._compiled_cache
    import flexlink.batch.grouped
    import flexlink.simulation
    import flexlink.simulation.objective
    import flexlink.simulation.sensitivities
    from flexlink.cli import WARMUP_RUNS, main

    record = {"complete": True}
    monkeypatch.setattr(flexlink._compiled_cache, "cache_root", lambda: tmp_path)
    monkeypatch.setattr(flexlink._compiled_cache, "read_record", lambda root: record)
    monkeypatch.setattr(flexlink._compiled_cache, "complete",
                        lambda r, runs: r["complete"] and runs == WARMUP_RUNS)

    def ran(scenario, progress=False, shapes=True, sensitivities=None):
        print("ran")

    monkeypatch.setattr(flexlink.simulation, "simulate", ran)
    monkeypatch.setattr(flexlink.simulation.sensitivities, "simulate_with_sensitivities",
                        lambda scenario, fields, **options: ran(scenario))
    # the sensitivities' warm-up run also takes one gradient by the reverse pass
    monkeypatch.setattr(flexlink.simulation.objective, "warm_up", lambda *args: None)
    # … and the batched one runs a sweep's batched loop
    monkeypatch.setattr(flexlink.batch.grouped, "warm_up", lambda *args: None)
    assert main(["warmup"]) == 0
    out = capsys.readouterr().out
    assert "nothing to do" in out and "ran" not in out.split()
    record["complete"] = False  # a run or kernel missing: every warm-up runs
    assert main(["warmup"]) == 0
    assert capsys.readouterr().out.split().count("ran") == len(WARMUP_RUNS)


def test_figures_are_split_in_two_groups_of_about_equal_work() -> None:
    from flexlink.results.figures import figure_stems, split_figures
    from tests.unit.test_writers import fake_results

    results = fake_results()
    mine, theirs = split_figures(results)
    assert sorted(mine + theirs) == sorted(figure_stems(results))
    assert mine == ["sensors"] and sorted(theirs) == ["joint_angles", "tip_paths"]


def _pixels(path_or_buffer: object) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(path_or_buffer).convert("RGBA"))


def test_save_png_stores_the_pixels_savefig_renders(tmp_path: Path) -> None:
    """RGB at zlib level 1 where the figure is opaque, RGBA otherwise: the pixels of
    matplotlib's own savefig either way."""
    import io

    from matplotlib.figure import Figure
    from PIL import Image

    from flexlink.results.figures import save_png

    for transparent in (False, True):
        fig = Figure(figsize=(2.0, 1.5), dpi=150)
        ax = fig.subplots()
        ax.plot([0.0, 1.0, 2.0], [0.0, 1.0, 0.5], label="β₁")
        ax.set_title("title", loc="left")
        ax.legend()
        if transparent:
            fig.patch.set_alpha(0.0)
        reference = io.BytesIO()
        fig.savefig(reference, format="png", dpi=150)
        save_png(fig, tmp_path / "figure.png")
        with Image.open(tmp_path / "figure.png") as image:
            assert image.mode == ("RGBA" if transparent else "RGB")
        np.testing.assert_array_equal(_pixels(tmp_path / "figure.png"), _pixels(reference))


def test_pinned_panel_titles_are_where_matplotlib_would_place_them(tmp_path: Path) -> None:
    """Panel titles skip matplotlib's automatic placement unless the y axis shows an offset
    text: the figure is pixel for pixel the one with automatic placement, with and without
    offset texts ("1e-14", "+1e3" above the axes)."""
    from matplotlib.axes import Axes

    from flexlink.results import plotting
    from flexlink.results.figures import save_png
    from tests.unit.test_writers import fake_results

    results = fake_results()
    tiny = fake_results()
    tiny["tip"][:] = 1e3 + 1e-9 * np.sin(40 * tiny.time)  # offset text "+1e3"
    tiny["root"][:] = 1e-20 * np.cos(40 * tiny.time)  # "1e-14" (µstrain)
    for case, data in (("plain", results), ("offsets", tiny)):
        save_png(plotting.plot_sensors(data), tmp_path / f"{case}-pinned.png")
    set_title = Axes.set_title

    def automatic(self: Axes, label: str, *args: object, y: float | None = None,
                  **kwargs: object) -> object:
        return set_title(self, label, *args, **kwargs)  # y left to matplotlib

    Axes.set_title = automatic
    try:
        for case, data in (("plain", results), ("offsets", tiny)):
            save_png(plotting.plot_sensors(data), tmp_path / f"{case}-auto.png")
    finally:
        Axes.set_title = set_title
    for case in ("plain", "offsets"):
        np.testing.assert_array_equal(_pixels(tmp_path / f"{case}-pinned.png"),
                                      _pixels(tmp_path / f"{case}-auto.png"))


def _two_joint_results(torque_ratio: float) -> object:
    """fake_results with a second joint and both joints' torques (``torque_ratio``: the
    second's size over the first's; above 5 they get a panel each)."""
    from flexlink.channels import Channel, ChannelKind
    from tests.unit.test_writers import fake_results

    results = fake_results()
    t = results.time
    joint = ChannelKind.JOINT
    results.add(Channel("joint2_angle", joint, "rad", "joint 2 angle", "angle", "joint2"),
                0.2 * t)
    results.add(Channel("joint1_torque", joint, "N·m", "joint 1 torque", "torque", "joint1"),
                np.sin(30 * t))
    results.add(Channel("joint2_torque", joint, "N·m", "joint 2 torque", "torque", "joint2"),
                torque_ratio * np.cos(30 * t))
    return results


@pytest.mark.parametrize("torque_ratio", [0.5, 20.0])
def test_prepared_frames_draw_the_same_pixels(tmp_path: Path, torque_ratio: float) -> None:
    """Figures drawn into frames prepared from the channel records alone (before the values
    exist: the figure worker's case) are byte for byte those drawn afresh, and take them."""
    from flexlink.results import plotting
    from flexlink.results.figures import (
        ChannelRecords,
        figure_stems,
        prepare_figures,
        save_png,
        split_figures,
        write_figures,
    )

    results = _two_joint_results(torque_ratio)
    records = ChannelRecords(results.channels.values())
    stems = figure_stems(results)
    assert figure_stems(records) == stems and split_figures(records) == split_figures(results)
    fresh = write_figures(results, tmp_path / "fresh")
    try:
        prepare_figures(records, stems)
        assert sum(map(len, plotting._PREPARED.values())) == len(stems) + 1  # both joint
        prepared = write_figures(results, tmp_path / "prepared")  # figure layouts
        assert sum(map(len, plotting._PREPARED.values())) == 1  # the joint one not taken
        prepare_figures(records, stems, stop=lambda: True)  # the values came: nothing made
        assert sum(map(len, plotting._PREPARED.values())) == 1
    finally:
        plotting._PREPARED.clear()
    for a, b in zip(fresh, prepared, strict=True):
        assert a.read_bytes() == b.read_bytes(), a.name
    save_png(plotting.plot_joint_angles(results), tmp_path / "again.png")  # nothing left over
    assert (tmp_path / "again.png").read_bytes() == (tmp_path / "fresh" / "joint_angles.png"
                                                      ).read_bytes()


def test_trace_text_is_the_json_of_the_traces() -> None:
    """report.html's traces formatted all at once: the text json.dumps gave, for values of
    every size (exponent and positional forms, integral, subnormal, signed zeros, non-finite)
    and names that need escaping."""
    import json

    from flexlink.results.report_html import Trace, _trace_text, decimate

    def numbers(values: np.ndarray) -> list[float | None]:  # one value at a time, as json
        return [float(f"{v:.6g}") if math.isfinite(v) else None for v in values.tolist()]

    def trace_json(trace: Trace) -> dict[str, object]:
        t, ys = decimate(np.asarray(trace.t, float), [np.asarray(v, float)
                                                       for v in trace.series.values()])
        return {"title": trace.title, "unit": trace.unit, "t": numbers(t),
                "series": [{"name": n, "y": numbers(y)}
                           for n, y in zip(trace.series, ys, strict=True)]}

    rng = np.random.default_rng(16)
    edge = np.array([0.0, -0.0, 1.0, 1e5, 999999.0, 999999.5, 1e6, 1234567.0, 9.999995e15,
                     1e16, 1e-4, 9.99999e-5, 1e-5, 5e-324, 2.2e-308, 1e-307,
                     1.7976931348623157e308, np.nan, np.inf, -np.inf, 0.1, 123456.0])
    for n in (0, 5, 2999, 7001):
        t = np.linspace(0.0, 5.0, n)
        series = {"µ 'tip' \"x\"": rng.standard_normal(n) * 10.0 ** rng.uniform(-320, 300, n),
                  "β₁": np.round(rng.standard_normal(n) * 10.0 ** rng.integers(-8, 18, n)),
                  "edges": np.resize(np.concatenate([edge, -edge]), n)}
        trace = Trace("τ₁ <title> & 'quotes'", "N·m", t, series)
        assert _trace_text(trace) == json.dumps(trace_json(trace))
