"""Batch sweeps: every case equals its own `simulate` run, failures and Ctrl-C keep the
finished cases, the netCDF file round-trips, the command line agrees with the library, and
the same sweep runs on a Dask cluster (test_sweep_dask.py)."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import xarray as xr

import flexlink
import flexlink.simulation
from flexlink.batch import SweepError, SweepInterrupted, executors, sweep
from flexlink.cli import main
from flexlink.scenario import paper_experiment_path, scenario_from_dict
from flexlink.scenario.load import read_toml
from flexlink.simulation import run_scenario, simulate

SPIN = """\
[simulation]
name = "spin"
t_end = 1.0
dt_out = 0.05

[[links]]
name = "arm"
length = 0.6
mass_per_length = 0.0636
EI = 0.163
modes = 1

[[joints]]
motion = [{ profile = "spinup", to_rate_deg_s = 30.0, start = 0.0, duration = 0.2 }]

[[sensors]]
name = "tip"
kind = "deflection"
link = "arm"
x = 0.6
"""
# The paper's model (no geometric stiffening) diverges above the first frequency, about
# 2.5 Hz = 900 deg/s for this arm: 3000 deg/s fails, 100 and 200 deg/s do not.
RATES = [3000.0, 100.0, 200.0]
RATE = "joints[0].motion[0].to_rate_deg_s"


def short_paper() -> dict[str, Any]:
    """The paper's two links, 2 modes each, a 20° / 20° move in 0.3 s, 0.4 s simulated."""
    raw = read_toml(paper_experiment_path())
    raw["simulation"].update(t_end=0.4, dt_out=0.01, geometric_stiffening=True)
    raw["joints"][0]["motion"][0].update(start=0.0, duration=0.3, to_deg=20.0)
    raw["joints"][1]["motion"][0].update(start=0.0, duration=0.3, to_deg=110.0)
    for link in raw["links"]:
        link["modes"] = 2
    return raw


def single_run(raw: dict[str, Any], link1_EI: float, duration: float):
    """The case built by hand, independently of the sweep's path machinery."""
    raw = copy.deepcopy(raw)
    link = raw["links"][0]
    del link["E"]
    link["EI"] = link1_EI
    raw["joints"][1]["motion"][0]["duration"] = duration
    return simulate(scenario_from_dict(raw, paper_experiment_path().parent))


def spin_file(tmp_path: Path) -> Path:
    path = tmp_path / "spin.toml"
    path.write_text(SPIN, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def paper_sweep(tmp_path_factory: pytest.TempPathFactory) -> tuple[xr.Dataset, Path]:
    out = tmp_path_factory.mktemp("sweep") / "paper.nc"
    dataset = sweep(short_paper(), grid={"links[0].EI": [250.0, 350.0]},
                    random={"joints[1].motion[0].duration": "uniform:0.25:0.35"},
                    samples=2, seed=5, output=out, workers=2,
                    base_dir=paper_experiment_path().parent)
    return dataset, out


def test_every_case_equals_its_own_simulate_run(paper_sweep) -> None:
    dataset, _ = paper_sweep
    assert dataset.sizes == {"case": 4, "time": 41}
    assert dataset.status.values.tolist() == ["ok"] * 4
    raw = short_paper()
    for case in range(4):
        EI = float(dataset["links[0].EI"][case])
        duration = float(dataset["joints[1].motion[0].duration"][case])
        reference = single_run(raw, EI, duration)
        assert set(reference.names) == set(dataset.data_vars) - {
            "status", "error", "wall_time", "cpu_time"}
        for name in reference.names:
            # bit for bit: the same computation in a worker process
            assert np.array_equal(dataset[name].values[case], reference[name]), (case, name)
        assert dataset[reference.names[0]].attrs["units"] == \
            reference.channels[reference.names[0]].unit
    # the cases differ: the sweep really varied the fields
    assert not np.array_equal(dataset.link1_tip_acceleration[0], dataset.link1_tip_acceleration[2])


def test_the_file_holds_the_dataset_and_the_sweep_definition(paper_sweep) -> None:
    dataset, out = paper_sweep
    with xr.open_dataset(out) as read:
        xr.testing.assert_identical(read.load(), dataset)
        assert read.attrs["sweep_state"] == "finished" and read.attrs["seed"] == "5"
        assert read.attrs["cases_ok"] == 4 and read.attrs["Conventions"] == "CF-1.8"
        assert read["links[0].EI"].attrs["units"] == "N m2"  # UDUNITS spelling
        assert read["link1_tip_acceleration"].attrs["kind"] == "sensor"
        base = read.attrs["base_scenario"]
    assert "[[links]]" in base and "EI = 308.7" in base  # the resolved base scenario
    assert not list(out.parent.glob(".*partial*"))


def test_a_failing_case_keeps_the_others(tmp_path: Path) -> None:
    dataset = sweep(spin_file(tmp_path), grid={RATE: RATES}, workers=1)
    assert dataset.status.values.tolist() == ["failed", "ok", "ok"]
    assert "SimulationError: the tip deflection of arm exceeds its length" in \
        str(dataset.error.values[0])
    assert dataset.error.values[1] == ""
    for name in ("tip", "joint1_angle", "wall_time", "cpu_time"):  # the failed case is NaN
        assert np.all(np.isnan(dataset[name].values[0]))
        assert np.all(np.isfinite(dataset[name].values[1:]))
    for case in (1, 2):
        raw = read_toml(spin_file(tmp_path))
        raw["joints"][0]["motion"][0]["to_rate_deg_s"] = RATES[case]
        reference = simulate(scenario_from_dict(raw))
        assert np.array_equal(dataset.tip.values[case], reference["tip"])


def test_interrupt_writes_the_finished_cases_and_raises(tmp_path: Path,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    calls: list[int] = []
    checkpoints: list[list[str]] = []
    out = tmp_path / "spin.nc"

    def interrupted_on_third(scenario, progress=False, shapes=True, channels=None):
        calls.append(1)
        if len(calls) == 3:
            with xr.open_dataset(out) as partial:  # the checkpoint after the second case
                checkpoints.append(partial.status.values.tolist())
            raise KeyboardInterrupt
        return run_scenario(scenario, progress, shapes, channels)

    monkeypatch.setattr(flexlink.simulation, "run_scenario", interrupted_on_third)
    with pytest.raises(SweepInterrupted) as excinfo:
        sweep(spin_file(tmp_path), grid={RATE: [100.0, 200.0, 300.0, 400.0]}, workers=1,
              output=out, checkpoint_interval=0.0)
    assert checkpoints == [["ok", "ok", "not_run", "not_run"]]
    assert excinfo.value.dataset.status.values.tolist() == ["ok", "ok", "not_run", "not_run"]
    with xr.open_dataset(out) as written:
        assert written.status.values.tolist() == ["ok", "ok", "not_run", "not_run"]
        assert written.attrs["sweep_state"] == "interrupted"
        assert written.attrs["cases_not_run"] == 2


def test_channels_can_be_selected_and_unknown_ones_are_rejected(tmp_path: Path) -> None:
    dataset = sweep(spin_file(tmp_path), grid={RATE: [100.0]}, channels=["tip"], workers=1)
    assert [n for n in dataset.data_vars if dataset[n].dims == ("case", "time")] == ["tip"]
    with pytest.raises(SweepError, match="unknown channel 'tipp'; available: tip, joint1_angle"):
        sweep(spin_file(tmp_path), grid={RATE: [100.0]}, channels=["tipp"], workers=1)


def test_a_sweep_written_as_mat_holds_the_same_layout(tmp_path: Path) -> None:
    from scipy.io import loadmat

    out = tmp_path / "rates.mat"
    dataset = sweep(spin_file(tmp_path), grid={RATE: RATES}, workers=1, output=out)
    mat = loadmat(out, simplify_cells=True)
    assert list(mat["status"]) == ["failed", "ok", "ok"]
    assert mat["error"][0].startswith("SimulationError")
    rate = "joints_0_motion_0_to_rate_deg_s"  # MATLAB names, the mapping in `variables`
    np.testing.assert_array_equal(mat[rate], RATES)
    np.testing.assert_array_equal(mat["tip"], dataset.tip.values)  # case × time, NaN row 0
    assert np.all(np.isnan(mat["tip"][0])) and mat["t"].shape == (dataset.sizes["time"],)
    table = {v["name"]: v for v in mat["variables"]}
    assert table[RATE]["matlab_name"] == rate and table[RATE]["units"] == "degree s-1"
    assert table["tip"]["dims"] == "case,time" and table["tip"]["kind"] == "sensor"
    assert mat["attributes"]["cases_failed"] == 1


def test_command_line_sweep_matches_the_library(tmp_path: Path,
                                                capsys: pytest.CaptureFixture[str]) -> None:
    scenario, out = spin_file(tmp_path), tmp_path / "cli.nc"
    status = main(["sweep", str(scenario), "--grid", f"{RATE}={','.join(map(str, RATES))}",
                   "--workers", "1", "-o", str(out)])
    report = capsys.readouterr().out
    assert status == 1  # one case failed; the file holds the others
    assert "3 cases" in report and "2 ok, 1 failed" in report
    assert f"case 0 ({RATE} = 3000): SimulationError" in report
    # the progress bar's rate, and where the rest of the time went
    assert "cases/s while the cases ran" in report and "start the workers and write" in report
    library = sweep(scenario, grid={RATE: RATES}, workers=1)
    with xr.open_dataset(out) as read:
        for name in ("tip", "joint1_angle", "status", RATE):  # NaN where case 0 failed
            np.testing.assert_array_equal(read[name].values, library[name].values)
        assert read.tip.encoding["_FillValue"] != read.tip.encoding["_FillValue"]  # NaN
    # the file exists now: refused without --overwrite, before anything runs
    assert main(["sweep", str(scenario), "--grid", f"{RATE}=100", "-o", str(out), "-q"]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["sweep", str(scenario), "--grid", f"{RATE}=100", "-o", str(out), "-q",
                 "--overwrite", "--workers", "1"]) == 0
    assert capsys.readouterr().out.strip() == str(out)


def test_the_command_writes_and_reports_without_importing_xarray(tmp_path: Path) -> None:
    """`flexlink sweep` writes its file and prints its summary from the sweep's layout: xarray
    and pandas (~0.7 s of CPU at start-up) are never imported in its process."""
    import subprocess
    import sys

    out = tmp_path / "spin.nc"
    code = ("import sys; from flexlink.cli import main; "
            f"status = main(['sweep', {str(spin_file(tmp_path))!r}, '--grid', '{RATE}=100,200', "
            f"'--summary', 'peak:tip', '--workers', '1', '-o', {str(out)!r}]); "
            "print(status, 'xarray' in sys.modules, 'pandas' in sys.modules)")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True)
    *report, last = done.stdout.strip().splitlines()
    assert last == "0 False False"
    assert "2 cases" in report[0] and "peak_tip: min" in "\n".join(report)
    with xr.open_dataset(out) as written:
        assert written.status.values.tolist() == ["ok", "ok"]
        assert np.all(written.peak_tip.values > 0)


def test_command_line_random_sweep_of_the_paper_defaults_its_file_name(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    # not run: the first case is invalid, so the whole sweep is refused with exit status 2
    status = main(["sweep", "--paper", "--random", "sensors[0].x=uniform:1.3:1.5",
                   "--samples", "3", "--seed", "2"])
    err = capsys.readouterr().err
    assert status == 2 and "sensors[0].x must be <= 1.37 m" in err
    assert not list(tmp_path.iterdir())
    assert main(["sweep", "--paper", "--grid", "links[0].EI=abc"]) == 2
    assert "grid links[0].EI: expected a number, got 'abc'" in capsys.readouterr().err


def test_command_line_interrupt_exits_130_with_the_file(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    calls: list[int] = []

    def interrupted_on_second(scenario, progress=False, shapes=True, channels=None):
        calls.append(1)
        if len(calls) == 2:
            raise KeyboardInterrupt
        return run_scenario(scenario, progress, shapes, channels)

    monkeypatch.setattr(flexlink.simulation, "run_scenario", interrupted_on_second)
    out = tmp_path / "cut.nc"
    status = main(["sweep", str(spin_file(tmp_path)), "--grid", f"{RATE}=100,200,300",
                   "--workers", "1", "-o", str(out), "-q"])
    assert status == 130 and "interrupted" in capsys.readouterr().err
    with xr.open_dataset(out) as written:
        assert written.status.values.tolist() == ["ok", "not_run", "not_run"]


@pytest.fixture
def forked_workers(monkeypatch: pytest.MonkeyPatch) -> None:
    """Local workers started by fork, so that they inherit the test's monkeypatches."""
    import multiprocessing

    if "fork" not in multiprocessing.get_all_start_methods():
        pytest.skip("needs the fork start method")
    monkeypatch.setattr(executors, "start_context", lambda: multiprocessing.get_context("fork"))


# Python >= 3.12 warns when forking while threads run (an idle Dask thread may linger from
# the cluster test): these tests fork on purpose, to share their monkeypatches
FORK_WITH_THREADS = "ignore:This process .* is multi-threaded:DeprecationWarning"


@pytest.mark.filterwarnings(FORK_WITH_THREADS)
def test_a_dying_worker_fails_its_cases_and_loses_none(tmp_path: Path, forked_workers,
                                                       monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    def dies_on_200(scenario, progress=False, shapes=True, channels=None):
        if scenario.chain.joints[0].to_rate_deg_s == 200.0:
            os._exit(1)  # as a worker killed by the out-of-memory killer
        return run_scenario(scenario, progress, shapes, channels)

    monkeypatch.setattr(flexlink.simulation, "run_scenario", dies_on_200)
    dataset = sweep(spin_file(tmp_path), grid={RATE: [100.0, 200.0, 300.0, 400.0]}, workers=2)
    status = dataset.status.values.tolist()
    assert status[1] == "failed" and "BrokenProcessPool" in str(dataset.error.values[1])
    assert set(status) <= {"ok", "failed"}  # every case accounted for, none silently lost
    for case in np.flatnonzero(dataset.status.values == "ok"):
        raw = read_toml(spin_file(tmp_path))
        raw["joints"][0]["motion"][0]["to_rate_deg_s"] = float(dataset[RATE][case])
        assert np.array_equal(dataset.tip.values[case], simulate(scenario_from_dict(raw))["tip"])


@pytest.mark.filterwarnings(FORK_WITH_THREADS)
def test_ctrl_c_ends_running_workers(tmp_path: Path, forked_workers,
                                     monkeypatch: pytest.MonkeyPatch) -> None:
    import os
    import signal

    pids = tmp_path / "pids"

    def interrupts_then_hangs(scenario, progress=False, shapes=True, channels=None):
        if scenario.chain.joints[0].to_rate_deg_s == 100.0:
            return run_scenario(scenario, progress, shapes, channels)
        with pids.open("a") as fh:
            fh.write(f"{os.getpid()}\n")
        os.kill(os.getppid(), signal.SIGINT)  # Ctrl-C reaches the sweep process
        signal.pause()  # a long case: must be ended, not waited for
        return None

    monkeypatch.setattr(flexlink.simulation, "run_scenario", interrupts_then_hangs)
    # A process started in the background by a non-interactive shell (as a CI runner may
    # start this suite) ignores SIGINT; Ctrl-C must raise KeyboardInterrupt here.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(SweepInterrupted) as excinfo:
            sweep(spin_file(tmp_path), grid={RATE: [100.0, 200.0]}, workers=2)
    finally:
        signal.signal(signal.SIGINT, previous)
    assert set(excinfo.value.dataset.status.values.tolist()) <= {"ok", "not_run"}
    for pid in map(int, pids.read_text().split()):
        assert _ended(pid), f"worker {pid} still runs after the sweep was interrupted"


def _ended(pid: int) -> bool:
    """Whether a process has exited (a zombie not yet reaped counts as exited), allowing a
    terminate signal up to 5 s to land."""
    import time

    stat = Path(f"/proc/{pid}/stat")
    if not Path("/proc/self/stat").exists():
        pytest.skip("needs /proc")
    for _ in range(100):
        try:
            state = stat.read_text().rsplit(")", 1)[1].split()[0]
        except (FileNotFoundError, ProcessLookupError):
            return True
        if state in ("Z", "X"):
            return True
        time.sleep(0.05)
    return False


@pytest.mark.slow
def test_the_python_example_of_docs_sweep_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    import re

    page = Path(__file__).resolve().parents[2] / "docs" / "sweep.md"
    block, = re.findall(r"```python\n(.*?)```", page.read_text(encoding="utf-8"), re.DOTALL)
    monkeypatch.chdir(tmp_path)
    exec(compile(block, str(page), "exec"), {"__name__": "docs_sweep_example"})  # noqa: S102
    means = [float(v) for v in re.findall(r"[0-9.]+(?:e[+-]?\d+)?", capsys.readouterr().out)]
    assert len(means) == 2 and all(m > 1.0 for m in means)  # peak accelerations, m/s²
    with xr.open_dataset(tmp_path / "sweep.nc") as written:
        assert written.sizes == {"case": 4, "time": 5001}


def test_conflicting_places_and_an_unwritable_output_fail_before_any_case_runs(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    def never(*args, **kwargs):
        raise AssertionError("a case ran")

    monkeypatch.setattr(flexlink.simulation, "run_scenario", never)
    with pytest.raises(SweepError, match="workers .* or scheduler .*, not both"):
        sweep(spin_file(tmp_path), grid={RATE: [100.0]}, workers=2, scheduler="tcp://x:1")
    blocker = tmp_path / "a_file"
    blocker.write_text("")
    status = main(["sweep", str(spin_file(tmp_path)), "--grid", f"{RATE}=100", "--workers", "1",
                   "-o", str(blocker / "out.nc")])
    # the option's check, naming the file in the way (not the OS's "[Errno 17] File exists")
    assert status == 2 and f"{blocker} is a file, not a folder" in capsys.readouterr().err


def test_a_sweep_file_defines_the_same_sweep_as_the_options(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from flexlink.batch import read_sweep_file

    spin_file(tmp_path)
    spec = tmp_path / "rates.toml"
    spec.write_text('base = "spin.toml"\nsamples = 2\nseed = 4\nchannels = ["tip"]\n\n'
                    '[grid]\n"links[0].modes" = [1, 2]\n\n'
                    f'[random]\n"{RATE}" = "uniform:50:150"\n', encoding="utf-8")
    assert main(["sweep", "--spec", str(spec), "--workers", "1", "-q",
                 "-o", str(tmp_path / "a.nc")]) == 0
    assert main(["sweep", str(tmp_path / "spin.toml"), "--grid", "links[0].modes=1,2",
                 "--random", f"{RATE}=uniform:50:150", "--samples", "2", "--seed", "4",
                 "--channels", "tip", "--workers", "1", "-q", "-o", str(tmp_path / "b.nc")]) == 0
    with xr.open_dataset(tmp_path / "a.nc") as a, xr.open_dataset(tmp_path / "b.nc") as b:
        timings = ["wall_time", "cpu_time"]
        xr.testing.assert_identical(a.drop_vars(timings).drop_attrs(),
                                    b.drop_vars(timings).drop_attrs())
        assert a.sizes["case"] == 4 and next(iter(a.data_vars)) == "tip"
    assert read_sweep_file(spec)["base"] == tmp_path / "spin.toml"
    capsys.readouterr()
    spec.write_text('bse = "spin.toml"\nsampler = "sobol"\n[grid]\n"links[0].EI" = "1,x"\n',
                    encoding="utf-8")
    assert main(["sweep", "--spec", str(spec)]) == 2
    err = capsys.readouterr().err
    assert "unknown key 'bse' (did you mean 'base'?)" in err
    assert "sweep.sampler must be one of 'random', 'lhs'" in err
    assert "grid links[0].EI: expected a number, got 'x'" in err


def test_the_sweep_key_scenario_is_pointed_to_base(tmp_path: Path) -> None:
    """`scenario = "arm.toml"` in a sweep file (the scenario swept is its `base`) got
    "allowed: base, samples, …" with no suggestion: spelled nothing like it."""
    from flexlink.batch.spec import read_sweep_file

    spec = tmp_path / "sweep.toml"
    spec.write_text('scenario = "arm.toml"\nsamples = 2\n', encoding="utf-8")
    with pytest.raises(SweepError, match=r"unknown key 'scenario' \(did you mean 'base'\?\)"):
        read_sweep_file(spec)


@pytest.mark.filterwarnings(FORK_WITH_THREADS)
def test_forked_workers_write_through_the_shared_array_bit_for_bit(
        tmp_path: Path, forked_workers, monkeypatch: pytest.MonkeyPatch) -> None:
    from flexlink.batch.dataset import SweepCollector

    sent_back: list[bool] = []
    add = SweepCollector.add

    def spy(self, chunk):
        sent_back.extend(block is not None for block in chunk.values)
        add(self, chunk)

    monkeypatch.setattr(SweepCollector, "add", spy)
    rates = [100.0, 200.0, 300.0]
    dataset = sweep(spin_file(tmp_path), grid={RATE: rates}, workers=2)
    assert sent_back == [False] * 3  # every result went through the shared array
    for case, rate in enumerate(rates):
        raw = read_toml(spin_file(tmp_path))
        raw["joints"][0]["motion"][0]["to_rate_deg_s"] = rate
        reference = simulate(scenario_from_dict(raw))
        for name in reference.names:
            assert np.array_equal(dataset[name].values[case], reference[name])


def test_rows_of_unfinished_cases_read_as_nan_while_workers_may_write() -> None:
    from flexlink.batch.dataset import SweepCollector
    from flexlink.batch.parameters import case_table, grid_values
    from flexlink.batch.worker import ChunkResult, SharedResults
    from flexlink.channels import Channel, ChannelKind

    channels = (Channel("a", ChannelKind.SENSOR, "m", "first"),
                Channel("b", ChannelKind.SENSOR, "s", "second"))
    shared = SharedResults.allocate(channels, 3, 4)
    collector = SweepCollector(case_table([grid_values("x.y", [1, 2, 3])]), np.arange(4.0),
                               {}, shared, channels)
    shared.array[:, 0, :] = 1.0  # case 0: written by a worker, result received
    collector.add(ChunkResult(channels, done=[0], values=[None], wall_times=[0.1],
                              cpu_times=[0.1]))
    shared.array[:, 2, :] = 7.0  # case 2: written, its result not yet received
    running = collector.dataset()
    assert running.status.values.tolist() == ["ok", "not_run", "not_run"]
    assert np.all(running.a.values[0] == 1.0) and np.all(np.isnan(running.a.values[1:]))
    assert np.all(shared.array[:, 2, :] == 7.0)  # not cleared under a writing worker
    collector.settle()  # workers stopped
    assert np.all(np.isnan(shared.array[:, 2, :]))
    np.testing.assert_array_equal(collector.dataset().b.values,
                                  [[1.0] * 4, [np.nan] * 4, [np.nan] * 4])


@pytest.mark.filterwarnings(FORK_WITH_THREADS)
def test_workers_load_the_compiled_code_while_the_cases_are_checked(
        tmp_path: Path, forked_workers, monkeypatch: pytest.MonkeyPatch) -> None:
    import os

    from flexlink.batch import cases, worker

    log = tmp_path / "log"

    def loading(scenario) -> None:
        with log.open("a") as fh:
            fh.write(f"load {scenario.chain.links[0].name} {os.getpid()}\n")

    checked = cases.valid_cases

    def checking(base, table, *lazy):
        with log.open("a") as fh:  # the workers were started before the checks
            fh.write("check\n")
        return checked(base, table, *lazy)

    monkeypatch.setattr(worker, "load_compiled_code", loading)
    monkeypatch.setattr(cases, "valid_cases", checking)
    dataset = sweep(spin_file(tmp_path), grid={RATE: [100.0, 200.0, 300.0]}, workers=2)
    assert (dataset.status.values == "ok").all()
    lines = log.read_text().splitlines()
    loads = [line for line in lines if line.startswith("load")]
    assert "check" in lines and len(loads) == 2  # one load per worker, none per case
    assert {line.split()[1] for line in loads} == {"arm"}
    assert len({line.split()[2] for line in loads}) == 2 and str(os.getpid()) not in lines[0]


@pytest.mark.filterwarnings(FORK_WITH_THREADS)
def test_forked_workers_inherit_the_compiled_code_loaded_once_before_the_fork(
        tmp_path: Path, forked_workers, monkeypatch: pytest.MonkeyPatch) -> None:
    """The sweep process loads the compiled code once, before it forks: the workers inherit
    it instead of each loading numba and the cached kernels again."""
    import multiprocessing
    import os

    log = tmp_path / "log"
    loaded = executors.load_compiled_code

    def loading(scenario) -> None:
        with log.open("a") as fh:
            fh.write(f"{os.getpid()} {len(multiprocessing.active_children())}\n")
        loaded(scenario)

    monkeypatch.setattr(executors, "load_compiled_code", loading)
    dataset = sweep(spin_file(tmp_path), grid={RATE: [100.0, 200.0]}, workers=2)
    assert (dataset.status.values == "ok").all()
    # once, in this process, while it had no worker yet
    assert log.read_text().split() == [str(os.getpid()), "0"]


def test_a_refused_sweep_ends_the_workers_it_started(tmp_path: Path) -> None:
    import multiprocessing

    with pytest.raises(SweepError, match="length must be > 0"):
        sweep(spin_file(tmp_path), grid={"links[0].length": [0.6, -1.0]}, workers=2)
    assert multiprocessing.active_children() == []


@pytest.mark.filterwarnings(FORK_WITH_THREADS)
def test_workers_check_the_cases_as_this_process_would(tmp_path: Path, forked_workers) -> None:
    """A sweep without histories has its cases checked by its workers, on slices of the case
    table, before any runs: the same problems in the same order as checked here, the same
    refusal, and with skip_invalid the same cases recorded as failed."""
    from flexlink.batch.cases import check_paths, check_rows, load_base
    from flexlink.batch.parameters import case_table, grid_values

    lengths = [0.6, -1.0, 0.5, 0.0, 0.7, -2.0, 0.6, 0.55, -0.1]
    base = load_base(spin_file(tmp_path))
    table = case_table([grid_values("links[0].length", lengths)])
    paths = check_paths(base, table)
    here = check_rows(base, table, paths)
    pool = executors.local_processes(2)
    try:
        assert pool.forked
        workers = pool.check_cases(base, table, paths)
    finally:
        pool.close()
    # lengths ≤ 0, and the tip sensor (x = 0.6 m) beyond a shorter link
    assert list(workers) == list(here) == [1, 2, 3, 5, 7, 8] and workers == here
    grid = {"links[0].length": lengths}
    summaries = ["peak:tip"]
    messages = []
    for count in (1, 2):
        with pytest.raises(SweepError) as refused:
            sweep(spin_file(tmp_path), grid=grid, summaries=summaries, histories=False,
                  workers=count)
        messages.append(str(refused.value))
    assert messages[0] == messages[1] and "length must be > 0" in messages[0]
    one, two = (sweep(spin_file(tmp_path), grid=grid, summaries=summaries, histories=False,
                      workers=count, skip_invalid=True) for count in (1, 2))
    assert two.status.values.tolist() == one.status.values.tolist()
    assert two.error.values.tolist() == one.error.values.tolist()
    np.testing.assert_array_equal(two.peak_tip.values, one.peak_tip.values)


def test_load_compiled_code_readies_the_prescribed_kernels() -> None:
    from flexlink.batch.worker import load_compiled_code
    from flexlink.solvers import _lawson_numba

    load_compiled_code(flexlink.load_paper_experiment())
    assert _lawson_numba.SIGNATURE in [tuple(s) for s in _lawson_numba.lawson_blocks.signatures]


def test_a_sweep_without_histories_holds_case_indices_and_a_few_chunks_at_a_time(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """10⁵ cases in bounded memory: the valid cases are kept as indices (each `LazyCase`
    made when its chunk is sent) and only a few chunks per worker are queued at once."""
    from concurrent.futures import ThreadPoolExecutor

    from flexlink.batch.cases import LazyCases, load_base, valid_cases
    from flexlink.batch.parameters import case_table, grid_values
    from flexlink.batch.worker import ChunkResult, Kept, LazyCase

    base = load_base(paper_experiment_path())
    table = case_table([grid_values("sensors[0].x", [1.0, 1.5, 1.2, 0.5])])  # 1.5 > 1.37 m
    cases, invalid = valid_cases(base, table, lazy=True)
    assert isinstance(cases, LazyCases) and list(cases) == [0, 2, 3] and list(invalid) == [1]
    assert cases.indexed()[1] == (2, LazyCase(base, {("sensors", 0, "x"): 1.2}))
    assert cases[2].build().sensors[0].x == 1.2
    with pytest.raises(KeyError):
        cases[1]

    def counting(chunk, kept):
        return ChunkResult(done=[i for i, _ in chunk])

    monkeypatch.setattr(executors, "run_chunk", counting)
    made: list[int] = []

    def chunks():
        for k in range(50):
            made.append(k)
            yield [(k, None)]

    pool = ThreadPoolExecutor(max_workers=2)
    results = executors.PoolResults(pool, workers=2)
    results.submit(chunks(), Kept())
    assert len(made) == results.window < 50  # not every chunk queued up front
    done = []
    for result in results:
        assert len(results.futures) <= results.window
        done += result.done
    pool.shutdown()
    assert sorted(done) == list(range(50))
    chunked = executors.make_chunks(cases.indexed(), workers=1)
    assert [[i for i, _ in chunk] for chunk in chunked] == [[0], [2], [3]]


def test_a_real_field_swept_over_integers_is_stored_as_float(tmp_path: Path) -> None:
    """--grid links[0].EI=300,310 stored EI as int32 (netCDF) and int64 (MATLAB), where
    EI / 3 is integer arithmetic; an integer field (modes) stays integer."""
    from scipy.io import loadmat

    raw = short_paper()
    raw["simulation"]["t_end"] = 0.02
    grid = {"links[0].EI": [300, 310], "links[1].modes": [1, 2]}
    for out in (tmp_path / "s.nc", tmp_path / "s.mat"):
        sweep(raw, grid=grid, workers=1, output=out)
    with xr.open_dataset(tmp_path / "s.nc") as written:
        assert written["links[0].EI"].dtype == np.float64
        assert written["links[1].modes"].dtype.kind == "i"
    mat = loadmat(tmp_path / "s.mat")
    assert mat["links_0_EI"].dtype == np.float64 and mat["links_1_modes"].dtype.kind == "i"
