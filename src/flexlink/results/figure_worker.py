"""Draw a run's figures in second processes while the first one simulates and writes.

`flexlink run` spends about as long importing matplotlib and drawing the figures as it spends
importing scipy and numba, simulating and writing the data files, and each is serial Python.
`FigureWorker.start()` forks a child process before those imports; the child imports
matplotlib and the plotting code at once (while the parent works), forks its partner, and
both wait for `submit(results, folder)`: the child reads the job and passes it on, and the two
draw the figures (`figures.split_figures`: two groups of about equal work) while the parent
writes the data files; `wait()` returns when all are written. (The partner is forked before
the job arrives: forking a process that holds matplotlib is slow, and would then be on the
command's critical path.)

The worker is an optimisation only: where it cannot run (not Linux, other threads running in
this process, the child failed or died) `wait()` returns False and the caller draws the
figures itself (`figures.write_figures`), raising whatever error drawing raises; where the
second drawing process fails, the child draws its figures. Only the command line uses it;
`write_run` draws in-process by default.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import pickle
import select
import signal
import struct
import sys
import threading
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from ..channels import Channel

_HEADER = struct.Struct("<Q")


class FigureWorker:
    """A forked child that draws figures on request (see the module docstring)."""

    def __init__(self, pid: int, jobs: int, replies: int) -> None:
        self._pid = pid
        self._jobs = jobs  # write end: the job (pickled)
        self._replies = replies  # read end: one status byte
        self._submitted = False

    @classmethod
    def start(cls, child: Callable[[int, int], int] | None = None) -> FigureWorker | None:
        """Fork the worker; None where forking is unavailable or unsafe: threads running, or
        not Linux (macOS's system libraries are not safe to use in a forked child).
        ``child``: what the child runs on its job and reply pipes instead of drawing a run's
        figures (another command's figures: `experiment.figure_worker`)."""
        if (not sys.platform.startswith("linux") or not hasattr(os, "fork")
                or threading.active_count() > 1):
            return None
        sys.stdout.flush()
        sys.stderr.flush()
        forked = _fork_piped(child or _child)
        return None if forked is None else cls(*forked)

    def hint(self, channels: Iterable[Channel]) -> None:
        """Tell the child the channel records the run will have (`channels.catalogue`), so
        that it prepares the figures' frames before the values come (`figures.
        prepare_figures`). Optional; before `submit`."""
        if self._jobs >= 0:
            with contextlib.suppress(OSError):  # the child is gone: wait() reports it
                _write_all(self._jobs, _message(("hint", list(channels))))

    def submit(self, results: Any, folder: Path) -> None:
        """Ask the child to draw ``results``' figures into ``folder`` (returns at once, unless
        the job is larger than the pipe and the child is still starting)."""
        if dataclasses.is_dataclass(results) and hasattr(results, "shapes"):
            # the links' deformed shapes (animations) are 7/8 of a paper run's results and no
            # figure draws them
            results = dataclasses.replace(results, shapes=[])
        try:
            _write_all(self._jobs, _message(("job", results, Path(folder))))
            self._submitted = True
        except OSError:  # the child is gone: wait() reports it
            pass
        finally:
            os.close(self._jobs)
            self._jobs = -1

    def wait(self) -> bool:
        """True when the child wrote the figures; False otherwise (draw them yourself). The
        child may still be ending: `close` reaps it."""
        ok = False
        if self._submitted:
            try:
                ok = os.read(self._replies, 1) == b"1"
            except OSError:
                ok = False
        if not ok:
            self.close()
        return ok

    def close(self) -> None:
        """Release the child (it exits when its job pipe closes) and reap it; a child that
        was given no job is stopped at once (the command failed before its figures)."""
        for attr in ("_jobs", "_replies"):
            fd = getattr(self, attr)
            if fd >= 0:
                os.close(fd)
                setattr(self, attr, -1)
        if self._pid and not self._submitted:
            with contextlib.suppress(OSError):  # it may be importing matplotlib still
                os.kill(self._pid, signal.SIGKILL)
        if self._pid:
            try:
                os.waitpid(self._pid, 0)
            except ChildProcessError:
                pass
            self._pid = 0

    def __del__(self) -> None:
        with contextlib.suppress(Exception):  # interpreter shutdown
            self.close()


def _child(jobs: int, replies: int) -> int:
    """The worker's child: its exit status (0: the figures are written)."""
    status = 1
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)  # nothing of the child's on the command's output
        os.dup2(devnull, 2)
        from . import figures  # matplotlib and the plotting code load while the parent works

        figures.preload_figures()
        partner = _Partner.start(jobs, replies)
        try:
            job = _await_job(jobs, 0 if partner is not None else None,
                             None if partner is None else partner.send)
        finally:
            if partner is not None:
                partner.close_jobs()  # the partner has its job, or ends
        try:
            if job is not None:
                _draw_mine(*job, partner)
                status = 0
                os.write(replies, b"1")
        except BaseException:
            if partner is not None:  # the parent draws again: nothing else may draw now
                partner.kill()
            raise
        if partner is not None:
            partner.reap()  # after the reply: its ending overlaps the parent's report
    except BaseException:  # noqa: BLE001 — reported as a status; the parent draws again
        status = 1
    return status


def _await_job(jobs: int, group: int | None,
               forward: Callable[[bytes], None] | None) -> tuple[Any, Path] | None:
    """Read messages from ``jobs`` until the job (results, folder); None if it closes
    first. Each message is passed on to ``forward`` (the partner) first. A hint's figures of
    ``group`` (`figures.split_figures`; None: all) are prepared while waiting, until the job
    is there."""
    from . import figures

    while True:
        message = _read_message(jobs)
        if message is None:
            return None
        if forward is not None:
            forward(message)
        kind, *data = pickle.loads(memoryview(message)[_HEADER.size:])
        if kind == "job":
            return data[0], data[1]
        if kind == "hint":
            records = figures.ChannelRecords(data[0])
            groups = figures.split_figures(records)
            stems = groups[0] + groups[1] if group is None else groups[group]
            figures.prepare_figures(records, stems, stop=lambda: _readable(jobs))


def _draw_mine(results: Any, folder: Path, partner: _Partner | None) -> None:
    """Draw this process's half of the figures into ``folder`` (`figures.split_figures`),
    then the partner's half too unless the partner drew it."""
    from . import figures

    folder.mkdir(exist_ok=True)
    mine, theirs = figures.split_figures(results)
    if partner is None:
        mine, theirs = mine + theirs, []
    figures.write_figures(results, folder, mine)
    if partner is not None and not partner.done() and theirs:
        figures.write_figures(results, folder, theirs)


class _Partner:
    """The second drawing process, forked by the worker's child before the job arrives; it
    draws the other half of `figures.split_figures` and reports a status byte."""

    def __init__(self, pid: int, jobs: int, replies: int) -> None:
        self._pid = pid
        self._jobs = jobs  # write end: the child's messages, passed on
        self._replies = replies  # read end: b"1" when its figures are written

    @classmethod
    def start(cls, child_jobs: int, child_replies: int) -> _Partner | None:
        """Fork the partner; None if forking fails (the child then draws everything)."""
        # the command's pipes are the child's: the parent must see them close when the child
        # ends, whatever the partner does
        forked = _fork_piped(_partner, inherited=(child_jobs, child_replies))
        return None if forked is None else cls(*forked)

    def send(self, message: bytes) -> None:
        """Pass a message on (if the partner is gone, done() says so)."""
        if self._jobs >= 0:
            try:
                _write_all(self._jobs, message)
            except OSError:
                self.close_jobs()

    def close_jobs(self) -> None:
        """No more messages: a partner without its job ends."""
        if self._jobs >= 0:
            os.close(self._jobs)
            self._jobs = -1

    def done(self) -> bool:
        """Wait for the partner: True when it wrote its figures (it may still be ending:
        `reap`)."""
        try:
            return os.read(self._replies, 1) == b"1"
        except OSError:
            return False
        finally:
            os.close(self._replies)
            self._replies = -1

    def kill(self) -> None:
        """Stop the partner at once and reap it."""
        with contextlib.suppress(OSError):
            os.kill(self._pid, signal.SIGKILL)
        self.reap()

    def reap(self) -> None:
        """Wait for the partner's end (it ends when its job pipe closes, job or not)."""
        self.close_jobs()
        if self._replies >= 0:
            os.close(self._replies)
            self._replies = -1
        with contextlib.suppress(ChildProcessError):
            os.waitpid(self._pid, 0)


def _partner(jobs: int, replies: int) -> int:
    from . import figures

    job = _await_job(jobs, 1, None)
    if job is None:
        return 0  # no job: the command failed or ended
    results, folder = job
    folder.mkdir(exist_ok=True)
    theirs = figures.split_figures(results)[1]
    if theirs:
        figures.write_figures(results, folder, theirs)
    os.write(replies, b"1")
    return 0


def _fork_piped(run: Callable[[int, int], int],
                inherited: tuple[int, ...] = ()) -> tuple[int, int, int] | None:
    """Fork a process that runs ``run(jobs, replies)`` on the read end of a new job pipe and
    the write end of a new reply pipe, after closing ``inherited`` descriptors, and exits
    with the status it returns (1 if it raises). Here: (its pid, the job pipe's write end,
    widened, the reply pipe's read end), or None if forking fails."""
    job_r, job_w = os.pipe()
    reply_r, reply_w = os.pipe()
    try:
        pid = os.fork()
    except OSError:
        for fd in (job_r, job_w, reply_r, reply_w):
            os.close(fd)
        return None
    if pid == 0:  # the new process: never returns
        status = 1
        try:
            for fd in (job_w, reply_r, *inherited):
                os.close(fd)
            status = run(job_r, reply_w)
        finally:
            os._exit(status)
    os.close(job_r)
    os.close(reply_w)
    _widen_pipe(job_w)
    return pid, job_w, reply_r


def _message(obj: Any) -> bytes:
    payload = pickle.dumps(obj, protocol=pickle.HIGHEST_PROTOCOL)
    return _HEADER.pack(len(payload)) + payload


def _read_message(fd: int) -> bytes | None:
    """One message as sent (header and payload); None if the pipe closes first."""
    header = _read_exactly(fd, _HEADER.size)
    if header is None:
        return None
    payload = _read_exactly(fd, _HEADER.unpack(header)[0])
    return None if payload is None else header + payload


def _readable(fd: int) -> bool:
    """Whether reading ``fd`` would not block (a message, or the pipe closed)."""
    return bool(select.select([fd], [], [], 0)[0])


def _widen_pipe(fd: int) -> None:
    """Let the pipe hold a whole job (~0.5 MB for the paper run), so that `submit` need not
    wait for a child still importing matplotlib; best effort (Linux, within its limit)."""
    try:
        import fcntl

        fcntl.fcntl(fd, fcntl.F_SETPIPE_SZ, 1 << 20)
    except (ImportError, AttributeError, OSError):
        pass


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def _read_exactly(fd: int, size: int) -> bytes | None:
    chunks, remaining = [], size
    while remaining:
        chunk = os.read(fd, min(remaining, 1 << 20))
        if not chunk:
            return None
        chunks.append(chunk)
        remaining -= len(chunk)
    return b"".join(chunks)
