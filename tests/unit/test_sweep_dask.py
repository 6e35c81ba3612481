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
