"""Compile the kernels into an installed package's cache folder (`_compiled_cache`): run by
setup.py's build step in a process whose ``flexlink`` is the one being built."""

from __future__ import annotations

import json
import sys
import time
from typing import Any

from ._compiled_cache import CACHE_FOLDER, MARKER, PACKAGE_DIR


def build(runs: list[str] | None = None) -> dict[str, Any]:
    """Compile the kernels of the given warm-up runs (`cli.WARMUP_RUNS`; all by default) into
    this package's cache folder, and those `flexlink run` preloads with their explicit
    signatures; called by setup.py's build step in a process whose ``flexlink`` is the one
    being built. Returns (and writes into the marker) what was compiled, with the seconds each
    run took; a run that fails is recorded and the others go on."""
    from . import cli

    root = PACKAGE_DIR / CACHE_FOLDER
    root.mkdir(exist_ok=True)
    info: dict[str, Any] = {"python": sys.version.split()[0], "runs": {}, "failed": {}}
    marker = root / MARKER
    marker.write_text(json.dumps(info))  # before any kernel module is imported: it activates
    import numba

    info["numba"] = numba.__version__
    from .simulation import simulate
    from .solvers._lawson_numba import load as load_loop

    scenarios = cli.warmup_scenarios()
    for name in runs or list(cli.WARMUP_RUNS):
        start = time.perf_counter()
        try:
            simulate(scenarios[name], shapes=False)
            if name == "prescribed":  # the explicit signatures of `flexlink run`'s preload
                from .dynamics.prescribed_kernel import load as load_kernels

                load_loop()
                load_kernels()
        except Exception as exc:  # noqa: BLE001 — a kernel left out compiles at first use
            info["failed"][name] = f"{type(exc).__name__}: {exc}"
            continue
        info["runs"][name] = round(time.perf_counter() - start, 1)
    marker.write_text(json.dumps(info, indent=1))
    return info


def main(argv: list[str] | None = None) -> int:
    """``python -c "from flexlink._build_kernels import main; main()" [runs]``: `build`,
    its record printed as JSON; status 1 when no run compiled."""
    argv = sys.argv[1:] if argv is None else argv
    result = build(argv[0].split(",") if argv and argv[0] else None)
    print(json.dumps(result))
    return 1 if result["failed"] and not result["runs"] else 0
