"""Compile every path's kernels into a package's cache folder (`_compiled_cache`): run by
setup.py's build step in a process whose ``flexlink`` is the one being installed (the wheel's
``build/lib``, or the source tree of an editable install).

What gets compiled is found, not listed: every warm-up run of `flexlink warmup`
(`cli.WARMUP_RUNS`, one tiny scenario per path and compiled loop) runs, with the kernels
`flexlink run` preloads for it; then every cached kernel of the package — each numba
function decorated with ``cache=True`` in any of its modules (`kernel_modules`) — is checked
to have been compiled, and one that no warm-up run reached is named in the record
(``uncompiled``; a test keeps that list empty). A new kernel called on an existing path is
therefore compiled without editing anything here; a new path or compiled loop needs its
warm-up run in `cli.warmup_scenarios`.

The runs are shared among worker processes (one per core), each on its own copy of the
package so that no two processes write one cache file (before each run a worker's copy takes
the kernels the others have compiled so far, which it then loads instead of compiling them
again: `_share`, `_AFTER`; a loop that several families use and whose types are every model's
is compiled first, on its own: `_BUILD_ONLY`); their cache files are then moved into
the package's folder (a kernel that two workers compiled for different types keeps every
version; one they both compiled keeps the first copy), and a last pass in one process runs
every warm-up again: it loads every kernel, compiles whatever the merge left out and checks
the coverage above.
"""

from __future__ import annotations

import importlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

from ._compiled_cache import (
    CACHE_FOLDER,
    MARKER,
    PACKAGE_DIR,
    complete,
    host_target,
    read_record,
    source_stamp,
)

_RESULT = "flexlink-warmup-result "  # prefix of a worker's report line
# CPU seconds each warm-up run compiled for in a two-worker build (``_compiled/build.json``,
# "compile"), after the runs of its family before it: the build hands the families out
# longest first. A run missing here counts as the mean of those listed.
COMPILE_CPU = {"radau_loop": 8, "prescribed": 18, "nonlinear": 18, "nonlinear_step": 1,
               "forward": 34, "free_base": 11, "nonlinear_forward": 9,
               "nonlinear_forward_step": 0, "closed_loop": 5, "four_bar": 17,
               "nonlinear_four_bar": 26, "sensitivities": 9, "batched": 10}
# Model paths whose runs integrate with another path's compiled loop (the closed loop's
# Lawson loop is the prescribed path's; the nonlinear path's Gauss loops, compiled once for
# both nonlinear models, are the nonlinear forward path's): one family, one worker.
_SHARES = {"closed_loop": "prescribed", "nonlinear": "nonlinear_forward"}
# Runs that take kernels a run of another family compiles (run → that run), held back until
# it is done: a worker starts each run with every kernel the other workers have compiled
# (`_share`), so these compile once. The first-order loops' closed start (`loops.LoopSystem`:
# `_loops_numba.close` and the kinematics under it) is also the nonlinear four-bar's.
_AFTER = {"four_bar": "nonlinear_four_bar", "nonlinear_four_bar": "radau_loop",
          "sensitivities": "prescribed", "batched": "prescribed"}
# Runs of a path that compile kernels of their own on top of the path's run (held by
# `_AFTER` until it is done): each a family of its own, so the worker free first takes it.
_ALONE = ("sensitivities", "batched")
# Build-only runs (name → its family): a compiled loop whose types do not depend on the model,
# compiled on its own at the start of a family that needs it, so that a run of another family
# that needs it too loads it (`_AFTER`) instead of compiling it again. Radau IIA's loop
# (`_radau_numba.radau_advance`: the model reached through the addresses of its compiled
# code, `_radau_model`) is the forward family's and the nonlinear four-bar's.
_BUILD_ONLY = {"radau_loop": "forward"}
_CACHED_KERNEL = re.compile(r"jit\([^)]*\bcache\s*=\s*True")
_INDEX_DATA = r"\.\d+\.nbc"  # numba's data files beside an index <stem>.nbi: <stem>.<n>.nbc


def kernel_modules(package_dir: Path = PACKAGE_DIR) -> list[str]:
    """Dotted names of the package's modules that define cached numba kernels (a decorator
    ``…jit(…, cache=True, …)`` in their source), in sorted order."""
    names = []
    for path in sorted(package_dir.rglob("*.py")):
        relative = path.relative_to(package_dir)
        if relative.parts[0] == CACHE_FOLDER or path.name in ("_compiled_cache.py",
                                                                "_build_kernels.py"):
            continue
        if _CACHED_KERNEL.search(path.read_text(encoding="utf-8")):
            parts = [package_dir.name, *relative.with_suffix("").parts]
            names.append(".".join(p for p in parts if p != "__init__"))
    return names


def kernels(package_dir: Path = PACKAGE_DIR) -> dict[str, Any]:
    """Every cached numba kernel of the package, by dotted name (importing its modules)."""
    from numba.core.caching import NullCache
    from numba.core.dispatcher import Dispatcher

    found = {}
    for name in kernel_modules(package_dir):
        module = importlib.import_module(name)
        for attribute, value in vars(module).items():
            if (isinstance(value, Dispatcher) and value.py_func.__module__ == name
                    and not isinstance(value._cache, NullCache)):
                found[f"{name}.{attribute}"] = value
    return found


def run_warmup(name: str, scenario: Any) -> dict[str, Any]:
    """Run one warm-up: the kernels `flexlink run` preloads for `scenario`, then the run
    itself. Its wall and CPU seconds, or the error."""
    from .cli import _preload_compiled_code, warmup_run

    wall, cpu = time.perf_counter(), time.process_time()
    try:
        thread = _preload_compiled_code(scenario)
        if thread is not None:
            thread.join()
        warmup_run(name, scenario)
    except Exception as exc:  # noqa: BLE001 — a kernel left out compiles at first use
        return {"error": f"{type(exc).__name__}: {exc}"}
    return {"seconds": round(time.perf_counter() - wall, 1),
            "cpu": round(time.process_time() - cpu, 1)}


def compile_radau_loop() -> None:
    """Compile Radau IIA's loop (`_radau_numba.radau_advance`) on the integrator's own linear
    test model (a damped oscillator, 1 ms): the loop's argument types are every model's
    (`_radau_model.model_functions`, `radau.integrate_radau`), so this compiles the version
    every forward and closed-loop run loads."""
    import numpy as np

    from .solvers._radau_model import LinearData
    from .solvers.radau import integrate_radau

    rates = np.array([[0.0, 1.0], [-1.0, -0.1]])
    integrate_radau(LinearData(rates, np.zeros((2, 1))), (), np.array([1.0, 0.0]),
                    np.array([0.0, 1e-3]), lambda t: np.zeros((t.size, 1)), np.zeros(0),
                    1e-6, 1e-12, np.array([0, 1]))


def run_build_only(name: str) -> dict[str, Any]:
    """Run one build-only run (`_BUILD_ONLY`): its wall and CPU seconds, or the error."""
    wall, cpu = time.perf_counter(), time.process_time()
    try:
        {"radau_loop": compile_radau_loop}[name]()
    except Exception as exc:  # noqa: BLE001 — what it compiles compiles at first use
        return {"error": f"{type(exc).__name__}: {exc}"}
    return {"seconds": round(time.perf_counter() - wall, 1),
            "cpu": round(time.process_time() - cpu, 1)}


def run_warmups(names: list[str] | None = None) -> dict[str, dict[str, Any]]:
    """`run_warmup` of each warm-up run named (all by default), in this process."""
    from .cli import WARMUP_RUNS, warmup_scenarios

    scenarios = warmup_scenarios()
    return {name: run_warmup(name, scenarios[name]) for name in names or WARMUP_RUNS}


def index_file(kernel: Any) -> Path:
    """The index file of a cached kernel's compiled versions (numba names their data files)."""
    return Path(kernel._cache._cache_file._index_path)


def uncached(found: dict[str, Any]) -> list[str]:
    """The kernels of `found` that have no index file in their cache folder: none of their
    versions was compiled there. (A kernel that only other kernels call gets its own files
    when they compile it, but stays untouched when they load from the cache: its files, not
    its signatures in this process, tell.)"""
    return sorted(name for name, kernel in found.items() if not index_file(kernel).is_file())


def unreached_kernels() -> list[str]:
    """The package's cached kernels that no warm-up run compiles: every warm-up run in this
    process, then each kernel without cache files. Meaningful with an empty cache only (a
    fresh NUMBA_CACHE_DIR, the package's cache folder off)."""
    failed = {name: r["error"] for name, r in run_warmups().items() if "error" in r}
    if failed:
        raise RuntimeError(f"warm-up runs failed: {failed}")
    return uncached(kernels())


def worker() -> None:
    """A build worker: reads warm-up run names from standard input, one a line, runs each and
    answers with one line ``_RESULT <json>``; ends at the end of its input."""
    from .cli import warmup_scenarios

    scenarios = warmup_scenarios()
    for line in sys.stdin:
        name = line.strip()
        result = (run_build_only(name) if name in _BUILD_ONLY
                  else run_warmup(name, scenarios[name]))
        print(_RESULT + json.dumps({name: result}), flush=True)


def next_run(queue: list[str], family: dict[str, str], working: dict[int, str],
             worker: int, held: set[str] | frozenset[str] = frozenset()) -> str | None:
    """Take from `queue` the next run for `worker`, leaving the `held` ones (waiting for a
    run of `_AFTER`): the next of the family (model path, or the path whose compiled loop it
    uses) it is on, else the first whose family no other worker is on. Runs of one family
    share most kernels, so one worker compiles them: None when every run left is held, of a
    family another worker is on (it takes them next), or none is left. `working` (worker →
    family) is updated."""
    others = {f for k, f in working.items() if k != worker}
    free = [n for n in queue if n not in held]
    for wanted in ([n for n in free if family[n] == working.get(worker)],
                   [n for n in free if family[n] not in others]):
        if wanted:
            name = wanted[0]
            queue.remove(name)
            working[worker] = family[name]
            return name
    if not any(family[n] == working.get(worker) for n in queue):  # its family's held: kept
        working.pop(worker, None)
    return None


def with_build_only(names: list[str], family: dict[str, str]) -> list[str]:
    """`names` after the build-only runs (`_BUILD_ONLY`) of their families, which go first
    in their family; `family` (run → family) gains theirs."""
    added = [n for n, f in _BUILD_ONLY.items() if f in family.values() and n not in names]
    family.update({n: _BUILD_ONLY[n] for n in added})
    return added + names


def queue_order(names: list[str], family: dict[str, str],
                cost: dict[str, float] = COMPILE_CPU) -> list[str]:
    """`names` in the order the workers take them: families (runs that share kernels) by
    their summed compile `cost`, longest first, as longest-processing-time-first
    scheduling does; within a family, in the order given."""
    known = [cost[n] for n in names if n in cost]
    default = sum(known) / len(known) if known else 1.0
    total: dict[str, float] = {}
    for name in names:
        total[family[name]] = total.get(family[name], 0.0) + cost.get(name, default)
    return sorted(names, key=lambda n: -total[family[n]])


def _copy_package(source: Path, target: Path) -> None:
    shutil.copytree(source, target, ignore=shutil.ignore_patterns("__pycache__"))


def _run_workers(names: list[str], count: int, env: dict[str, str]) -> dict[str, Any]:
    """Share the warm-up runs `names` among `count` worker processes, each on its own copy of
    this package, the next run going to the first worker free (`next_run`); then move the
    cache files they made into this package's folder. The result of each run (and of the
    build-only runs of their families, `with_build_only`), with the worker that ran it and
    when it started (s after the workers started)."""
    results: dict[str, Any] = {}
    from .cli import warmup_scenarios
    from .simulation import model_path

    scenarios = warmup_scenarios()
    paths = {name: model_path(scenarios[name]) for name in names}
    family = {name: name if name in _ALONE else _SHARES.get(path, path)
              for name, path in paths.items()}
    names = with_build_only(names, family)
    queue = queue_order(names, family)
    lock = threading.Condition()
    working: dict[int, str] = {}  # worker → the family (model path) of its current run
    running: set[str] = set()

    def held() -> set[str]:  # runs whose `_AFTER` run is still to come or running
        waiting = set(queue) | running
        return {n for n in queue if _AFTER.get(n) in waiting}

    root = PACKAGE_DIR / CACHE_FOLDER
    with tempfile.TemporaryDirectory(prefix="flexlink-build-") as tmp:
        copies = [Path(tmp) / str(k) / PACKAGE_DIR.name for k in range(count)]
        for copy in copies:
            _copy_package(PACKAGE_DIR, copy)
        start = time.perf_counter()

        def serve(worker: int, copy: Path) -> None:
            worker_env = dict(env, PYTHONPATH=os.pathsep.join(
                [str(copy.parent)] + [p for p in env.get("PYTHONPATH", "").split(os.pathsep)
                                      if p]))
            process = subprocess.Popen(
                [sys.executable, "-c", "from flexlink._build_kernels import worker; worker()"],
                cwd=copy.parent, env=worker_env, stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                text=True)
            assert process.stdin is not None and process.stdout is not None
            try:
                while True:
                    with lock:
                        name = next_run(queue, family, working, worker, held())
                        while name is None and held():  # its own family's, once done
                            lock.wait()
                            name = next_run(queue, family, working, worker, held())
                        if name is not None:
                            running.add(name)
                    if name is None:
                        break
                    for k, other in enumerate(copies):  # the idle worker's copy only
                        if k != worker:
                            _share(other / CACHE_FOLDER, copy / CACHE_FOLDER)
                    began = round(time.perf_counter() - start, 1)
                    process.stdin.write(name + "\n")
                    process.stdin.flush()
                    for line in process.stdout:
                        if line.startswith(_RESULT):
                            result = json.loads(line[len(_RESULT):])
                            results[name] = dict(result[name], worker=worker, start=began)
                            break
                    else:  # the worker died: its run (and the rest) go to the last pass
                        results[name] = {"error": f"worker ended ({process.wait()})"}
                    with lock:
                        running.discard(name)
                        lock.notify_all()
                    if process.poll() is not None:
                        break
            finally:
                with lock:  # its family's runs left go to the others
                    working.pop(worker, None)
                    lock.notify_all()
                process.stdin.close()
                process.wait()

        threads = [threading.Thread(target=serve, args=(k, copy))
                   for k, copy in enumerate(copies)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
        for copy in copies:
            _merge(copy / CACHE_FOLDER, root)
    return results


def _merge(source: Path, target: Path) -> None:
    """Move each kernel's cache files (its index ``<stem>.nbi`` and data ``<stem>.<n>.nbc``)
    from `source` to `target`. Where `target` holds an index of that kernel already (another
    worker compiled other versions of it: a loop specialised for another model's record),
    the versions it lacks join it under data file numbers of its own; a version both hold
    keeps `target`'s copy."""
    for index in sorted(source.rglob("*.nbi")):
        relative = index.parent.relative_to(source)
        destination = target / relative
        stem = index.name[:-len(".nbi")]
        if (destination / index.name).exists():
            _merge_index(index, destination / index.name)
            continue
        destination.mkdir(parents=True, exist_ok=True)
        data = re.compile(re.escape(stem) + _INDEX_DATA + "$")
        for path in index.parent.iterdir():
            if data.match(path.name):
                shutil.move(path, destination / path.name)
        shutil.move(index, destination / index.name)  # last: an index names its data


def _read_index(path: Path) -> tuple[Any, Any, dict[Any, str]]:
    """numba's index file: (numba version, source stamp, {version key: data file name})."""
    import pickle

    with open(path, "rb") as f:
        version = pickle.load(f)
        stamp, overloads = pickle.loads(f.read())
    return version, stamp, overloads


def _share(source: Path, target: Path) -> None:
    """Copy into the cache folder `target` (of a worker between two runs) the compiled
    versions of the cache folder `source` (of a worker that may be compiling) that it lacks.
    numba writes a kernel's index before the data file it names, each whole (a new file
    renamed into place): a version whose data file is not there yet is left out."""
    for index in sorted(source.rglob("*.nbi")):
        into = target / index.parent.relative_to(source) / index.name
        into.parent.mkdir(parents=True, exist_ok=True)
        _merge_index(index, into, copy=True)


def _merge_index(index: Path, into: Path, copy: bool = False) -> None:
    """Add the compiled versions of the index file `index` that the index file `into` (of
    the same kernel, in another folder; absent: none) lacks, moving (``copy``: copying)
    their data files beside `into` under free numbers; nothing when the two were written by
    another numba or for another source (their versions could not be loaded together)."""
    import pickle

    from numba.core.serialize import dumps

    version, stamp, overloads = _read_index(index)
    into_version, into_stamp, into_overloads = (_read_index(into) if into.exists()
                                                else (version, stamp, {}))
    if (version, stamp) != (into_version, into_stamp):
        return
    stem = into.name[:-len(".nbi")]
    taken = set(into_overloads.values())
    number, added = 0, False
    for key, name in overloads.items():
        if key in into_overloads or not (index.parent / name).is_file():
            continue
        added = True
        number += 1
        while f"{stem}.{number}.nbc" in taken:
            number += 1
        fresh = f"{stem}.{number}.nbc"
        taken.add(fresh)
        (shutil.copyfile if copy else shutil.move)(index.parent / name, into.parent / fresh)
        into_overloads[key] = fresh
    if not added:
        return
    temporary = into.with_name(into.name + ".merging")
    with open(temporary, "wb") as f:
        pickle.dump(into_version, f, protocol=-1)
        f.write(dumps((into_stamp, into_overloads)))
    os.replace(temporary, into)  # last: the index names data files already in place


def _seed(root: Path, stamp: str, seed: Path | None) -> None:
    """Make `root` hold no cache files but this source's: kept when its record has the same
    stamp, else replaced by `seed`'s (another build of the same sources, e.g. the wheel's
    ``build/lib`` for an editable install) when that has the same stamp, else emptied."""
    if (read_record(root) or {}).get("stamp") == stamp:
        return
    shutil.rmtree(root, ignore_errors=True)
    if seed is not None and (read_record(seed) or {}).get("stamp") == stamp:
        shutil.copytree(seed, root)


def build(runs: list[str] | None = None, workers: int | None = None,
          seed: Path | None = None) -> dict[str, Any]:
    """Compile the kernels of the given warm-up runs (`cli.WARMUP_RUNS`, all by default) into
    this package's cache folder, shared among `workers` processes (default: one per core
    available), starting from `seed` when that is a cache of the same sources. Returns (and
    writes into the marker) the record: the source stamp, the numba target, each run's
    seconds (compiling, then loading in the last pass), the runs that failed and the kernels
    none reached."""
    start = time.perf_counter()
    root = PACKAGE_DIR / CACHE_FOLDER
    stamp = source_stamp(PACKAGE_DIR)
    _seed(root, stamp, seed)
    previous = read_record(root)
    if previous is not None and previous.get("stamp") == stamp:
        from .cli import WARMUP_RUNS  # the marker is this source's: the locator is on

        if complete(previous, WARMUP_RUNS):
            return previous
    root.mkdir(exist_ok=True)
    info: dict[str, Any] = {"stamp": stamp, "python": sys.version.split()[0], "runs": {},
                            "failed": {}, "uncompiled": []}
    (root / MARKER).write_text(json.dumps(info))  # before any kernel module is imported
    import numba

    from .cli import WARMUP_RUNS

    names = runs or list(WARMUP_RUNS)
    if workers is None:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
            os.cpu_count() or 1)
    compiled: dict[str, Any] = {}
    if min(workers, len(names)) > 1:
        compiled = _run_workers(names, min(workers, len(names)), dict(os.environ))
    # the last pass: loads what the workers compiled, compiles the rest
    for name, result in run_warmups(names).items():
        if "error" in result:
            info["failed"][name] = result["error"]
        else:
            info["runs"][name] = {"compile": compiled.get(name), "last_pass": result}
    info["build_only"] = {name: result for name, result in compiled.items()
                          if name in _BUILD_ONLY}
    found = kernels()
    info["uncompiled"] = uncached(found)
    info["outside"] = sorted(  # cached elsewhere: a kernel module that does not import
        name for name, kernel in found.items()  # _compiled_cache before its decorators
        if not index_file(kernel).resolve().is_relative_to(root.resolve()))
    info.update(numba=numba.__version__, target=host_target(), kernels=len(found),
                workers=workers, seconds=round(time.perf_counter() - start, 1))
    (root / MARKER).write_text(json.dumps(info, indent=1))
    return info


def main(argv: list[str] | None = None) -> int:
    """``python -c "from flexlink._build_kernels import main; main()" [runs] [seed]``:
    `build`, its record printed as JSON; status 1 when no run compiled."""
    argv = sys.argv[1:] if argv is None else argv
    runs = argv[0].split(",") if argv and argv[0] else None
    seed = Path(argv[1]) if len(argv) > 1 and argv[1] else None
    result = build(runs, seed=seed)
    print(json.dumps(result))
    return 1 if result["failed"] and not result["runs"] else 0
