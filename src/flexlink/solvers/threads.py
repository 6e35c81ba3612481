"""One BLAS thread for the solvers' tiny matrices.

Matrices of a few dozen rows gain nothing from BLAS threads, which only add contention (under
load they slowed a paper run many times over); batch runs parallelise over cases instead. The loaded
BLAS libraries are scanned once per process: ``threadpool_limits`` rescans them on every call,
a cost comparable to a short run.
"""

from __future__ import annotations

from contextlib import AbstractContextManager, nullcontext
from functools import lru_cache
from typing import Any

from threadpoolctl import ThreadpoolController


@lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def single_threaded() -> AbstractContextManager[Any]:
    """Context in which BLAS uses one thread (nothing to do in a process that keeps one
    BLAS thread for its life: `one_thread_for_good`)."""
    if _LIMIT is not None:
        return nullcontext()
    return _controller().limit(limits=1)


def one_thread_for_good() -> None:
    """Limit BLAS to one thread for the rest of this process (a sweep's worker, whose
    cores are shared out by process): `single_threaded` then costs nothing, instead of
    setting and restoring every BLAS library's threads around each run (~50 µs)."""
    global _LIMIT
    # A fresh scan: a forked worker may have loaded a BLAS since its parent's scan.
    _LIMIT = ThreadpoolController().limit(limits=1)  # kept alive: holds while it exists


_LIMIT: object = None
