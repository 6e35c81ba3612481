"""Build step of flexlink (everything else is in pyproject.toml): the numba kernels of every
path are compiled while flexlink installs, on the machine that installs it, so that no first
run waits for LLVM (src/flexlink/_compiled_cache.py, _build_kernels.py, ARCHITECTURE.md).

A wheel (``pip install .``) carries them in its package folder ``_compiled/``; an editable
install (``pip install -e .``) puts them into the source tree's ``src/flexlink/_compiled/``,
copied from the wheel's ``build/lib`` when an earlier ``pip install .`` compiled the same
sources, so the README's second command does not compile again.

FLEXLINK_BUILD_KERNELS: ``all`` (the default) compiles the kernels of every warm-up run
(flexlink.cli.WARMUP_RUNS: one per path and compiled loop), a comma-separated list of warm-up
runs those, ``none`` nothing. A failure never fails the build: the kernels left out compile
at first use.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = Path(__file__).resolve().parent
TIMEOUT = 1800  # s; on a slow machine compiling every path takes a few minutes


def compile_kernels(package_dir: Path, seed: Path | None, choice: str) -> None:
    """Compile the kernels into `package_dir`'s cache folder in a subprocess whose
    ``flexlink`` is `package_dir` (flexlink._build_kernels), starting from `seed`'s cache
    when that holds the same sources'; a note instead of a failure."""
    runs = "" if choice == "all" else choice
    cache = package_dir / "_compiled"
    env = {k: v for k, v in os.environ.items()
           if k not in ("NUMBA_CACHE_LOCATOR_CLASSES", "NUMBA_DISABLE_JIT")}
    # the flexlink being installed first; pip's isolated build environment (numba …) reaches
    # the process through PYTHONPATH too
    env["PYTHONPATH"] = os.pathsep.join(
        [str(package_dir.parent)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep)
                                     if p])
    start = time.perf_counter()
    try:
        done = subprocess.run(
            [sys.executable, "-c",
             "import sys; from flexlink._build_kernels import main; sys.exit(main())",
             runs, str(seed or "")], check=False, cwd=package_dir.parent, env=env,
            capture_output=True, text=True, timeout=TIMEOUT)
        ok = done.returncode == 0
        detail = (done.stdout.strip().splitlines() or [""])[-1]  # the record: what compiled
        if not ok:
            detail = f"{done.stderr.strip()} {detail}"
    except (OSError, subprocess.SubprocessError) as exc:
        ok, detail = False, str(exc)
    if not ok or not any(cache.rglob("*.nbi")):
        shutil.rmtree(cache, ignore_errors=True)
        print("flexlink: note: the numba kernels were not compiled at installation; they "
              f"compile at first use instead ({detail.strip()[-2000:]})", file=sys.stderr)
        return
    print(f"flexlink: numba kernels compiled into {cache} in "
          f"{time.perf_counter() - start:.0f} s: {detail}")


def compile_bytecode(package_dir: Path) -> None:
    """The package's modules compiled to bytecode beside them (``__pycache__``), for an
    editable install, whose source tree pip compiles nothing of: a Python that writes no
    bytecode (PYTHONDONTWRITEBYTECODE, a read-only tree) would otherwise compile every
    flexlink module it imports from source at each start of a command. A note instead of a
    failure; a module edited later is compiled from source again until Python rewrites it."""
    import compileall

    try:
        ok = compileall.compile_dir(str(package_dir), quiet=1)
    except OSError as exc:
        ok, detail = False, str(exc)
    else:
        detail = "a module did not compile"
    if not ok:
        print(f"flexlink: note: bytecode not written into {package_dir} ({detail})",
              file=sys.stderr)


class BuildPyWithKernels(build_py):
    """build_py, then the kernels compiled into the package that is installed: build_lib's
    for a wheel, the source tree's for an editable install (with its bytecode)."""

    def run(self) -> None:
        super().run()
        if getattr(self, "editable_mode", False):
            compile_bytecode(HERE / "src" / "flexlink")
        choice = os.environ.get("FLEXLINK_BUILD_KERNELS", "all").strip()
        if choice == "none":
            return
        if getattr(self, "editable_mode", False):
            compile_kernels(HERE / "src" / "flexlink", HERE / "build" / "lib" / "flexlink"
                            / "_compiled", choice)
        else:
            compile_kernels(Path(self.build_lib).resolve() / "flexlink", None, choice)


setup(cmdclass={"build_py": BuildPyWithKernels})
