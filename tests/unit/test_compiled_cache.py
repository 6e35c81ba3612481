"""The cache of kernels compiled at installation (flexlink/_compiled_cache.py,
flexlink/_build_kernels.py): the source stamp, where the locator puts a function's cache and
when it declines, a real numba cache written in one copy of a package and loaded, without
compiling, from another, the build's merge of its workers' caches, and that the warm-up runs
reach every kernel of the package."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from flexlink import _build_kernels, _compiled_cache
from flexlink._compiled_cache import CACHE_FOLDER, MARKER, cache_root, read_record, source_stamp

pytestmark = pytest.mark.skipif(not hasattr(_compiled_cache, "PackageCacheLocator"),
                                reason="this numba has no cache locator class to extend")


def _package(root: Path) -> Path:
    """A small package with two modules and a marked cache folder."""
    package = root / "pkg"
    (package / "sub").mkdir(parents=True)
    (package / "__init__.py").write_text("")
    (package / "sub" / "kernels.py").write_text("def f():\n    return 1\n")
    (package / CACHE_FOLDER).mkdir()
    return _mark(package)


def _mark(package: Path) -> Path:
    """Mark the package's cache folder as the build does: its record holds the stamp of the
    sources it is compiled from."""
    (package / CACHE_FOLDER / MARKER).write_text(json.dumps({"stamp": source_stamp(package)}))
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


def test_locator_declines_a_cache_of_other_sources(tmp_path: Path) -> None:
    """An installation whose sources changed after its build (an editable install's tree
    edited): numba's own per-module caches apply, not the package's."""
    package = _package(tmp_path)
    assert cache_root(package) == package / CACHE_FOLDER
    record = read_record(package / CACHE_FOLDER)
    (package / CACHE_FOLDER / MARKER).write_text(json.dumps(dict(record, stamp="other")))
    _compiled_cache._package_stamp.cache_clear()
    assert cache_root(package) is None
    assert _compiled_cache.PackageCacheLocator.from_function(
        _kernel, str(package / "sub" / "kernels.py"), package) is None
    (package / CACHE_FOLDER / MARKER).write_text("not json")
    assert read_record(package / CACHE_FOLDER) is None and cache_root(package) is None


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
    _mark(built)
    assert "data saved" in _run(built)
    assert any((built / CACHE_FOLDER).glob("kernels.twice-*.nbi"))
    installed = tmp_path / "site" / "pkg"
    shutil.copytree(built, installed)
    os.utime(installed / "kernels.py", (1.0e9, 1.0e9))
    log = _run(installed)
    assert "data loaded" in log and "data saved" not in log
    (installed / "sub" / "kernels.py").write_text("def f():\n    return 2\n")
    before = sorted((installed / CACHE_FOLDER).iterdir())
    assert "data saved" in _run(installed)
    # compiled into numba's own cache beside the module, the package's left as built
    assert any((installed / "__pycache__").glob("kernels.twice-*.nbi"))
    assert sorted((installed / CACHE_FOLDER).iterdir()) == before


def _kernel_files(root: Path, stem: str, versions: dict[str, str]) -> Any:
    """numba's own cache files of one kernel in ``root/sub``: its index and one data file
    per version (key → data)."""
    from numba.core.caching import IndexDataCacheFile

    files = IndexDataCacheFile(str(root / "sub"), stem, ("mtime", 1))
    (root / "sub").mkdir(parents=True, exist_ok=True)
    for key, data in versions.items():
        files.save(key, data)
    return files


def test_merge_joins_each_kernels_versions_from_every_worker(tmp_path: Path) -> None:
    """The build's workers each compile into their own copy; a kernel that two compiled for
    different types (a loop specialised for two models' records) keeps every version, each
    data file under its own number; a version both compiled keeps the first copy."""
    main, other = tmp_path / "main", tmp_path / "other"
    _kernel_files(main, "m.f-10.py311", {"a": "main a", "b": "main b"})
    _kernel_files(other, "m.f-10.py311", {"b": "other b", "c": "other c", "d": "other d"})
    _kernel_files(other, "m.f-1.py311", {"a": "other a"})  # a name that begins the one above
    _kernel_files(other, "m.g-5.py311", {"a": "g a", "b": "g b"})
    _build_kernels._merge(other, main)
    assert sorted(p.name for p in (main / "sub").iterdir()) == [
        "m.f-1.py311.1.nbc", "m.f-1.py311.nbi", "m.f-10.py311.1.nbc", "m.f-10.py311.2.nbc",
        "m.f-10.py311.3.nbc", "m.f-10.py311.4.nbc", "m.f-10.py311.nbi",
        "m.g-5.py311.1.nbc", "m.g-5.py311.2.nbc", "m.g-5.py311.nbi"]
    merged = _kernel_files(main, "m.f-10.py311", {})
    assert {key: merged.load(key) for key in "abcd"} == {
        "a": "main a", "b": "main b", "c": "other c", "d": "other d"}
    assert _kernel_files(main, "m.g-5.py311", {}).load("b") == "g b"
    assert sorted(p.name for p in (other / "sub").iterdir()) == [
        "m.f-10.py311.1.nbc", "m.f-10.py311.nbi"]  # b, left where it was


def test_share_copies_the_versions_a_worker_lacks_whose_data_is_written(
        tmp_path: Path) -> None:
    """Between two runs a worker's copy takes what the others compiled: each version it
    lacks, copied; one whose data file numba has not written yet (it writes the index
    first) is left out, and the source folder is left as it was."""
    source, target = tmp_path / "source", tmp_path / "target"
    files = _kernel_files(source, "m.f-10.py311", {"a": "src a", "b": "src b", "c": "src c"})
    _kernel_files(source, "m.g-5.py311", {"a": "g a"})
    _kernel_files(target, "m.f-10.py311", {"c": "own c"})
    (source / "sub" / files._load_index()["b"]).unlink()
    before = sorted(p.name for p in (source / "sub").iterdir())
    _build_kernels._share(source, target)
    shared = _kernel_files(target, "m.f-10.py311", {})
    assert {key: shared.load(key) for key in "abc"} == {"a": "src a", "b": None, "c": "own c"}
    assert _kernel_files(target, "m.g-5.py311", {}).load("a") == "g a"
    assert sorted(p.name for p in (source / "sub").iterdir()) == before


def test_merge_leaves_an_index_of_another_source_alone(tmp_path: Path) -> None:
    from numba.core.caching import IndexDataCacheFile

    main, other = tmp_path / "main", tmp_path / "other"
    _kernel_files(main, "m.f-10.py311", {"a": "main a"})
    (other / "sub").mkdir(parents=True)
    IndexDataCacheFile(str(other / "sub"), "m.f-10.py311", ("edited", 2)).save("c", "c")
    _build_kernels._merge(other, main)
    merged = _kernel_files(main, "m.f-10.py311", {})
    assert merged.load("a") == "main a" and merged.load("c") is None


def test_seed_keeps_a_cache_of_these_sources_else_copies_one_or_empties(tmp_path: Path) -> None:
    """An editable install starts from the wheel build's cache of the same sources."""
    root, seed = tmp_path / "root", tmp_path / "seed"
    for folder, stamp in ((root, "old"), (seed, "new")):
        folder.mkdir()
        (folder / MARKER).write_text(json.dumps({"stamp": stamp}))
        (folder / "k.nbi").write_text(stamp)
    _build_kernels._seed(root, "new", seed)
    assert (root / "k.nbi").read_text() == "new"
    (root / "extra.nbi").write_text("")
    _build_kernels._seed(root, "new", None)  # already this source's: kept
    assert (root / "extra.nbi").exists()
    _build_kernels._seed(root, "newer", seed)  # neither matches: nothing kept
    assert not root.exists()


def test_complete_needs_every_run_no_failure_every_kernel_and_this_target(
        monkeypatch: pytest.MonkeyPatch) -> None:
    from flexlink.cli import WARMUP_RUNS

    monkeypatch.setattr(_compiled_cache, "host_target", lambda: ["triple", "cpu", "+f"])
    good = {"runs": {name: {} for name in WARMUP_RUNS}, "failed": {}, "uncompiled": [],
            "target": ["triple", "cpu", "+f"]}
    assert _compiled_cache.complete(good, WARMUP_RUNS)
    assert not _compiled_cache.complete(None, WARMUP_RUNS)
    for change in ({"runs": {WARMUP_RUNS[0]: {}}}, {"failed": {"forward": "boom"}},
                   {"uncompiled": ["flexlink.x.k"]}, {"target": ["triple", "other", "+f"]}):
        assert not _compiled_cache.complete({**good, **change}, WARMUP_RUNS), change


def test_every_module_with_cached_kernels_is_found_and_caches_into_the_package() -> None:
    """`kernel_modules` finds them by their decorators; each imports `_compiled_cache` (which
    puts the package's locator first) and defines at least one cached kernel."""
    package = Path(_compiled_cache.__file__).parent
    importing = {
        ".".join(("flexlink", *path.relative_to(package).with_suffix("").parts))
        for path in package.rglob("*.py")
        if CACHE_FOLDER not in path.relative_to(package).parts
        and "import _compiled_cache" in path.read_text(encoding="utf-8")}
    modules = _build_kernels.kernel_modules()
    assert set(modules) == importing and len(modules) >= 12
    defined = {name.rsplit(".", 1)[0] for name in _build_kernels.kernels()}
    assert defined == set(modules)


def test_the_installation_compiled_every_kernel() -> None:
    """The record of the build that compiled this installation (pip install ., or -e .):
    every warm-up run passed and every cached kernel of the package is in its folder."""
    root = cache_root()
    if root is None:
        pytest.skip("flexlink runs from a tree that no installation compiled (the slow "
                    "test_the_warmup_runs_reach_every_kernel checks the warm-up runs)")
    record = read_record(root)
    assert record["failed"] == {} and record["uncompiled"] == [] and record["outside"] == []
    assert record["kernels"] == len(_build_kernels.kernels())


# After every warm-up run: the uncompiled kernels, then the paths argv[1] names — (scenario
# as JSON, fields, an objective's channel or None): sensitivities, and the objective's value
# and gradient — and the kernels that compiled a version in them (numba's cache misses).
_FIRST_USES = """
import json, sys
import flexlink._compiled_cache as c
c.cache_root = lambda package_dir=None: None
import flexlink
from flexlink._build_kernels import kernels, unreached_kernels
from flexlink.scenario import scenario_from_dict
from flexlink.simulation.objective import MeanSquare, Objective

unreached = unreached_kernels()
found = kernels()
misses = {name: sum(k.stats.cache_misses.values()) for name, k in found.items()}
for path, fields, channel in json.loads(sys.argv[1]):
    scenario = scenario_from_dict(json.load(open(path)))
    flexlink.simulate(scenario, shapes=False, sensitivities=fields)
    if channel:
        objective = Objective(scenario, fields, MeanSquare(channel))
        objective(objective.x0)
compiled = sorted(name for name, k in found.items()
                  if sum(k.stats.cache_misses.values()) > misses[name])
from flexlink._build_kernels import compile_radau_loop
from flexlink.solvers._radau_numba import radau_advance
before = sum(radau_advance.stats.cache_misses.values())
compile_radau_loop()
print(json.dumps([unreached, compiled,
                  sum(radau_advance.stats.cache_misses.values()) - before]))
"""


def _first_uses(folder: Path) -> list[tuple[str, list[str], str | None]]:
    """Paths no warm-up run takes as they are, their scenarios written into ``folder``:
    the sensitivities and an objective of closed loops (the four-bar's pin, the
    slider-crank's piston) and of held inputs (PPF sampled on a torque-driven arm)."""
    import tomllib

    from tests.unit.test_forward_sensitivities import PPF

    examples = Path(__file__).parents[2] / "examples"
    cases = [(tomllib.loads((examples / "four_bar.toml").read_text()), 0.05,
              ["links[1].EI", "links[1].mass_per_length"], "pin_force_x"),
             (tomllib.loads((examples / "slider_crank.toml").read_text()), 0.01,
              ["links[1].EI"], "rod_mid"),
             (tomllib.loads(PPF), 0.1, ["links[0].EI", "controllers[0].gain"], None)]
    runs = []
    for k, (data, t_end, fields, channel) in enumerate(cases):
        data["simulation"]["t_end"] = t_end
        path = folder / f"case{k}.json"
        path.write_text(json.dumps(data))
        runs.append((str(path), fields, channel))
    return runs


@pytest.mark.slow
def test_the_warmup_runs_reach_every_kernel(tmp_path: Path) -> None:
    """What `pip install` compiles is every kernel: a kernel that no warm-up run
    (cli.warmup_scenarios) calls would compile at its first use. Every warm-up run in a new
    process whose numba cache is empty (a new NUMBA_CACHE_DIR, the package's folder off);
    then the sensitivities and objectives of closed loops and held inputs, which no warm-up
    run takes as they are, compile no version of any kernel; nor does Radau IIA's loop
    compiled on its own as the build does (`_build_kernels.compile_radau_loop`): the runs
    load that version."""
    cache = tmp_path / "cache"
    done = subprocess.run([sys.executable, "-c", _FIRST_USES,
                           json.dumps(_first_uses(tmp_path))], capture_output=True, text=True,
                          check=True, timeout=3600,
                          env=dict(os.environ, NUMBA_CACHE_DIR=str(cache)))
    unreached, compiled, radau_versions = json.loads(done.stdout.strip().splitlines()[-1])
    assert unreached == []
    assert compiled == []
    assert radau_versions == 0  # the build's Radau IIA loop alone is the runs' version
    assert any(cache.rglob("*.nbi"))


def test_a_worker_keeps_to_its_path_and_two_workers_to_different_ones() -> None:
    """Runs of one path share most kernels: the build's workers each compile them once."""
    family = {"p": "prescribed", "n": "nonlinear", "f": "forward", "fb": "forward",
              "nf": "nonlinear_forward", "c": "closed_loop"}
    queue, working = ["p", "n", "f", "fb", "nf", "c"], {}
    take = _build_kernels.next_run
    assert take(queue, family, working, 0) == "p" and take(queue, family, working, 1) == "n"
    assert take(queue, family, working, 1) == "f"  # nothing more of n's path
    assert take(queue, family, working, 0) == "nf"  # not fb: worker 1 is on the forward path
    assert take(queue, family, working, 0) == "c"
    assert take(queue, family, working, 0) is None  # fb is worker 1's next
    assert take(queue, family, working, 1) == "fb" and queue == []
    assert take(queue, family, working, 1) is None and working == {}


def test_a_held_run_waits_and_its_worker_keeps_its_family() -> None:
    """A run of `_AFTER` is not taken while the run it loads kernels from is to come; its
    worker keeps its family meanwhile, so the other worker does not take it over."""
    family = {"f": "forward", "fb": "forward", "n": "nonlinear"}
    queue, working = ["f", "fb", "n"], {}
    take = _build_kernels.next_run
    assert take(queue, family, working, 0, {"fb"}) == "f"
    assert take(queue, family, working, 1) == "n"
    assert take(queue, family, working, 0, {"fb"}) is None and working[0] == "forward"
    assert take(queue, family, working, 1) is None  # fb stays worker 0's
    assert take(queue, family, working, 0) == "fb" and queue == []
    assert _build_kernels._AFTER["four_bar"] == "nonlinear_four_bar"


def test_the_families_longest_to_compile_go_first() -> None:
    """Longest-processing-time-first: the family with the largest summed compile time is
    handed out first, its runs in their order; a run without a measured time counts as the
    mean of the others (here 19.4 s: after the prescribed family's 25 s)."""
    from flexlink.cli import WARMUP_RUNS

    family = {"p": "prescribed", "c": "prescribed", "f": "forward", "fb": "forward",
              "n": "nonlinear", "new": "other"}
    cost = {"p": 20.0, "c": 5.0, "f": 60.0, "fb": 2.0, "n": 10.0}
    order = _build_kernels.queue_order(["p", "n", "new", "f", "c", "fb"], family, cost)
    assert order == ["f", "fb", "p", "c", "new", "n"]
    assert set(_build_kernels.COMPILE_CPU) == set(WARMUP_RUNS) | set(_build_kernels._BUILD_ONLY)


def test_a_build_only_run_goes_first_in_its_family() -> None:
    """Radau IIA's loop is compiled on its own first in the forward family, when that family
    is built, and the nonlinear four-bar (another family whose run integrates with it) waits
    for it, so that it loads the loop instead of compiling it again."""
    family = {"p": "prescribed", "f": "forward", "fb": "forward", "nfb": "nonlinear_four_bar"}
    names = _build_kernels.with_build_only(["p", "nfb", "f", "fb"], family)
    assert names == ["radau_loop", "p", "nfb", "f", "fb"] and family["radau_loop"] == "forward"
    cost = {"p": 20.0, "f": 30.0, "fb": 10.0, "nfb": 45.0, "radau_loop": 9.0}
    order = _build_kernels.queue_order(names, family, cost)
    assert order == ["radau_loop", "f", "fb", "nfb", "p"]
    assert _build_kernels._AFTER["nonlinear_four_bar"] == "radau_loop"
    family = {"p": "prescribed", "nfb": "nonlinear_four_bar"}
    assert _build_kernels.with_build_only(["p", "nfb"], family) == ["p", "nfb"]
    assert "radau_loop" not in family


def test_a_run_alone_goes_to_the_worker_free_first() -> None:
    """The sensitivities' and the batched runs compile kernels of their own on top of the
    prescribed run's: held until it is done, then each a family of its own, so a worker free
    while the other is still on the prescribed family takes one (the build's longer worker
    had both after the prescribed family)."""
    from flexlink.cli import warmup_scenarios
    from flexlink.simulation import model_path

    for name in _build_kernels._ALONE:
        assert _build_kernels._AFTER[name] == "prescribed"
        assert model_path(warmup_scenarios()[name]) == "prescribed"
    family = {"p": "prescribed", "c": "prescribed", "s": "s", "b": "b"}
    queue, working = ["c", "b", "s"], {1: "prescribed"}
    take = _build_kernels.next_run
    assert take(queue, family, working, 0) == "b"
    assert take(queue, family, working, 1) == "c"
    assert take(queue, family, working, 1) == "s" and queue == []
