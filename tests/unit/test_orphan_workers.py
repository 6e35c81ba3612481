"""A killed command takes its pool's workers with it: `flexlink sweep` killed by SIGKILL (or the
out-of-memory killer) cannot stop its pool, and its workers waited on the pool's queue
forever; the same for the pools of optimize and of the shaping report."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GONE_WITHIN_S = 10.0  # a worker checks its parent every 0.5 s; the rest is a loaded machine

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="reads the process table in /proc")

SWEEP = ["-m", "flexlink", "sweep", "--paper", "--random", "links[0].E=uniform:20e9:40e9",
         "--samples", "20000", "--seed", "1", "--summary", "peak:link2_tip_deflection",
         "--no-histories", "--workers", "2", "-q"]
# the shaping report's pool (forked workers of init_pool_worker, as optimize's) kept busy
REPORT_POOL = ["-c", """
import time
from flexlink.shaping.compare import _fork_pool
pool = _fork_pool(2)
futures = [pool.submit(time.sleep, 120) for _ in range(2)]
time.sleep(120)
"""]


def _state(pid: int) -> str | None:
    """The process's state letter (R, S, Z …), None if there is no such process."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except (FileNotFoundError, ProcessLookupError):
        return None
    return text.rpartition(")")[2].split()[0]


def _children(pid: int) -> list[int]:
    found = []
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                fields = (entry / "stat").read_text().rpartition(")")[2].split()
            except (FileNotFoundError, ProcessLookupError):
                continue
            if int(fields[1]) == pid:
                found.append(int(entry.name))
    return found


def _alive(pid: int) -> bool:
    return _state(pid) not in (None, "Z", "X")  # a zombie has ended (its parent reaps it)


def _wait_for(condition: Callable[[], bool], timeout: float) -> bool:
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if condition():
            return True
        time.sleep(0.1)
    return condition()


@pytest.mark.parametrize("args", [SWEEP, REPORT_POOL], ids=["sweep", "report_pool"])
def test_workers_end_when_their_command_is_killed(tmp_path: Path, args: list[str]) -> None:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])])}
    output = ["-o", str(tmp_path / "s.nc")] if args is SWEEP else []
    errors = tmp_path / "stderr.txt"
    with errors.open("wb") as err:
        command = subprocess.Popen([sys.executable, *args, *output], cwd=tmp_path, env=env,
                                   stdout=subprocess.DEVNULL, stderr=err)
    workers: list[int] = []
    try:
        assert _wait_for(lambda: len(_children(command.pid)) >= 2 or command.poll() is not None,
                         300.0), "the command started no workers"
        assert command.poll() is None, errors.read_text()
        workers = _children(command.pid)
        time.sleep(1.0)  # past their initializers: at work, or waiting on the queue
        assert all(_alive(w) for w in workers)
        command.send_signal(signal.SIGKILL)
        command.wait()
        assert _wait_for(lambda: not any(_alive(w) for w in workers), GONE_WITHIN_S), \
            f"workers {[w for w in workers if _alive(w)]} outlived their killed command"
    finally:
        if command.poll() is None:
            command.kill()
            command.wait()
        for w in workers:  # left behind by a failure: never outlive the test
            if _alive(w):
                os.kill(w, signal.SIGKILL)
