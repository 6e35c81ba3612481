"""`flexlink fit`'s own process goes without what it never uses (flexlink/_light_start.py):
numpy's testing and f2py packages stay lazy, numba's typing and lowering registries are not
installed to load cached kernels, scipy's docstrings are not parsed at import, matplotlib
stays in the figures' processes — and it
estimates what the same command run in-process (without those measures) estimates."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

from flexlink.cli import main

ROOT = Path(__file__).resolve().parents[2]
PARAMS = ("links[0].EI", "links[0].damping_ratio", "links[1].damping_ratio", "pzt:gain",
          "pzt:offset", "link1_tip_acceleration:gain")
# modules numba imports to install its registries (CPUContext.load_additional_registries,
# the typing context's), which loading a cached kernel does not need
REGISTRY_MODULES = ("numba.np.linalg", "numba.np.arraymath", "numba.np.npyimpl",
                    "numba.np.random.generator_methods", "numba.cpython.listobj",
                    "numba.core.typing.arraydecl", "numba.experimental.jitclass.base")
# the command's process, recording at its exit (after its atexit handlers' turn: `cli._exit`
# runs them) which modules it imported and which of them stayed lazy
PROBE = """
import atexit, json, sys, threading
path = sys.argv.pop(1)
def record():
    modules = {n: type(m).__name__ for n, m in sys.modules.items() if m is not None}
    modules["(threads)"] = threading.active_count()  # 1: the exit without teardown
    # scipy's array-backend note, which parsing the docstring at import would have appended
    modules["(notes appended)"] = "Array API" in sys.modules["scipy.linalg"].block_diag.__doc__
    with open(path, "w") as f:
        json.dump(modules, f)
atexit.register(record)
from flexlink.cli import command
command()
"""


def fit_args(out: Path) -> list[str]:
    args = ["fit", str(ROOT / "examples" / "lab_arm.toml"), str(ROOT / "examples" / "lab_run3.csv"),
            "-o", str(out), "-q"]
    for p in PARAMS:
        args += ["-p", p]
    return args


def _lightly_started(tmp_path: Path, args: list[str]) -> dict:
    """The modules of a `flexlink` command run with ``args`` in a fresh process (`PROBE`),
    after checking it left numpy's unused packages lazy and numba's registries out."""
    record = tmp_path / "modules.json"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT / "src"), *filter(None, [os.environ.get("PYTHONPATH")])])}
    done = subprocess.run([sys.executable, "-c", PROBE, str(record), *args], env=env,
                          capture_output=True, text=True, timeout=600, check=False)
    assert done.returncode == 0, done.stderr
    modules = json.loads(record.read_text())
    for name in ("numpy.testing", "numpy.f2py", "numpy.ctypeslib"):
        assert modules.get(name) == "_LazyModule", f"{name}: {modules.get(name)}"
    installed = [name for name in REGISTRY_MODULES if name in modules]
    assert not installed, f"numba's registries were installed: {installed}"
    return modules


def test_the_fit_command_imports_only_what_it_uses_and_estimates_the_same(tmp_path: Path) -> None:
    modules = _lightly_started(tmp_path, fit_args(tmp_path / "command"))
    assert "matplotlib" not in modules  # drawn by the figure processes
    assert modules["(notes appended)"] is False  # scipy's docstrings left unparsed
    assert (tmp_path / "command" / "figures" / "overlay.png").is_file()

    # the same command in this process: numba's registries and numpy's packages as they were
    assert main(fit_args(tmp_path / "in_process") + ["--no-figures"]) == 0
    command, in_process = (json.loads((tmp_path / folder / "fit.json").read_text())["parameters"]
                           for folder in ("command", "in_process"))
    assert [p["path"] for p in command] == list(PARAMS)
    for ours, theirs in zip(command, in_process, strict=True):
        for key in ("value", "ci_low", "ci_high"):  # round-off apart at most (BLAS threads)
            assert math.isclose(ours[key], theirs[key], rel_tol=1e-9, abs_tol=1e-12), (
                ours["path"], key, ours[key], theirs[key])


SWEEP_RANDOM = {"links[0].E": "uniform:20e9:40e9",
                "joints[0].motion[0].duration": "uniform:0.8:1.2"}
SWEEP_SUMMARIES = ["peak:link2_tip_deflection", "peak:joint1_torque"]


def test_the_sweep_command_takes_the_same_measures_and_its_workers_match_the_library(
        tmp_path: Path) -> None:
    """`flexlink sweep`'s own process (and so its forked workers) goes without numba's
    registries, numpy's unused packages and xarray, and ends without teardown (no thread
    left); its cases equal the library's bit for bit."""
    import numpy as np
    import xarray as xr

    import flexlink
    from flexlink.scenario import paper_experiment_path

    out = tmp_path / "sweep.nc"
    args = ["sweep", "--paper", "--samples", "4", "--seed", "3", "--no-histories",
            "--workers", "2", "-o", str(out)]
    for path, spec in SWEEP_RANDOM.items():
        args += ["--random", f"{path}={spec}"]
    for summary in SWEEP_SUMMARIES:
        args += ["--summary", summary]
    modules = _lightly_started(tmp_path, args)
    assert "xarray" not in modules and "pandas" not in modules
    assert modules["(threads)"] == 1  # no progress bar's monitor thread left: no teardown
    library = flexlink.sweep(paper_experiment_path(), random=SWEEP_RANDOM, samples=4, seed=3,
                             summaries=SWEEP_SUMMARIES, histories=False, workers=1)
    with xr.open_dataset(out) as written:
        assert written.status.values.tolist() == ["ok"] * 4
        for name in ("peak_link2_tip_deflection", "peak_joint1_torque", *SWEEP_RANDOM):
            np.testing.assert_array_equal(written[name].values, library[name].values)


def test_deferred_packages_load_on_first_use() -> None:
    script = ("import sys, numpy\n"
              "from flexlink._light_start import defer_unused_submodules\n"
              "deferred = ['numpy.testing', 'numpy.f2py', 'numpy.ctypeslib']\n"
              "assert defer_unused_submodules() == deferred\n"
              "assert type(sys.modules['numpy.testing']).__name__ == '_LazyModule'\n"
              "import scipy.linalg\n"  # copies numpy's namespace: the packages stay lazy
              "assert type(sys.modules['numpy.testing']).__name__ == '_LazyModule'\n"
              "from numpy.testing import assert_allclose\n"
              "assert_allclose(scipy.linalg.expm(numpy.zeros((2, 2))), numpy.eye(2))\n"
              "assert type(sys.modules['numpy.testing']).__name__ == 'module'\n"
              "assert numpy.testing.assert_allclose is assert_allclose\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    done = subprocess.run([sys.executable, "-c", script], env=env, capture_output=True,
                          text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr


def test_scipy_keeps_its_docstrings_and_capabilities_unparsed() -> None:
    script = ("import math, sys\n"
              "from flexlink._light_start import keep_docstrings_unparsed\n"
              "measure = sys.argv[1] == 'measure'\n"
              "if measure:\n"
              "    assert keep_docstrings_unparsed() == ['scipy._lib._array_api', "
              "'scipy._lib._util']\n"
              "import scipy.linalg, scipy.special\n"
              "from scipy._lib._array_api import xp_capabilities_table\n"
              "f = scipy.special.logsumexp\n"
              "assert f in xp_capabilities_table\n"
              "assert f.__doc__.startswith('Compute the log of the sum'), f.__doc__[:80]\n"
              "assert ('Array API' in f.__doc__) is not measure\n"
              "assert ('\"batch\" dimensions' in scipy.linalg.cholesky.__doc__) is not measure\n"
              "assert math.isclose(f([0.0, 0.0]), math.log(2.0), rel_tol=1e-15)\n"
              "assert scipy.linalg.expm([[0.0]])[0, 0] == 1.0\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    for argument in ("measure", "none"):  # the notes are there without the measure
        done = subprocess.run([sys.executable, "-c", script, argument], env=env,
                              capture_output=True, text=True, timeout=300, check=False)
        assert done.returncode == 0, (argument, done.stderr)
