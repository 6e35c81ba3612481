"""The cache of kernels compiled at installation (flexlink/_compiled_cache.py): the source
stamp, where the locator puts a function's cache and when it declines, and a real numba
cache written in one copy of a package and loaded, without compiling, from another."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from flexlink import _compiled_cache
from flexlink._compiled_cache import CACHE_FOLDER, MARKER, cache_root, source_stamp

pytestmark = pytest.mark.skipif(not hasattr(_compiled_cache, "PackageCacheLocator"),
                                reason="this numba has no cache locator class to extend")


def _package(root: Path) -> Path:
    """A small package with two modules and a marked cache folder."""
    package = root / "pkg"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "sub" / "kernels.py").write_text("def f():\n    return 1\n")
    (package / CACHE_FOLDER).mkdir()
    (package / CACHE_FOLDER / MARKER).write_text("{}")
    return package


def test_stamp_is_stable_under_copies_and_new_modification_times(tmp_path: Path) -> None:
    package = _package(tmp_path)
    stamp = source_stamp(package)
    os.utime(package / "sub" / "kernels.py", (1.0e9, 1.0e9))
    assert source_stamp(package) == stamp
    copy = tmp_path / "elsewhere" / "pkg"
    shutil.copytree(package, copy)  # new modification times, another path
    assert source_stamp(copy) == stamp
    (package / CACHE_FOLDER / "x.py").write_text("ignored")  # the cache is not a source
    assert source_stamp(package) == stamp


def test_stamp_changes_with_any_source_of_the_package(tmp_path: Path) -> None:
    package = _package(tmp_path)
    stamp = source_stamp(package)
    (package / "__init__.py").write_text("X = 2\n")  # not the kernel's own module
    assert source_stamp(package) != stamp
    changed = source_stamp(package)
    (package / "sub" / "new.py").write_text("")
    assert source_stamp(package) != changed


def _kernel() -> None:  # a function to locate (never compiled here)
    pass


def test_locator_puts_the_cache_inside_the_package(tmp_path: Path) -> None:
    package = _package(tmp_path)
    py_file = str(package / "sub" / "kernels.py")
    locator = _compiled_cache.PackageCacheLocator.from_function(_kernel, py_file, package)
    assert locator is not None
    assert Path(locator.get_cache_path()) == package / CACHE_FOLDER / "sub"
    assert locator.get_source_stamp() == source_stamp(package)
    assert locator.get_disambiguator() == str(_kernel.__code__.co_firstlineno)


def test_locator_declines_without_marker_outside_the_package_or_unwritable(
        tmp_path: Path) -> None:
    locate = _compiled_cache.PackageCacheLocator.from_function
    package = _package(tmp_path)
    outside = tmp_path / "other.py"
    outside.write_text("")
    assert locate(_kernel, str(outside), package) is None
    # a cache folder that cannot be made (a file in its place): numba's own locators then
    (package / CACHE_FOLDER / "sub").write_text("")
    assert locate(_kernel, str(package / "sub" / "kernels.py"), package) is None
    (package / CACHE_FOLDER / MARKER).unlink()  # a source tree: no marker, nothing changes
    assert cache_root(package) is None
    assert locate(_kernel, str(package / "__init__.py"), package) is None


def test_installed_first_and_once() -> None:
    from numba.core import caching

    impl = getattr(caching, "CacheImpl", None) or caching._CacheImpl
    assert impl._locator_classes[0] is _compiled_cache.PackageCacheLocator
    assert _compiled_cache.install_locator()
    assert impl._locator_classes.count(_compiled_cache.PackageCacheLocator) == 1


def test_without_numbas_locator_list_nothing_changes(monkeypatch: pytest.MonkeyPatch) -> None:
    from numba.core import caching

    for name in ("CacheImpl", "_CacheImpl"):
        monkeypatch.delattr(caching, name, raising=False)
    assert not _compiled_cache.install_locator()


_KERNEL_MODULE = """
from numba import njit

from . import _compiled_cache  # noqa: F401


@njit(cache=True)
def twice(x):
    return 2.0 * x


print("result", twice(1.5))
"""


def _run(package: Path) -> str:
    env = dict(os.environ, NUMBA_DEBUG_CACHE="1", PYTHONPATH=str(package.parent))
    env.pop("NUMBA_CACHE_DIR", None)
    done = subprocess.run([sys.executable, "-c", "import pkg.kernels"], env=env,
                          capture_output=True, text=True, check=True, timeout=120)
    assert "result 3.0" in done.stdout
    return done.stdout


def test_a_cache_built_in_one_copy_loads_in_another_and_a_change_recompiles(
        tmp_path: Path) -> None:
    """What the wheel does: compiled in build/lib, loaded from site-packages (new paths, new
    modification times) without compiling; a changed source anywhere compiles again."""
    built = _package(tmp_path / "build")
    shutil.copy(_compiled_cache.__file__, built / "_compiled_cache.py")
    (built / "kernels.py").write_text(_KERNEL_MODULE)
    assert "data saved" in _run(built)
    assert any((built / CACHE_FOLDER).glob("kernels.twice-*.nbi"))
    installed = tmp_path / "site" / "pkg"
    shutil.copytree(built, installed)
    os.utime(installed / "kernels.py", (1.0e9, 1.0e9))
    log = _run(installed)
    assert "data loaded" in log and "data saved" not in log
    (installed / "sub" / "kernels.py").write_text("def f():\n    return 2\n")
    assert "data saved" in _run(installed)
