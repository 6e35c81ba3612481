"""Write a file atomically: under a hidden temporary name beside it, then renamed over it.

``os.replace`` is atomic on one file system: readers see the old file or the new one, never a
half-written file, and a failed write leaves nothing behind.
"""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path


@contextmanager
def atomic_file(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` to write; renamed to ``path`` if the block
    succeeds, removed otherwise. Creates the parent folder."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    partial = path.parent / f".{path.name}.partial-{uuid.uuid4().hex[:8]}"
    try:
        yield partial
        os.replace(partial, path)
    except BaseException:
        partial.unlink(missing_ok=True)
        raise


def check_writable(path: str | Path) -> None:
    """OSError now if ``path`` could not be written (its folder cannot be made, or holds no
    new file), without touching ``path`` itself: a cheap check before a long job."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    probe = path.parent / f".{path.name}.probe-{uuid.uuid4().hex[:8]}"
    probe.touch(exist_ok=False)
    probe.unlink()
