"""Build step of flexlink (everything else is in pyproject.toml): a wheel built on the machine
that installs it (``pip install .``) carries the compiled numba kernels, so that the first run
does not wait ~10 s for LLVM (src/flexlink/_compiled_cache.py, docs/performance.md).

FLEXLINK_BUILD_KERNELS: ``prescribed`` (the default) compiles the kernels of prescribed runs
(the paper's), ``all`` those of every path, a comma-separated list of warm-up runs
(flexlink.cli.WARMUP_RUNS) those, ``none`` nothing. A failure never fails the build: the
kernels left out compile at first use.
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

DEFAULT_PATHS = "prescribed"  # the paper and every prescribed run; "all" adds ~1 min (docs)
TIMEOUT = 1800  # s; on a slow machine compiling every path takes a few minutes


class BuildPyWithKernels(build_py):
    """build_py, then the kernels compiled into build_lib/flexlink/_compiled (not for an
    editable install: its kernels compile and cache at first use, as numba does by default)."""

    def run(self) -> None:
        super().run()
        choice = os.environ.get("FLEXLINK_BUILD_KERNELS", DEFAULT_PATHS).strip()
        if getattr(self, "editable_mode", False) or choice == "none":
            return
        runs = "" if choice == "all" else choice
        build_lib = Path(self.build_lib).resolve()
        cache = build_lib / "flexlink" / "_compiled"
        shutil.rmtree(cache, ignore_errors=True)  # never ship a cache of an earlier build
        env = {k: v for k, v in os.environ.items()
               if k not in ("NUMBA_CACHE_LOCATOR_CLASSES", "NUMBA_DISABLE_JIT")}
        # the flexlink being built first; pip's isolated build environment (numba …) reaches
        # the process through PYTHONPATH too
        env["PYTHONPATH"] = os.pathsep.join(
            [str(build_lib)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep) if p])
        start = time.perf_counter()
        try:
            done = subprocess.run(
                [sys.executable, "-c",
                 "import sys; from flexlink._build_kernels import main; sys.exit(main())",
                 runs], check=False, cwd=build_lib, env=env, capture_output=True, text=True,
                timeout=TIMEOUT)
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
        print(f"flexlink: numba kernels compiled into the package in "
              f"{time.perf_counter() - start:.0f} s: {detail}")


setup(cmdclass={"build_py": BuildPyWithKernels})
