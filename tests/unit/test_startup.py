"""What the start-up work changed must not change outputs: the report's decimation, the
figures drawn in a forked process, the mode eigenvalues found without scipy.optimize."""

from __future__ import annotations

import itertools
import os
import signal
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

from flexlink.modes.shapes import _frequency_function, clamped_free_modes, tip_loaded_modes
from flexlink.results import writers
from flexlink.results.figure_worker import FigureWorker
from flexlink.results.report_html import decimate
from flexlink.scenario import resolve_scenario_dict

from .test_writers import fake_results, scenario_dict


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


needs_fork = pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork")


@needs_fork
def test_figures_drawn_by_the_worker_equal_those_drawn_here(tmp_path: Path) -> None:
    worker = FigureWorker.start()
    if worker is None:
        pytest.skip("threads running: the worker is not forked")
    results = fake_results()
    worker.submit(results, tmp_path / "worker")
    assert worker.wait()
    here = writers.write_figures(results, tmp_path / "here")
    assert here
    for path in here:
        assert (tmp_path / "worker" / path.name).read_bytes() == path.read_bytes()


@needs_fork
def test_write_run_draws_the_figures_itself_when_the_worker_dies(
        tmp_path: Path) -> None:
    resolved = resolve_scenario_dict(scenario_dict())
    worker = FigureWorker.start()
    if worker is None:
        pytest.skip("threads running: the worker is not forked")
    os.kill(worker._pid, signal.SIGKILL)
    out = writers.write_run(fake_results(), tmp_path / "run", resolved, figure_worker=worker)
    assert sorted(p.name for p in (out / "figures").iterdir()) == [
        "joint_angles.png", "sensors.png", "tip_paths.png"]
    assert (out / "report.html").is_file()
