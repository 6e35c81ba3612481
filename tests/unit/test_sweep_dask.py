"""The sweep on a Dask cluster started here on loopback equals the local sweep.

In a file of its own, run after test_sweep.py: the cluster leaves Dask's event-loop thread
running in the test process, and the tests there that fork workers on purpose can deadlock
when a process with running threads forks."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from flexlink.batch import SweepError, executors, sweep
from tests.unit.test_sweep import RATE, RATES, spin_file


def test_sweep_on_a_dask_cluster_equals_the_local_sweep(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    scenario = spin_file(tmp_path)
    local = sweep(scenario, grid={RATE: RATES}, workers=1)
    # tcp on loopback, one in-process worker with two threads: starts in about a second
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        assert cluster.scheduler_address.startswith("tcp://127.0.0.1:")
        remote = sweep(scenario, grid={RATE: RATES}, scheduler=cluster.scheduler_address)
    for name in ("tip", "joint1_angle", "status", "error"):  # NaN where case 0 failed
        np.testing.assert_array_equal(remote[name].values, local[name].values)
    assert remote.status.values.tolist() == ["failed", "ok", "ok"]


def test_an_unreachable_scheduler_is_an_input_error(tmp_path: Path,
                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    pytest.importorskip("distributed")
    monkeypatch.setattr(executors, "CONNECT_TIMEOUT", "1s")
    with pytest.raises(SweepError, match="cannot reach the Dask scheduler"):
        sweep(spin_file(tmp_path), grid={RATE: [100.0]}, scheduler="tcp://127.0.0.1:9")


def test_a_dask_sweep_queues_a_few_chunks_per_worker_thread_at_a_time(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """One chunk per worker thread in flight (the rest submitted as each finishes): every
    case still runs once and equals the local sweep."""
    distributed = pytest.importorskip("distributed")
    monkeypatch.setattr(executors, "IN_FLIGHT_PER_WORKER", 1)
    submitted: list[int] = []
    finished: list[int] = []
    in_flight: list[int] = []
    original_submit, original_run = distributed.Client.submit, executors.run_chunk

    def counting(self, *args, **kwargs):
        submitted.append(len(args[1]))  # the chunk's cases
        in_flight.append(len(submitted) - len(finished))
        return original_submit(self, *args, **kwargs)

    def running(chunk, kept):
        result = original_run(chunk, kept)
        finished.append(1)
        return result

    monkeypatch.setattr(distributed.Client, "submit", counting)
    monkeypatch.setattr(executors, "run_chunk", running)
    scenario = spin_file(tmp_path)
    rates = [100.0, 150.0, 200.0, 250.0, 300.0, 350.0]
    local = sweep(scenario, grid={RATE: rates}, workers=1)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  protocol="tcp", host="127.0.0.1",
                                  dashboard_address=None) as cluster:
        remote = sweep(scenario, grid={RATE: rates}, scheduler=cluster.scheduler_address)
    assert sum(submitted) == len(rates) and len(submitted) == len(rates)  # 1 case a chunk
    assert max(in_flight) <= 2  # the 2 worker threads' chunks, never more
    np.testing.assert_array_equal(remote["tip"].values, local["tip"].values)
    assert (remote.status.values == "ok").all()
