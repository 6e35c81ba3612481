"""Where the chunks of a sweep run: this process, local worker processes, or a Dask cluster.

Each executor gives the `ChunkResult` of every chunk in completion order, and has a
``close()`` (use ``contextlib.closing``): closed before the end (an exception or Ctrl-C in
the consumer) it cancels the chunks not yet started and stops the running ones, so an
interrupted sweep returns at once.
"""

from __future__ import annotations

import math
import multiprocessing
import os
import threading
from collections.abc import Iterable, Iterator, Mapping, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any

from ..model import Scenario
from ..scenario.fields import FieldPath, ScenarioFile
from .cases import check_rows
from .errors import SweepError
from .parameters import CaseTable
from .worker import (
    Case,
    ChunkResult,
    Kept,
    SharedResults,
    exit_with_parent,
    init_local_worker,
    load_compiled_code,
    run_chunk,
    thread_runner,
)

Chunk = list[tuple[int, Case]]
CHUNKS_PER_WORKER = 8  # enough chunks to balance the load and move the progress bar
MAX_CHUNK = 32  # cases per chunk: bounds the result message size and the wait on Ctrl-C
# The fewest cases of a chunk that can advance together: solvers/lawson_batch.MIN_GROUP
# (not imported: this module is on the sweep's start-up path; a test checks they agree).
BATCH_CHUNK = 24
IN_FLIGHT_PER_WORKER = 3  # chunks queued or running per worker: none idles between chunks
CHECKS_PER_WORKER = 4  # slices of the case table each worker checks before the sweep runs
CONNECT_TIMEOUT = "10s"  # to reach a Dask scheduler
STOP_TIMEOUT = 5.0  # s to wait for a terminated worker to exit


def available_cores() -> int:
    """Cores this process may run on (the affinity mask where the OS has one)."""
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def make_chunks(indexed: Sequence[tuple[int, Case]], workers: int) -> Sequence[Chunk]:
    """Consecutive cases in chunks of equal size: few enough tasks that the per-task overhead
    (one message each way) is small, enough of them to keep every worker busy to the end.
    Each chunk is sliced from ``indexed`` when it is read (cases made on demand stay so)."""
    size = max(1, min(MAX_CHUNK, math.ceil(len(indexed) / (workers * CHUNKS_PER_WORKER))))
    return _Chunks(indexed, size)


class _Chunks(Sequence[Chunk]):
    def __init__(self, indexed: Sequence[tuple[int, Case]], size: int) -> None:
        self.indexed, self.size = indexed, size

    def __len__(self) -> int:
        return math.ceil(len(self.indexed) / self.size)

    def __getitem__(self, k: Any) -> Any:
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        if not -len(self) <= k < len(self):
            raise IndexError(k)
        start = (k % len(self)) * self.size
        return list(self.indexed[start:start + self.size])


def failed_chunk(chunk: Chunk, exc: BaseException) -> ChunkResult:
    """Every case of a chunk that could not run (lost worker, unpicklable result …)."""
    return ChunkResult(failed={index: f"{type(exc).__name__}: {exc}" for index, _ in chunk})


def in_process(chunks: Sequence[Chunk], kept: Kept) -> Iterator[ChunkResult]:
    """One worker: run the cases here, in order (no process start-up, same code path); one
    case at a time, as there is no per-task overhead to amortise, but a chunk of
    `BATCH_CHUNK` or more whole: its cases that share their output times and steps advance together."""
    try:
        for chunk in chunks:
            if len(chunk) >= BATCH_CHUNK:
                yield run_chunk(chunk, kept)
                continue
            for case in chunk:
                yield run_chunk([case], kept)
    finally:  # the last case's run is not kept in this process after the sweep
        thread_runner().clear()


def local_processes(workers: int, shared: SharedResults | None = None,
                    preload: Scenario | None = None) -> PoolResults:
    """Start a pool of ``workers`` processes on this machine now, one BLAS thread each, with
    the compiled code a run of ``preload`` needs: loaded here and inherited by forked
    workers, loaded by each worker otherwise while this process goes on (checking the
    cases). `PoolResults.submit` queues the chunks; iterate over it for their results
    and close it (``contextlib.closing``) to end the pool. Forked workers write their results
    into ``shared``; others send them back."""
    context = start_context()
    forked = context.get_start_method() == "fork"
    inherited = shared if forked else None
    if forked and preload is not None:
        # Loaded once here, before the fork: every worker inherits it (its own load then
        # finds it loaded), so the sweep pays numba's import and the cached kernels once
        # instead of once per worker.
        load_compiled_code(preload)
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context,
                               initializer=init_local_worker, initargs=(inherited, preload))
    try:
        for _ in range(workers):  # a pool starts its processes with the first tasks
            pool.submit(_started)
    except BaseException:
        stop_pool(pool)
        raise
    return PoolResults(pool, workers, forked)


def _started() -> None:
    """The task that starts a worker (its initializer does the work)."""


def start_context() -> multiprocessing.context.BaseContext:
    """fork while this process has a single thread: no start-up cost, and a script need not
    guard its code with ``if __name__ == "__main__":``. Forking a process that runs threads
    can deadlock a child (a lock held by another thread is copied held), so then forkserver
    (workers forked from a clean server; the script must have the guard), else spawn."""
    methods = multiprocessing.get_all_start_methods()
    if "fork" in methods and threading.active_count() == 1:
        return multiprocessing.get_context("fork")
    return multiprocessing.get_context("forkserver" if "forkserver" in methods else "spawn")


class PoolResults:
    """The results of a process pool's chunks in completion order. ``close()`` (also when
    iteration never started) ends the pool: waits for it after a complete iteration, else
    cancels the queued chunks and terminates the workers."""

    def __init__(self, pool: ProcessPoolExecutor, workers: int = 1,
                 forked: bool = False) -> None:
        self.pool = pool
        self.workers = workers
        self.forked = forked  # started with the compiled code: idle until their first chunk
        self.futures: dict[Future[ChunkResult], Chunk] = {}
        self.finished = False
        self.window = IN_FLIGHT_PER_WORKER * workers
        self._pending: Iterator[Chunk] = iter(())
        self._kept = Kept()

    def check_cases(self, base: ScenarioFile, table: CaseTable,
                    paths: Mapping[str, FieldPath]) -> dict[int, list[str]]:
        """`cases.check_rows` of every case, run by the workers on slices of the table while
        this process waits (they have no chunk yet): the same problems in the same order as
        checked here, in a fraction of the time. Checked here if a worker is lost."""
        count = table.count
        size = max(1, math.ceil(count / (self.workers * CHECKS_PER_WORKER)))
        starts = range(0, count, size)
        try:
            futures = [self.pool.submit(check_rows, base, table.rows(lo, lo + size), paths, lo)
                       for lo in starts]
            invalid: dict[int, list[str]] = {}
            for future in futures:  # in order of cases
                invalid.update(future.result())
        except Exception:  # noqa: BLE001 — BrokenProcessPool: the sweep's chunks report it
            return check_rows(base, table, paths)
        return invalid

    def submit(self, chunks: Iterable[Chunk], kept: Kept) -> None:
        """Queue the chunks (``kept``: what to keep of each case): a few per worker at a time,
        the next as each finishes, so that a sweep of 10⁵ cases never holds them all."""
        self._pending, self._kept = iter(chunks), kept
        self._top_up()

    def _top_up(self) -> None:
        while len(self.futures) < self.window:
            chunk = next(self._pending, None)
            if chunk is None:
                return
            self.futures[self.pool.submit(run_chunk, chunk, self._kept)] = chunk

    def __iter__(self) -> Iterator[ChunkResult]:
        while self.futures:
            done, _ = wait(self.futures, return_when=FIRST_COMPLETED)
            for future in done:
                chunk = self.futures.pop(future)  # drop it: a held future holds its result
                try:
                    result = future.result()
                except Exception as exc:  # noqa: BLE001 — BrokenProcessPool (a worker died), pickling
                    result = failed_chunk(chunk, exc)
                del future
                self._top_up()  # before the consumer's work on this result: no worker idles
                yield result
        self.finished = True

    def close(self) -> None:
        if self.finished:
            self.pool.shutdown(wait=True)
        else:
            stop_pool(self.pool)


def init_pool_worker() -> None:
    """Initializer of a pool's worker: no SIGINT, Ctrl-C is handled once, by the parent,
    which stops the workers (`stop_pool`; otherwise each worker prints its own traceback of
    the KeyboardInterrupt over the command's message); and an end with the parent if it is
    killed (`worker.exit_with_parent`)."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)
    exit_with_parent()


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel the queued tasks and end the running ones now (not after they finish)."""
    terminate = getattr(pool, "terminate_workers", None)  # Python >= 3.14
    if terminate is not None:
        terminate()
        return
    processes = list((getattr(pool, "_processes", None) or {}).values())  # before shutdown
    for process in processes:  # clears it
        process.terminate()
    pool.shutdown(wait=False, cancel_futures=True)
    for process in processes:  # gone when the sweep returns or raises (SIGTERM: at once)
        process.join(STOP_TIMEOUT)


def dask_cluster(chunks: Iterable[Chunk], kept: Kept, client: Any, cores: int = 1
                 ) -> Iterator[ChunkResult]:
    """The chunks as tasks on a `distributed.Client`, ``IN_FLIGHT_PER_WORKER`` per worker
    thread (``cores``) at a time, the next as each finishes; results in completion order."""
    from distributed import as_completed as dask_as_completed

    remaining = iter(chunks)
    pending: dict[Any, tuple[Any, Chunk]] = {}

    def submit_next() -> Any:
        chunk = next(remaining, None)
        if chunk is None:
            return None
        future = client.submit(run_chunk, chunk, kept=kept, pure=False)
        pending[future.key] = (future, chunk)
        return future

    first = []
    for _ in range(IN_FLIGHT_PER_WORKER * max(1, cores)):
        future = submit_next()
        if future is None:
            break
        first.append(future)
    completed = dask_as_completed(first)
    del first
    try:
        for future in completed:
            _, chunk = pending.pop(future.key)
            try:
                result = future.result()
            except Exception as exc:  # noqa: BLE001 — a worker lost, flexlink not importable there
                result = failed_chunk(chunk, exc)
            future.release()  # else the cluster keeps every result until the sweep ends
            del future
            following = submit_next()
            if following is not None:
                completed.add(following)
            del following
            yield result
    finally:
        if pending:  # left early: cancel what has not run
            client.cancel([future for future, _ in pending.values()])


def connect(scheduler: Any) -> tuple[Any, bool]:
    """(client, whether we opened it) for a scheduler address or an existing Client."""
    try:
        from distributed import Client
    except ImportError:
        raise SweepError([("running on a Dask cluster needs dask.distributed: "
                          "pip install 'flexlink[cluster]'")]) from None
    if isinstance(scheduler, Client):
        return scheduler, False
    try:
        return Client(str(scheduler), timeout=CONNECT_TIMEOUT), True
    except (OSError, TimeoutError) as exc:
        raise SweepError([f"cannot reach the Dask scheduler at {scheduler}: {exc}"]) from None


def dask_cores(client: Any) -> int:
    """Worker threads of the cluster (for the chunk size)."""
    workers = client.scheduler_info().get("workers", {})
    return max(1, sum(int(w.get("nthreads", 1)) for w in workers.values()))
