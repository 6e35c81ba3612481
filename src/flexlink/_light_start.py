"""Three start-up measures for a command's own process, which ends when the command does
(`flexlink fit` and `flexlink compare`: ARCHITECTURE.md, "Start-up of `flexlink run`"):

- `defer_unused_submodules`: numpy's ``testing``, ``f2py`` and ``ctypeslib`` packages made
  lazy modules (`importlib.util.LazyLoader`), executed on their first attribute access.
  scipy's copy of numpy's namespace (``scipy._lib.array_api_compat.numpy``, imported by
  every scipy subpackage) touches every public attribute of numpy, which imports them;
  nothing the fit runs uses them (numpy's ``ma``, ``random`` and ``polynomial`` are used at
  import by scipy itself: deferring them gains nothing).
- `load_cached_kernels_only`: numba loads a cached kernel without first installing its
  typing and lowering registries (several thousand templates: most of its first use), which
  only compiling needs. numba still starts its runtime (NRT) there, which loaded code calls;
  a kernel missing from the cache is compiled as before (numba's compiler installs the
  registries itself).
- `keep_docstrings_unparsed`: scipy's decorators ``xp_capabilities`` (``scipy._lib._array_api``)
  and ``_apply_over_batch``, ``_transition_to_rng`` (``scipy._lib._util``), applied at import
  to some 300 functions of scipy.special, optimize, linalg, …, parse each docstring
  (numpydoc's ``FunctionDoc``) to add a note on array backends, batches or the ``rng``
  argument. Here the docstring is kept as written: nothing a command runs reads it, and the
  decorators still do everything else (the capabilities table, the wrappers).

Each leaves the library untouched where the private parts it relies on are missing (another
numpy, numba or scipy), and none is for a caller whose interpreter goes on (a library user's
process): the module objects and numba's cache loading stay changed until the process ends.
"""

from __future__ import annotations

import importlib.util
import sys
from typing import Any

DEFERRED_SUBMODULES = ("numpy.testing", "numpy.f2py", "numpy.ctypeslib")


def defer_unused_submodules(names: tuple[str, ...] = DEFERRED_SUBMODULES) -> list[str]:
    """Make each of ``names`` (``package.submodule``, not imported yet) a lazy module, set on
    its package as well; returns the names deferred."""
    deferred = []
    for name in names:
        if name in sys.modules:
            continue
        package_name, _, attribute = name.rpartition(".")
        package = sys.modules.get(package_name) or importlib.import_module(package_name)
        if attribute in vars(package):
            continue
        spec = importlib.util.find_spec(name)
        if spec is None or spec.loader is None or not hasattr(spec.loader, "exec_module"):
            continue
        spec.loader = importlib.util.LazyLoader(spec.loader)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
        setattr(package, attribute, module)
        deferred.append(name)
    return deferred


def load_cached_kernels_only() -> bool:
    """Let numba load cached kernels without installing its registries (see the module
    doc), for the rest of the process; False (nothing changed) where numba's cache lacks the
    private methods this needs."""
    try:
        from numba.core import caching
        from numba.core.runtime import rtsys
    except ImportError:
        return False
    cache = caching.Cache
    if getattr(cache.load_overload, "registries_skipped", False):
        return True
    if not all(hasattr(cache, a) for a in ("_load_overload",
                                             "_guard_against_spurious_io_errors")):
        return False

    def load_overload(self: Any, sig: Any, target_context: Any) -> Any:
        # numba's own version refreshes target_context (the registries, then the runtime)
        rtsys.initialize(target_context)
        with self._guard_against_spurious_io_errors():
            return self._load_overload(sig, target_context)

    load_overload.registries_skipped = True  # type: ignore[attr-defined]
    cache.load_overload = load_overload
    return True


class _UnparsedDoc:
    """Stands in for numpydoc's ``FunctionDoc`` in scipy's decorators: its sections take
    what is added and drop it, and its text is the docstring as written."""

    def __init__(self, function: Any) -> None:
        self._doc = getattr(function, "__doc__", None) or ""

    def __getitem__(self, section: str) -> list[Any]:
        return []

    def __str__(self) -> str:
        return "\n" + self._doc  # the decorators drop the first line (a signature)


SCIPY_DOC_PARSERS = ("scipy._lib._array_api", "scipy._lib._util")  # modules calling FunctionDoc


def keep_docstrings_unparsed(modules: tuple[str, ...] = SCIPY_DOC_PARSERS) -> list[str]:
    """Let scipy's decorators in ``modules`` leave docstrings unparsed (see the module doc)
    for the scipy modules imported from now on; returns the modules changed (none where
    scipy lacks them or their ``FunctionDoc``)."""
    changed = []
    for name in modules:
        try:
            module = importlib.import_module(name)
        except ImportError:
            continue
        if not hasattr(module, "FunctionDoc"):
            continue
        module.FunctionDoc = _UnparsedDoc
        changed.append(name)
    return changed


def start_command_process() -> None:
    """The three measures above for a command's own process (`flexlink fit`, `optimize`):
    submodules it never uses deferred, compiled kernels loaded from the cache only, scipy's
    docstrings left unparsed."""
    defer_unused_submodules()
    load_cached_kernels_only()
    keep_docstrings_unparsed()
