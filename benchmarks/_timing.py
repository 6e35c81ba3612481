"""Timing pieces shared by the benchmarks that run flexlink beside a reference."""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

ROOT = Path(__file__).resolve().parents[1]
T = TypeVar("T")


def median_cpu(run: Callable[[], T], repeat: int) -> tuple[float, T]:
    """The median CPU (process) seconds of ``repeat`` calls of ``run`` after one call to warm
    up (imports, numba's compilation; 0 if ``repeat`` is 0), and the last call's result."""
    out = run()
    cpus = []
    for _ in range(repeat):
        cpu = time.process_time()
        out = run()
        cpus.append(time.process_time() - cpu)
    return (statistics.median(cpus) if cpus else 0.0), out


def use_tree(src: str) -> None:
    """Child initializer: import flexlink from ``src`` (and the tests from this tree)."""
    sys.path.insert(0, str(ROOT))
    sys.path.insert(0, src)
