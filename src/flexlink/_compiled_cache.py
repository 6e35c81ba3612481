"""The compiled kernels carried by an installed package (docs/performance.md, "Compiled at
installation").

numba caches a compiled function (``cache=True``) beside its module or in
``NUMBA_CACHE_DIR``, so the first run on a machine waits for LLVM. ``pip install .``
builds a wheel whose build step (setup.py) compiles the kernels into the package's folder
``_compiled/`` on the machine that installs it; `PackageCacheLocator`, put first in numba's
list of cache locators when a kernel module is imported, finds them there.

What keeps a wrong kernel out: numba's index file refuses another numba version, its key
holds the signature, the target CPU (name and features) and a hash of the function's
bytecode; the source stamp here is a hash of every ``.py`` file of the package with the
numba, llvmlite and numpy versions, so any change of any source (a kernel calls kernels and
constants of other modules) or of those libraries makes numba compile again, as without
this cache. The marker records the stamp of the sources it was compiled from: where
``_compiled/`` is missing (a source tree), holds another stamp (a source edited since, or
another numba, llvmlite or numpy) or is not writable, the locator declines and numba's own
locators apply, unchanged (in an editable install, whose build compiles into the source tree's
``_compiled/``, editing a source returns to numba's per-file caches beside the modules). The locator list is
private numba API: without it (a future numba), `install_locator` does nothing and
``cache=True`` behaves as it always did.
"""

from __future__ import annotations

import functools
import hashlib
import json
import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

CACHE_FOLDER = "_compiled"
MARKER = "build.json"  # written by `_build_kernels.build`; the locator is active where it is
PACKAGE_DIR = Path(os.path.realpath(__file__)).parent

try:  # private numba API: guarded, see the module's docstring
    from numba.core.caching import _CacheLocator
except ImportError:  # pragma: no cover — numba moved it: plain cache=True
    _CacheLocator = None


def source_stamp(package_dir: Path) -> str:
    """Hex digest of every ``.py`` file under `package_dir` (relative path and content, in
    sorted order; the cache folder left out) and of the numba, llvmlite and numpy versions:
    the same for the same sources wherever and whenever they were copied (modification
    times play no part)."""
    import llvmlite
    import numba
    import numpy

    digest = hashlib.sha256()
    for library in (numba, llvmlite, numpy):
        digest.update(f"{library.__name__}={library.__version__}\n".encode())
    files = []
    for folder, subfolders, names in os.walk(package_dir):
        subfolders[:] = [s for s in subfolders if s not in (CACHE_FOLDER, "__pycache__")]
        relative = Path(folder).relative_to(package_dir)
        files += [(relative / name).as_posix() for name in names if name.endswith(".py")]
    for name in sorted(files):
        digest.update(name.encode() + b"\0")
        digest.update((package_dir / name).read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()


@functools.cache
def _package_stamp(package_dir: Path) -> str:
    # Once per process: the installed sources do not change under a running program.
    return source_stamp(package_dir)


def read_record(root: Path) -> dict[str, Any] | None:
    """The build's record in cache folder `root` (its marker), None when missing or unreadable."""
    try:
        record = json.loads((root / MARKER).read_text())
    except (OSError, ValueError):
        return None
    return record if isinstance(record, dict) else None


def cache_root(package_dir: Path = PACKAGE_DIR) -> Path | None:
    """The package's cache folder if the build made one for these sources (its marker
    records their stamp), else None."""
    root = package_dir / CACHE_FOLDER
    record = read_record(root)
    if record is None or record.get("stamp") != _package_stamp(package_dir):
        return None
    return root


def host_target() -> list[str]:
    """numba's code generation target here (triple, CPU name, CPU features): part of the key
    of every cached kernel, so a cache made for another target is compiled again."""
    from numba.core.registry import cpu_target

    return list(cpu_target.target_context.codegen().magic_tuple())


def complete(record: dict[str, Any] | None, runs: Sequence[str]) -> bool:
    """Whether a build record says every kernel is compiled for this machine: each of the
    warm-up runs `runs` passed, every kernel was reached, for this numba target."""
    return (record is not None and set(runs) <= set(record.get("runs", {}))
            and not record.get("failed") and not record.get("uncompiled")
            and record.get("target") == host_target())


@functools.cache
def _writable(folder: str) -> bool:
    """Whether numba can write its index and data files in `folder` (created if missing)."""
    try:
        os.makedirs(folder, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()  # a unique name: threads may probe at once
    except OSError:
        return False
    return True


if _CacheLocator is not None:

    class PackageCacheLocator(_CacheLocator):
        """numba cache locator for the kernels of an installed flexlink: the cache folder is
        ``_compiled/<subpackage>`` inside the package, the source stamp `source_stamp` of the
        whole package."""

        def __init__(self, py_func: Any, py_file: str, cache_path: str,
                     package_dir: Path = PACKAGE_DIR) -> None:
            self._py_file = py_file  # numba's warnings name it
            self._lineno = py_func.__code__.co_firstlineno
            self._cache_path = cache_path
            self._package_dir = package_dir

        def get_cache_path(self) -> str:
            return self._cache_path

        def get_source_stamp(self) -> str:
            return _package_stamp(self._package_dir)

        def get_disambiguator(self) -> str:
            return str(self._lineno)  # as numba's own locators: functions are told by line

        @classmethod
        def from_function(cls, py_func: Any, py_file: str,
                          package_dir: Path = PACKAGE_DIR) -> PackageCacheLocator | None:
            """A locator for a function of this package when its cache folder exists and is
            writable; None leaves the function to numba's next locator."""
            root = cache_root(package_dir)
            if root is None or not py_file or not os.path.exists(py_file):
                return None
            folder = os.path.dirname(os.path.realpath(py_file))
            relative = os.path.relpath(folder, package_dir)
            if relative == os.pardir or relative.startswith(os.pardir + os.sep):
                return None  # not one of ours
            cache_path = os.path.normpath(os.path.join(root, relative))
            if not _writable(cache_path):
                return None  # a read-only installation: numba's locators (NUMBA_CACHE_DIR)
            return cls(py_func, os.path.realpath(py_file), cache_path, package_dir)


def install_locator() -> bool:
    """Put `PackageCacheLocator` first in numba's cache locators (once per process). False
    when this numba has no such list: then nothing changes."""
    if _CacheLocator is None:
        return False
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    classes = getattr(impl, "_locator_classes", None)
    if not isinstance(classes, list):
        return False
    if PackageCacheLocator not in classes:
        classes.insert(0, PackageCacheLocator)
    return True


install_locator()
