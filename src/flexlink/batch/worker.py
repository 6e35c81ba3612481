"""What a worker runs: a chunk of cases, each through `flexlink.simulate` up to its channel
values (`runner.CaseRunner`), one at a time after the integrations of those that share a
discretisation ran together (`grouped.integrate_together`).

A case that raises is recorded with its error message and the chunk goes on: one bad case
never costs the others. Runs in a local worker process or on a Dask worker (which must be
able to import flexlink). A forked local worker writes its results straight into the
collecting process's result array (`SharedResults`) instead of sending them back.
"""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..channels import Channel
from ..model import Scenario
from ..scenario.fields import FieldPath, ScenarioFile
from .grouped import integrate_together
from .runner import CaseRunner
from .summaries import Summary

PARENT_CHECK_S = 0.5  # s between a worker's checks that the process that started it runs
BLAS_THREAD_VARIABLES = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                         "BLIS_NUM_THREADS", "VECLIB_MAXIMUM_THREADS", "NUMEXPR_NUM_THREADS")


def labels(channels: Sequence[Channel]) -> list[tuple[str, str]]:
    """Names and units: what must agree between cases (descriptions may name a swept x)."""
    return [(c.name, c.unit) for c in channels]


@dataclass(frozen=True)
class SharedResults:
    """The collecting process's result array (channel × case × time) in an anonymous shared
    memory mapping, which forked workers inherit, with the channel labels it holds."""

    array: np.ndarray
    labels: tuple[tuple[str, str], ...]

    @classmethod
    def allocate(cls, channels: Sequence[Channel], cases: int, samples: int) -> SharedResults:
        import mmap

        shape = (len(channels), cases, samples)
        buffer = mmap.mmap(-1, max(1, 8 * shape[0] * shape[1] * shape[2]))  # zeros, shared
        array = np.frombuffer(buffer, dtype=np.float64, count=int(np.prod(shape)))
        return cls(array.reshape(shape), tuple(labels(channels)))


@dataclass
class ChunkResult:
    """Outcome of a chunk. ``values[i]`` (channels × time) belongs to case ``done[i]``; None
    when the worker wrote it into the `SharedResults` array already, or when the sweep keeps
    no histories; ``summaries[i]`` holds the case's summary metrics (`summaries.Summary`)."""

    channels: tuple[Channel, ...] = ()
    done: list[int] = field(default_factory=list)
    values: list[np.ndarray | None] = field(default_factory=list)
    summaries: list[np.ndarray] = field(default_factory=list)
    wall_times: list[float] = field(default_factory=list)
    cpu_times: list[float] = field(default_factory=list)
    failed: dict[int, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Kept:
    """What a sweep keeps of each case: the histories of ``channels`` (all if None) unless
    ``histories`` is false, and the ``summaries``."""

    channels: tuple[str, ...] | None = None
    summaries: tuple[Summary, ...] = ()
    histories: bool = True

    def needed(self) -> frozenset[str] | None:
        """The channels a case must compute: the kept histories' and the summaries' (None:
        every channel)."""
        if self.histories and self.channels is None:
            return None
        histories = (self.channels or ()) if self.histories else ()
        return frozenset([*histories, *(s.channel for s in self.summaries)])


def run_chunk(cases: Sequence[tuple[int, Case]], kept: Kept = Kept(),
              runner: CaseRunner | None = None) -> ChunkResult:
    """Simulate each (case index, case) and keep what ``kept`` says. A case is a `Scenario`
    or a `LazyCase` built here. ``runner``: the `CaseRunner` that keeps the last case's run
    for the next (default: this thread's)."""
    runner = runner or thread_runner()
    channels, summaries = kept.channels, kept.summaries
    needed = kept.needed()
    out = ChunkResult()
    cases = list(cases)
    built, build_times = [], []
    for _, case in cases:  # every case first: those that share output times and steps run together
        started, cpu_started = time.perf_counter(), time.thread_time()
        try:
            built.append(case.build() if isinstance(case, LazyCase) else case)
        except Exception as exc:  # noqa: BLE001 — reported as the case's failure below
            built.append(exc)
        build_times.append((time.perf_counter() - started, time.thread_time() - cpu_started))
    integrated = integrate_together([s if isinstance(s, Scenario) else None for s in built])
    for k, (index, _) in enumerate(cases):
        started, cpu_started = time.perf_counter(), time.thread_time()
        together = integrated.get(k)
        if together is not None:
            started -= together.wall
            cpu_started -= together.cpu
        started -= build_times[k][0]
        cpu_started -= build_times[k][1]
        try:
            scenario = built[k]
            if isinstance(scenario, Exception):
                raise scenario
            results = runner.run(scenario, needed, together)
            names = (list(channels) if channels is not None else results.names) \
                if kept.histories else []
            missing = [n for n in [*names, *(s.channel for s in summaries)] if n not in results]
            if missing:
                raise KeyError(f"no channel {', '.join(missing)} in this case's results")
            found = tuple(results.channels[n] for n in names)
            if out.channels and labels(found) != labels(out.channels):
                raise ValueError("this case's channels differ from the other cases'")
            metrics = np.array([s.evaluate(results.time, results[s.channel]) for s in summaries])
            block: np.ndarray | None = None
            if names and _SHARED is not None and tuple(labels(found)) == _SHARED.labels:
                for k, name in enumerate(names):  # the collector reads it there
                    _SHARED.array[k, index, :] = results[name]
            elif names:
                block = np.stack([results[n] for n in names])
        except Exception as exc:  # noqa: BLE001 — any failure of one case is that case's result
            out.failed[index] = f"{type(exc).__name__}: {exc}"
            continue
        out.channels = found
        out.done.append(index)
        out.values.append(block)
        out.summaries.append(metrics)
        out.wall_times.append(time.perf_counter() - started)
        out.cpu_times.append(time.thread_time() - cpu_started)
    return out


def thread_runner() -> CaseRunner:
    """This thread's `CaseRunner`."""
    runner = getattr(_RUNNERS, "runner", None)
    if runner is None:
        runner = _RUNNERS.runner = CaseRunner()
    return runner


@dataclass(frozen=True)
class LazyCase:
    """A case of a sweep that is built where it runs: the base scenario file with the case's
    values (field path → value), already validated when the sweep started. Sent to a worker
    it costs the values, not a whole `Scenario`, and the parent never holds every case."""

    base: ScenarioFile
    values: dict[FieldPath, float]

    def build(self) -> Scenario:
        return self.base.build(self.values)


Case = Scenario | LazyCase


def exit_with_parent(interval: float = PARENT_CHECK_S) -> None:
    """End this worker process at once (status 1) when the process that started it is gone.
    Killed (SIGKILL, the out-of-memory killer), a parent cannot stop its pool, and its
    workers would wait on the pool's queue forever. A daemon thread polls `os.getppid`,
    which changes when the parent dies (the worker passes to init or a subreaper). Linux's
    parent-death signal cannot serve: it fires when the *thread* that forked the worker
    ends, and a pool may fork its workers from a thread that ends before the pool."""
    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(interval)
        os._exit(1)

    threading.Thread(target=watch, name="flexlink-parent-watch", daemon=True).start()


def init_local_worker(shared: SharedResults | None = None,
                      preload: Scenario | None = None) -> None:
    """Initializer of a local worker process: one BLAS thread (the cores are already shared
    out by process), no SIGINT (Ctrl-C is handled once, by the parent), an end with its
    parent (`exit_with_parent`), the shared result array if the worker was forked (a mapping
    cannot be sent to a spawned one), and the compiled code a run of ``preload`` needs,
    loaded before the first case arrives."""
    global _SHARED
    exit_with_parent()
    _SHARED = shared
    for name in BLAS_THREAD_VARIABLES:
        os.environ[name] = "1"
    from ..solvers.threads import one_thread_for_good

    one_thread_for_good()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if preload is not None:
        load_compiled_code(preload)


def load_compiled_code(scenario: Scenario) -> None:
    """Import the model path ``scenario`` runs and load its compiled kernels (the prescribed
    Lawson path's; other paths load theirs on first use). A failure is left for the cases
    to report."""
    try:
        from ..simulation import model_path, path_function

        path = model_path(scenario)
        path_function(path)
        if path == "prescribed" and scenario.settings.method == "lawson":
            from ..solvers.lawson import load_compiled_loop
            from ..solvers.lawson_batch import load as load_batched_loop

            load_compiled_loop()
            load_batched_loop()  # for the cases that share output times and steps (grouped.py)
    except Exception:  # noqa: BLE001, S110 — every case runs the same code and reports it
        pass


_SHARED: SharedResults | None = None  # set in a local worker process only
_RUNNERS = threading.local()  # a Dask worker may run chunks in several threads
