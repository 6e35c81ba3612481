"""The flexlink command: exit codes, messages, output folders, agreement with the library."""

from __future__ import annotations

import os
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import flexlink.simulation
from flexlink.channels.catalogue import catalogue
from flexlink.cli import main
from flexlink.errors import SimulationError
from flexlink.model import Scenario
from flexlink.results import Results
from flexlink.scenario import load_scenario, paper_experiment_path

SHORT = """\
[simulation]
name = "short"
t_end = 0.2
dt_out = 0.02

[[links]]
name = "arm"
length = 0.6
mass_per_length = 0.0636
E = 70e9
width = 0.028
thickness = 0.001
modes = 1
damping_ratio = 0.01

[[joints]]
motion = [{ profile = "cycloidal", from_deg = 0.0, to_deg = 20.0, start = 0.0, duration = 0.2 }]

[[sensors]]
name = "tip"
kind = "deflection"
link = "arm"
x = 0.6
"""

BAD = """\
[simulation]
t_end = "5"
dt_out = 0.01

[[links]]
name = "arm"
lenght = 0.6
mass_per_length = 0.0636
EI = -3.0

[[joints]]
motion = [{ profile = "sine" }]
"""


def write(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def fake_simulate(scenario: Scenario, progress: bool = False) -> Results:
    """Instant stand-in for simulate(): the channels it promises, with zero motion."""
    t = np.arange(0.0, scenario.settings.t_end + 1e-12, scenario.settings.dt_out)
    results = Results(time=t)
    for channel in catalogue(scenario):
        results.add(channel, np.zeros_like(t))
    return results


@pytest.fixture
def fake(monkeypatch: pytest.MonkeyPatch) -> list[Scenario]:
    """Replace simulate() by fake_simulate() and record the scenarios it was given."""
    seen: list[Scenario] = []

    def record(scenario: Scenario, progress: bool = False) -> Results:
        seen.append(scenario)
        return fake_simulate(scenario, progress)

    monkeypatch.setattr(flexlink.simulation, "simulate", record)
    return seen


def test_version_and_help(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0 and capsys.readouterr().out.startswith("flexlink ")
    with pytest.raises(SystemExit) as info:
        main(["--help"])
    out = capsys.readouterr().out
    assert info.value.code == 0 and "run" in out and "show-paper" in out


def test_show_paper_prints_the_builtin_file(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["show-paper"]) == 0
    out = capsys.readouterr().out
    assert out == paper_experiment_path().read_text(encoding="utf-8")
    assert tomllib.loads(out)["simulation"]["name"] == "paper-experiment"


def test_real_short_run_writes_what_the_library_returns(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    returned: list[Results] = []
    real_simulate = flexlink.simulation.simulate

    def spy(scenario: Scenario, progress: bool = False) -> Results:
        returned.append(real_simulate(scenario, progress=progress))
        return returned[-1]

    monkeypatch.setattr(flexlink.simulation, "simulate", spy)
    scenario_file, out = write(tmp_path, SHORT), tmp_path / "out"
    assert main(["run", str(scenario_file), "-o", str(out), "--no-figures"]) == 0
    summary = capsys.readouterr().out
    assert "tip" in summary and "joint1_angle" in summary and str(out) in summary
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    assert header == ["t", "tip", "joint1_angle", "joint1_torque", "arm_tip_X", "arm_tip_Y"]
    table = np.loadtxt(out / "results.csv", delimiter=",", skiprows=1)
    (direct,) = returned
    np.testing.assert_allclose(table[:, 0], direct.time, atol=1e-12)
    assert direct.time[-1] == pytest.approx(0.2)
    np.testing.assert_allclose(table[:, 1:], np.column_stack([direct[n] for n in header[1:]]),
                               rtol=1e-9, atol=1e-15)
    assert np.degrees(table[-1, 2]) == pytest.approx(20.0)
    assert load_scenario(out / "scenario.resolved.toml") == load_scenario(scenario_file)


def test_invalid_scenario_lists_every_problem(tmp_path: Path, fake: list[Scenario],
                                              capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    assert main(["run", str(write(tmp_path, BAD)), "-o", str(out)]) == 2
    captured = capsys.readouterr()
    err = captured.err.splitlines()
    assert err[0].endswith("has 5 problems:")
    assert "  - simulation.t_end: expected a number, got string '5'" in err
    assert "  - links[0]: unknown key 'lenght' (did you mean 'length'?)" in err
    assert "  - links[0].EI must be > 0 N·m², got -3.0" in err
    assert "Traceback" not in captured.err and captured.out == ""
    assert not out.exists() and fake == []


@pytest.mark.parametrize("text", [None, "[simulation\nt_end = 1"])
def test_missing_or_broken_file(tmp_path: Path, fake: list[Scenario], text: str | None,
                                capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "s.toml" if text is None else write(tmp_path, text)
    assert main(["run", str(path), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert ("file not found" if text is None else "TOML syntax error") in err
    assert "line 1" in err or text is None
    assert not (tmp_path / "out").exists()


def test_non_empty_output_is_refused_before_simulating(
        tmp_path: Path, fake: list[Scenario], capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    assert main(["run", str(write(tmp_path, SHORT)), "-o", str(out)]) == 2
    assert "already exists and is not empty" in capsys.readouterr().err
    assert fake == [] and sorted(p.name for p in out.iterdir()) == ["keep.txt"]


def test_overwrite_an_earlier_run(tmp_path: Path, fake: list[Scenario]) -> None:
    scenario_file, out = write(tmp_path, SHORT), tmp_path / "out"
    assert main(["run", str(scenario_file), "-o", str(out), "-q", "--no-figures"]) == 0
    assert main(["run", str(scenario_file), "-o", str(out), "-q"]) == 2
    assert main(["run", str(scenario_file), "-o", str(out), "-q", "--overwrite"]) == 0
    assert len(fake) == 2 and (out / "figures" / "tip_paths.png").is_file()


def test_simulation_failure_exits_1_without_folder(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    def diverge(scenario: Scenario, progress: bool = False) -> Results:
        raise SimulationError("step size too small at t = 0.1 s")

    monkeypatch.setattr(flexlink.simulation, "simulate", diverge)
    out = tmp_path / "out"
    assert main(["run", str(write(tmp_path, SHORT)), "-o", str(out)]) == 1
    assert "simulation failed: step size too small" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == [tmp_path / "s.toml"]


@pytest.mark.parametrize("argv", [["paper"], ["run", "--paper"]])
def test_paper_commands_use_the_builtin_scenario(
        argv: list[str], tmp_path: Path, fake: list[Scenario],
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.chdir(tmp_path)
    assert main([*argv, "--no-figures", "--quiet"]) == 0
    assert capsys.readouterr().out.strip() == "paper_results"
    assert fake[0] == load_scenario(paper_experiment_path())
    resolved = tomllib.loads((tmp_path / "paper_results" / "scenario.resolved.toml").read_text())
    assert resolved["simulation"]["name"] == "paper-experiment"


def test_run_needs_exactly_one_source(tmp_path: Path,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    for argv in (["run"], ["run", str(write(tmp_path, SHORT)), "--paper"]):
        with pytest.raises(SystemExit) as info:
            main(argv)
        assert info.value.code == 2
        assert "give a scenario file or --paper" in capsys.readouterr().err


def test_default_output_folder_is_named_after_the_scenario(
        tmp_path: Path, fake: list[Scenario], monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    assert main(["run", str(write(tmp_path, SHORT, "arm.toml")), "-q", "--no-figures"]) == 0
    assert (tmp_path / "arm_results" / "results.csv").is_file()


def test_summary_says_which_model_ran_and_warns_past_its_validity(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    gentle = write(tmp_path, SHORT.replace("to_deg = 20.0", "to_deg = 5.0"))
    assert main(["run", str(gentle), "-o", str(tmp_path / "a"), "--no-figures"]) == 0
    out = capsys.readouterr().out
    assert "model: first-order (geometrically stiffened), prescribed joints" in out
    assert "peak tip deflection" in out and "warning" not in out
    paper = write(tmp_path, SHORT.replace("to_deg = 20.0", "to_deg = 5.0")
                  .replace('name = "short"', 'name = "short"\ngeometric_stiffening = false'),
                  "paper.toml")
    assert main(["run", str(paper), "-o", str(tmp_path / "p"), "--no-figures"]) == 0
    out = capsys.readouterr().out
    assert "model: first-order (the paper's, without geometric stiffening), prescribed joints" in out
    # the same arm swung through 40° in 0.2 s: its tip deflects over a third of its length
    fast = write(tmp_path, SHORT.replace("to_deg = 20.0", "to_deg = 40.0"), "fast.toml")
    assert main(["run", str(fast), "-o", str(tmp_path / "b"), "--no-figures"]) == 0
    out = capsys.readouterr().out
    assert "(geometrically stiffened)" in out
    assert "warning: the tip of arm deflected" in out and 'model = "nonlinear"' in out


def test_a_run_too_large_for_memory_is_an_input_error(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    huge = write(tmp_path, SHORT.replace("dt_out = 0.02", "dt_out = 1e-10"))
    assert main(["run", str(huge), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("error: simulation.dt_out: this run needs") and "coarser fits" in err
    assert not (tmp_path / "out").exists()


def test_only_the_command_itself_skips_the_final_garbage_collection(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """main() of the command pauses the collector for its start-up and freezes the heap (its
    process exits next), and leaves the collector running; main(argv) of a caller that goes
    on changes neither."""
    import gc

    gc.unfreeze()
    assert main(["show-paper"]) == 0
    assert gc.get_freeze_count() == 0 and gc.isenabled()
    for args in (["show-paper"], ["run", "no-such-file.toml", "--no-figures"]):
        monkeypatch.setattr(sys, "argv", ["flexlink", *args])
        try:
            assert main() == (0 if args == ["show-paper"] else 2)
            assert gc.get_freeze_count() > 0 and gc.isenabled()
        finally:
            gc.unfreeze()
    assert "[simulation]" in capsys.readouterr().out


def test_the_program_exits_without_teardown_but_flushes_and_runs_exit_functions(
        tmp_path: Path) -> None:
    """`command` (python -m flexlink, the installed script) ends the process with os._exit
    after flushing stdout and stderr and running the atexit functions; its status is main's."""
    import subprocess

    script = ("import atexit, sys\n"
              "atexit.register(lambda: print('exit functions ran'))\n"
              "from flexlink.cli import command\n"
              "sys.argv = ['flexlink', *sys.argv[1:]]\n"
              "command()\n"
              "print('never here')\n")
    env = {**os.environ,
           "PYTHONPATH": str(Path(flexlink.simulation.__file__).parents[2])}
    shown = subprocess.run([sys.executable, "-c", script, "show-paper"], capture_output=True,
                           text=True, env=env, check=False)
    assert shown.returncode == 0
    assert shown.stdout.endswith(paper_experiment_path().read_text(encoding="utf-8")
                                 + "exit functions ran\n")
    assert "never here" not in shown.stdout
    missing = subprocess.run([sys.executable, "-c", script, "run", str(tmp_path / "no.toml"),
                              "--no-figures"], capture_output=True, text=True, env=env,
                             check=False)
    assert missing.returncode == 2 and missing.stderr and "exit functions ran" in missing.stdout


def test_withheld_imports_fail_inside_the_block_only(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """withheld_imports makes a module not yet imported unimportable within the block (as an
    optional import sees a missing package), leaves imported ones alone, and restores both."""
    from flexlink import cli

    (tmp_path / "flexlink_test_optional.py").write_text("VALUE = 1\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "flexlink_test_optional", raising=False)
    with cli.withheld_imports(["flexlink_test_optional", "math"]) as held:
        assert held == ["flexlink_test_optional"]
        with pytest.raises(ImportError):
            import flexlink_test_optional
        import math  # already imported: untouched

        assert math.pi > 3
    import flexlink_test_optional

    assert flexlink_test_optional.VALUE == 1
    monkeypatch.delitem(sys.modules, "flexlink_test_optional")


def test_only_the_command_withholds_optional_imports(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The command's process withholds WITHHELD_IMPORTS, yaml only without a numba config
    file in the current folder (numba reads it with yaml); main(argv) withholds nothing."""
    from flexlink import cli

    monkeypatch.chdir(tmp_path)
    assert cli._optional_imports() == ()
    monkeypatch.setitem(cli._start_up, "command", True)
    assert cli._optional_imports() == cli.WITHHELD_IMPORTS
    (tmp_path / cli.NUMBA_CONFIG_FILE).write_text("")
    assert "yaml" not in cli._optional_imports()
    assert set(cli._optional_imports()) == set(cli.WITHHELD_IMPORTS) - {"yaml"}


def test_run_commands_start_blas_with_one_thread_unless_the_user_chose(
        monkeypatch: pytest.MonkeyPatch) -> None:
    """The command's own process of run/paper sets OPENBLAS_NUM_THREADS=1 before numpy loads,
    unless a BLAS thread variable is set; other commands, or numpy already loaded: nothing."""
    from flexlink import cli

    for name in cli.BLAS_THREAD_VARIABLES:
        monkeypatch.delenv(name, raising=False)
    cli._one_blas_thread(["run", "--paper"])  # numpy is loaded in this process: too late
    assert "OPENBLAS_NUM_THREADS" not in os.environ
    monkeypatch.delitem(sys.modules, "numpy")
    for args in (["sweep", "x.toml"], ["show-paper"], []):
        cli._one_blas_thread(args)
        assert "OPENBLAS_NUM_THREADS" not in os.environ
    monkeypatch.setenv("OMP_NUM_THREADS", "2")
    cli._one_blas_thread(["paper"])
    assert "OPENBLAS_NUM_THREADS" not in os.environ
    monkeypatch.delenv("OMP_NUM_THREADS")
    cli._one_blas_thread(["run", "a.toml"])
    assert os.environ["OPENBLAS_NUM_THREADS"] == "1"
    monkeypatch.delenv("OPENBLAS_NUM_THREADS")


def test_summary_names_the_mode_basis_and_warns_when_it_is_far_from_converged(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    loaded = SHORT.replace("modes = 1", "modes = 4\ntip_inertia = 0.002")
    assert main(["run", str(write(tmp_path, loaded)), "-o", str(tmp_path / "a"),
                 "--no-figures", "--no-report"]) == 0
    out = capsys.readouterr().out
    assert "modes: arm tip_loaded ×4; the highest frequency at t = 0" in out
    assert "warning: mode basis" not in out
    resolved = tomllib.loads((tmp_path / "a" / "scenario.resolved.toml").read_text())
    assert resolved["links"][0]["mode_shapes"] == "tip_loaded"
    cantilever = loaded.replace("modes = 4", 'modes = 4\nmode_shapes = "clamped_free"')
    assert main(["run", str(write(tmp_path, cantilever, "c.toml")), "-o", str(tmp_path / "b"),
                 "--no-figures", "--no-report"]) == 0
    out = capsys.readouterr().out
    assert "warning: mode basis (arm clamped_free ×4):" in out and "estimated" in out
    from flexlink.results.reading import read_run

    assert "mode basis (arm clamped_free ×4)" in \
        read_run(tmp_path / "b").metadata["mode_convergence_warning"]


# Every command with options, as (positional arguments, options each with its value); the
# parse must not depend on where the options stand among the positional arguments.
COMMAND_LINES = {
    "run": (["s.toml"], [["-o", "out"], ["--no-figures"], ["-q"]]),
    "sweep": (["s.toml"], [["--grid", "links[0].EI=1,2"], ["-o", "s.nc"], ["--workers", "1"]]),
    "compare": (["s.toml", "m.csv"], [["--map", "b=joint1"], ["-o", "out"], ["--no-hold"]]),
    "fit": (["s.toml", "m.csv"], [["-p", "links[0].EI"], ["--time-offset", "-0.5"],
                                  ["-o", "out"]]),
    "optimize": (["s.toml"], [["-o", "out"], ["--rate-limit", "90"], ["--no-figures"]]),
    "linearize": (["s.toml"], [["--at", "joint1=-5"], ["-o", "out"], ["-q"]]),
    "modes": (["s.toml"], [["--times", "0:1:0.5"], ["-o", "out"], ["--count", "3"]]),
    "animate": (["run_dir"], [["-o", "a.gif"], ["--fps", "5"], ["--magnify", "2"]]),
    "report": (["run_dir"], [["--animate"]]),
}


def _orders(positionals: list[str], options: list[list[str]]) -> list[list[str]]:
    """The options before, between and after the positional arguments, in turn."""
    orders = []
    for at in range(len(positionals) + 1):
        for option in options:
            others = [token for o in options if o is not option for token in o]
            orders.append([*positionals[:at], *option, *positionals[at:], *others])
    return orders


@pytest.mark.parametrize("command", sorted(COMMAND_LINES))
def test_options_and_positional_arguments_in_any_order(command: str) -> None:
    """`flexlink fit S.toml -p X M.csv` was refused (argparse takes an optional second
    positional only right after the first): every command parses every order alike."""
    from flexlink.cli import build_parser

    positionals, options = COMMAND_LINES[command]

    parser = build_parser()

    def parsed(tokens: list[str]) -> dict[str, object]:
        return vars(parser.parse_args([command, *tokens]))

    expected = parsed([*positionals, *[t for o in options for t in o]])
    assert all(expected[k] is not None for k in ("scenario", "measured") if k in expected)
    for tokens in _orders(positionals, options):
        assert parsed(tokens) == expected, tokens


def test_an_unknown_option_is_reported_with_the_command_s_usage(
        capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as info:
        main(["fit", "s.toml", "--bogus", "m.csv"])
    err = capsys.readouterr().err
    assert info.value.code == 2
    assert "flexlink fit: error: unrecognized arguments: --bogus" in err
