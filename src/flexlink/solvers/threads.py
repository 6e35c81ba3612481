"""One BLAS thread for the solvers' tiny matrices.

Matrices of a few dozen rows gain nothing from BLAS threads, which only add contention (under
load they slowed a paper run many times over); batch runs parallelise over cases instead. The loaded
BLAS libraries are scanned once per process: ``threadpool_limits`` rescans them on every call,
a cost comparable to a short run.
"""

from __future__ import annotations

from contextlib import AbstractContextManager
from functools import lru_cache
from typing import Any

from threadpoolctl import ThreadpoolController


@lru_cache(maxsize=1)
def _controller() -> ThreadpoolController:
    return ThreadpoolController()


def single_threaded() -> AbstractContextManager[Any]:
    """Context in which BLAS uses one thread."""
    return _controller().limit(limits=1)
