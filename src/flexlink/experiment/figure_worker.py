"""Draw the figures of ``flexlink fit``, ``flexlink compare`` and ``flexlink optimize`` in
forked processes while the command computes and writes its data files, as `flexlink run`
does (`flexlink.results.figure_worker`, whose pipes and fallbacks this reuses).

The child imports matplotlib and the command's figure module while the parent works, forks
its partner, and both wait for the job: a picklable figure record of plain arrays (such as
`experiment.figures.FigureData` or `shaping.figures.OptimizeFigures`, with ``stems()``, the
figures there are, and ``write(folder, stems)``) and the folder. The child draws the first
figure, the partner the others. Where anything fails, `wait()` returns False and the caller
draws the figures itself."""

from __future__ import annotations

import contextlib
import functools
import importlib
import os
import pickle
import signal
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..results import figure_worker as _base

_THREE_D = "mpl_toolkits.mplot3d"  # not imported by the drawing processes


class FigureWorker(_base.FigureWorker):
    """A forked child that draws a command's figures on request (see the module doc)."""

    @classmethod
    def start(cls, child: Callable[[int, int], int] | None = None,
              drawing: str = "flexlink.experiment.figures") -> FigureWorker | None:
        """Fork the worker (None where `flexlink.results.figure_worker` cannot); its child
        imports the module ``drawing`` (of the figure record to come) while it waits."""
        worker = super().start(child or functools.partial(_child, drawing=drawing))
        return worker if isinstance(worker, FigureWorker) else None


def _child(jobs: int, replies: int, drawing: str = "flexlink.experiment.figures") -> int:
    """The worker's child: its exit status (0: the figures are written)."""
    partner = None
    try:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, 1)  # nothing of the child's on the command's output
        os.dup2(devnull, 2)
        # loaded while the parent works; without the 3-D axes, which matplotlib imports to
        # register them (optional to it: a warning, to the null device) and these figures
        # never draw
        sys.modules.setdefault(_THREE_D, None)  # type: ignore[arg-type]
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            import matplotlib.backends.backend_agg
            import matplotlib.figure  # noqa: F401

        importlib.import_module(drawing)

        partner = _base._fork_piped(_partner, inherited=(jobs, replies))
        message = _base._read_message(jobs)
        if partner is not None:
            if message is not None:
                with contextlib.suppress(OSError):  # a partner gone: done below says so
                    _base._write_all(partner[1], message)
            os.close(partner[1])
        if message is None:
            return 1  # no job: the command failed or drew nothing
        data, folder = _job(message)
        stems = data.stems()
        mine, theirs = (stems[:1], stems[1:]) if partner is not None else (stems, [])
        data.write(folder, mine)
        if theirs and os.read(partner[2], 1) != b"1":  # type: ignore[index]
            data.write(folder, theirs)
        os.write(replies, b"1")
        return 0
    except BaseException:  # noqa: BLE001 — reported as a status; the parent draws again
        if partner is not None:  # nothing else may draw while the parent does
            with contextlib.suppress(OSError):
                os.kill(partner[0], signal.SIGKILL)
        return 1
    finally:
        if partner is not None:
            with contextlib.suppress(ChildProcessError):
                os.waitpid(partner[0], 0)


def _partner(jobs: int, replies: int) -> int:
    """The partner: draws the figures after the first (the record's ``stems()``)."""
    message = _base._read_message(jobs)
    if message is None:
        return 0
    data, folder = _job(message)
    data.write(folder, data.stems()[1:])
    os.write(replies, b"1")
    return 0


def _job(message: bytes) -> tuple[Any, Path]:
    kind, data, folder = pickle.loads(memoryview(message)[_base._HEADER.size:])
    if kind != "job":
        raise ValueError(f"unexpected message {kind!r}")
    return data, folder
