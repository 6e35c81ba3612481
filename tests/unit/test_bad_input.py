"""A corpus of bad input to the commands, run as a user runs them (the ``flexlink`` entry
point with its output captured): each case is refused with exit status 2 (1 for a run that
failed), no traceback, a message that names the option, field or file, nothing left behind,
and no simulation started (the refusals come first)."""

from __future__ import annotations

import os
import shutil
import traceback
from pathlib import Path

import numpy as np
import pytest

from flexlink import simulation
from flexlink.cli import main
from flexlink.options import OptionError, check_writable
from flexlink.results.netcdf import read_netcdf, write_netcdf
from flexlink.scenario import paper_experiment_path, resolve_scenario_dict
from flexlink.scenario.toml_writer import dump_toml

PAPER = "scenario.toml"  # the paper arm, 0.5 s
MEASURED = "measured.toml"  # the same with a [measurement] section and measured.csv


def _paper(**simulation_keys: object) -> dict:
    d = resolve_scenario_dict(paper_experiment_path())
    d.pop("flexlink_version", None)
    d["simulation"].update({"t_end": 0.5, **simulation_keys})
    return d


def _driven(d: dict) -> dict:
    for joint in d["joints"]:
        joint.pop("motion")
        joint.update(drive="torque", torque=[{"profile": "bang_bang", "amplitude": 0.05,
                                              "start": 0.0, "duration": 0.2}])
    return d


def _scenarios() -> dict[str, dict]:
    """Scenario files of the corpus, by file name."""
    out = {PAPER: _paper()}
    fast = _paper()
    fast["actuators"] = [{"name": "patch", "kind": "piezo", "collocated_with": "pzt",
                          "limit": 100.0}]
    fast["controllers"] = [{"name": "ppf", "kind": "ppf", "sensor": "pzt", "actuator": "patch",
                            "frequency_hz": 2.5, "damping": 0.3, "gain": 10.0,
                            "sample_rate": 1e9}]
    out["sampled_1e9.toml"] = fast
    massless = _driven(_paper(model="nonlinear"))
    massless["base"] = {"type": "free", "mass": 0.0, "inertia": 0.0}
    out["massless_base_driven.toml"] = massless
    loaded = _paper(model="nonlinear")
    loaded["base"] = {"type": "free", "mass": 0.0, "inertia": 0.0, "loads": [
        {"moment": [{"profile": "bang_bang", "amplitude": 0.01, "start": 0.0,
                     "duration": 0.2}]}]}
    out["massless_base_loads.toml"] = loaded
    stiff = _driven(_paper(model="nonlinear"))
    stiff["links"][0]["EI"] = 1e9
    out["stiff_nonlinear_driven.toml"] = stiff
    out["long_driven.toml"] = _driven(_paper(t_end=1e5, geometric_stiffening=True))
    out["huge_t_end_driven.toml"] = _driven(_paper(t_end=1e9, dt_out=1e6))
    return out


@pytest.fixture(scope="module")
def inputs(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The corpus's input files: scenarios, a run folder of the paper arm (``run``) and its
    measured angles and PZT signal (``measured.csv``)."""
    folder = tmp_path_factory.mktemp("inputs")
    for name, d in _scenarios().items():
        (folder / name).write_text(dump_toml(d), encoding="utf-8")
    assert main(["run", str(folder / PAPER), "-o", str(folder / "run"), "--no-figures",
                 "--no-report", "-q"]) == 0
    names = (folder / "run" / "results.csv").read_text().splitlines()[0].split(",")
    table = np.loadtxt(folder / "run" / "results.csv", delimiter=",", skiprows=1)
    columns = [table[:, 0], *(np.degrees(table[:, names.index(f"joint{k}_angle")])
                              for k in (1, 2)), table[:, names.index("pzt")]]
    np.savetxt(folder / "measured.csv", np.column_stack(columns), delimiter=",",
               header="t,beta1,beta2,pzt_v", comments="", fmt="%.10g")
    (folder / MEASURED).write_text((folder / PAPER).read_text() + (
        '\n[measurement]\nfile = "measured.csv"\n'
        '[[measurement.columns]]\ncolumn = "beta1"\njoint = 1\nunit = "deg"\n'
        '[[measurement.columns]]\ncolumn = "beta2"\njoint = 2\nunit = "deg"\n'
        '[[measurement.columns]]\ncolumn = "pzt_v"\nsensor = "pzt"\n'
        '\n[[fit.parameters]]\npath = "links[1].EI"\n'), encoding="utf-8")
    return folder


def _damage(folder: Path, how: str) -> None:
    """Damage the run folder ``folder`` in the way ``how`` names."""
    nc = folder / "results.nc"
    if how == "random bytes":
        nc.write_bytes(np.random.default_rng(1).bytes(5000))
    elif how == "truncated":
        nc.write_bytes(nc.read_bytes()[: nc.stat().st_size // 2])
    elif how == "bad header":
        data = bytearray(nc.read_bytes())
        data[4:40] = b"\xff" * 36
        nc.write_bytes(bytes(data))
    elif how in ("no shapes", "half a shape", "time not increasing"):
        layout = read_netcdf(nc)
        if how == "no shapes":
            for name in [n for n in layout.data if "_shape_" in n]:
                del layout.data[name]
        elif how == "half a shape":
            del layout.data["link2_shape_Y"]
        else:
            layout.coords["time"].values[3] = np.nan
        write_netcdf(layout, nc)
    elif how == "csv only":
        nc.unlink()
    elif how == "csv only, truncated":
        nc.unlink()
        text = (folder / "results.csv").read_text()
        (folder / "results.csv").write_text(text[: len(text) // 2])
    elif how == "csv only, unknown kind":
        nc.unlink()
        (folder / "channels.csv").write_text("name,unit,kind\nfoo,m,bogus\n")
    else:
        raise AssertionError(how)


# (command line, exit status, text the message must hold). {in}: the inputs folder, {out}: a
# folder to write into (must stay empty), {run}: a copy of the run folder, damaged as the
# case's "damage" says.
CASES = {
    # output paths: under a regular file
    "linearize -o under a file": (["linearize", "{in}/scenario.toml", "-o", "{in}/run/results.csv/x"], 2, "is a file, not a folder"),
    "modes -o under a file": (["modes", "{in}/scenario.toml", "-o", "{in}/run/results.csv/x"], 2, "results.csv is a file"),
    "optimize -o under a file": (["optimize", "{in}/scenario.toml", "-o", "{in}/run/results.csv/x"], 2, "results.csv is a file"),
    "run -o under a file": (["run", "{in}/scenario.toml", "-o", "{in}/run/results.csv/x"], 2, "results.csv is a file"),
    "compare -o under a file": (["compare", "{in}/measured.toml", "-o", "{in}/run/results.csv/x"], 2, "results.csv is a file"),
    "fit -o under a file": (["fit", "{in}/measured.toml", "-o", "{in}/run/results.csv/x"], 2, "results.csv is a file"),
    "sweep -o under a file": (["sweep", "{in}/scenario.toml", "--grid", "links[0].EI=250", "-o", "{in}/run/results.csv/x.nc"], 2, "results.csv"),
    "animate -o under a file": (["animate", "{run}", "-o", "{in}/run/results.csv/a.gif"], 2, "results.csv is a file"),
    # sizes
    "modes --grid step 1e-6": (["modes", "{in}/scenario.toml", "--grid", "joint2=0:90:1e-6", "-o", "{out}"], 2, "--grid joint2 0:90:1e-6: 9e+07 points, more than the 2,000"),
    "modes --times step 1e-7": (["modes", "{in}/scenario.toml", "--times", "0:0.5:1e-7", "-o", "{out}"], 2, "--times 0:0.5:1e-7: 5,000,001 points, more than the 2,000"),
    "animate --fps 1e9": (["animate", "{run}", "--fps", "1e9", "-o", "{out}/a.gif"], 2, "fps = 1e+09"),
    "animate --speed 1e-12": (["animate", "{run}", "--speed", "1e-12", "-o", "{out}/a.gif"], 2, "frames"),
    "optimize --duration 1e5": (["optimize", "{in}/scenario.toml", "--duration", "1e5", "-o", "{out}"], 2, "--duration: 1e+08 output samples"),
    "controller sample_rate 1e9 (run)": (["run", "{in}/sampled_1e9.toml", "-o", "{out}"], 2, "controllers[0].sample_rate = 1e+09 Hz: 5e+08 samples"),
    "controller sample_rate 1e9 (linearize)": (["linearize", "{in}/sampled_1e9.toml", "-o", "{out}"], 2, "controllers[0].sample_rate"),
    "controller sample_rate 1e9 (modes)": (["modes", "{in}/sampled_1e9.toml", "-o", "{out}"], 2, "controllers[0].sample_rate"),
    "controller sample_rate 1e9 (optimize)": (["optimize", "{in}/sampled_1e9.toml", "-o", "{out}"], 2, "controllers[0].sample_rate"),
    # counts, ranges, non-finite numbers
    "fit --max-simulations 0": (["fit", "{in}/measured.toml", "--max-simulations", "0", "-o", "{out}"], 2, "--max-simulations must be an integer >= 3"),
    "fit --max-simulations -3": (["fit", "{in}/measured.toml", "--max-simulations", "-3", "-o", "{out}"], 2, "--max-simulations"),
    "optimize --workers -3": (["optimize", "{in}/scenario.toml", "--workers", "-3", "-o", "{out}"], 2, "argument --workers"),
    "optimize --workers 0": (["optimize", "{in}/scenario.toml", "--workers", "0", "-o", "{out}"], 2, "argument --workers"),
    "optimize --duration nan": (["optimize", "{in}/scenario.toml", "--duration", "nan", "-o", "{out}"], 2, "argument --duration"),
    "optimize --duration -1": (["optimize", "{in}/scenario.toml", "--duration", "-1", "-o", "{out}"], 2, "argument --duration"),
    "optimize --harmonics 0": (["optimize", "{in}/scenario.toml", "--harmonics", "0", "-o", "{out}"], 2, "argument --harmonics"),
    "optimize --harmonics 1000": (["optimize", "{in}/scenario.toml", "--harmonics", "1000", "-o", "{out}"], 2, "harmonics"),
    "optimize --robust nan": (["optimize", "{in}/scenario.toml", "--robust", "nan", "-o", "{out}"], 2, "argument --robust"),
    "optimize --seed -1": (["optimize", "{in}/scenario.toml", "--seed", "-1", "-o", "{out}"], 2, "argument --seed"),
    "optimize --rate-limit nan": (["optimize", "{in}/scenario.toml", "--rate-limit", "nan", "-o", "{out}"], 2, "rate"),
    "optimize --rate-limit three values": (["optimize", "{in}/scenario.toml", "--rate-limit", "1,2,3", "-o", "{out}"], 2, "rate"),
    "modes --count 0": (["modes", "{in}/scenario.toml", "--count", "0", "-o", "{out}"], 2, "argument --count"),
    "modes --count -1": (["modes", "{in}/scenario.toml", "--count", "-1", "-o", "{out}"], 2, "argument --count"),
    "modes --count 1.5": (["modes", "{in}/scenario.toml", "--count", "1.5", "-o", "{out}"], 2, "argument --count"),
    "modes --times nan": (["modes", "{in}/scenario.toml", "--times", "nan", "-o", "{out}"], 2, "--times 'nan'"),
    "modes --times to inf": (["modes", "{in}/scenario.toml", "--times", "0:inf:1", "-o", "{out}"], 2, "--times '0:inf:1'"),
    "modes --times outside the run": (["modes", "{in}/scenario.toml", "--times", "7", "-o", "{out}"], 2, "simulation.t_end"),
    "modes --times and --grid": (["modes", "{in}/scenario.toml", "--times", "0", "--grid", "joint2=0", "-o", "{out}"], 2, "--times or --grid"),
    "modes --grid unknown joint": (["modes", "{in}/scenario.toml", "--grid", "joint9=0:10:5", "-o", "{out}"], 2, "joint9"),
    "linearize --at nan": (["linearize", "{in}/scenario.toml", "--at", "nan", "-o", "{out}"], 2, "at = nan"),
    "linearize --at 1e9": (["linearize", "{in}/scenario.toml", "--at", "1e9", "-o", "{out}"], 2, "simulation.t_end"),
    "linearize --at unknown joint": (["linearize", "{in}/scenario.toml", "--at", "joint9=3", "-o", "{out}"], 2, "joint9"),
    "linearize --at inf angle": (["linearize", "{in}/scenario.toml", "--at", "joint2=inf", "-o", "{out}"], 2, "joint2"),
    "linearize --outputs unknown": (["linearize", "{in}/scenario.toml", "--outputs", "nosuch", "-o", "{out}"], 2, "nosuch"),
    "linearize --bode malformed": (["linearize", "{in}/scenario.toml", "--bode", "abc", "-o", "{out}"], 2, "--bode"),
    "animate --fps nan": (["animate", "{run}", "--fps", "nan", "-o", "{out}/a.gif"], 2, "fps must be a positive number"),
    "animate --fps 0": (["animate", "{run}", "--fps", "0", "-o", "{out}/a.gif"], 2, "fps must be a positive number"),
    "animate --trail inf": (["animate", "{run}", "--trail", "inf", "-o", "{out}/a.gif"], 2, "trail must be a finite number"),
    "animate --magnify -1": (["animate", "{run}", "--magnify", "-1", "-o", "{out}/a.gif"], 2, "magnification"),
    "animate --channels unknown": (["animate", "{run}", "--channels", "nosuch", "-o", "{out}/a.gif"], 2, "nosuch"),
    "animate -o a folder": (["animate", "{run}", "-o", "{out}"], 2, "is a folder; give a file name"),
    "animate -o unknown format": (["animate", "{run}", "-o", "{out}/a.avi"], 2, "unknown format 'avi'"),
    "fit --window nan": (["fit", "{in}/measured.toml", "--window", "nan:1", "-o", "{out}"], 2, "--window"),
    "fit --window reversed": (["fit", "{in}/measured.toml", "--window", "0.4:0.1", "-o", "{out}"], 2, "--window: the start must be before the end"),
    "fit --window outside the data": (["fit", "{in}/measured.toml", "--window", "1e9:2e9", "-o", "{out}"], 2, "outside the measured data"),
    "fit -p bounds reversed": (["fit", "{in}/measured.toml", "-p", "links[1].EI=5:1", "-o", "{out}"], 2, "links[1].EI"),
    "fit -p unknown link": (["fit", "{in}/measured.toml", "-p", "links[9].EI", "-o", "{out}"], 2, "links[9].EI"),
    "fit --time-offset nan": (["fit", "{in}/measured.toml", "--time-offset", "nan", "-o", "{out}"], 2, "argument --time-offset"),
    "compare --time-offset inf": (["compare", "{in}/measured.toml", "--time-offset", "inf", "-o", "{out}"], 2, "argument --time-offset"),
    "compare --free-from nan": (["compare", "{in}/measured.toml", "--free-from", "nan", "-o", "{out}"], 2, "argument --free-from"),
    "compare --free-from before the data": (["compare", "{in}/measured.toml", "--free-from", "-5", "-o", "{out}"], 2, "free_vibration_start (--free-from) = -5 s is outside the data"),
    "compare --free-from after the data": (["compare", "{in}/measured.toml", "--free-from", "1e9", "-o", "{out}"], 2, "--free-from"),
    # duplicates
    "linearize --at duplicate joint": (["linearize", "{in}/scenario.toml", "--at", "joint2=45,joint2=50", "-o", "{out}"], 2, "--at: 'joint2' is given twice"),
    "linearize --inputs duplicate": (["linearize", "{in}/scenario.toml", "--inputs", "a,a", "-o", "{out}"], 2, "--inputs: 'a' is given twice"),
    "modes --grid duplicate joint": (["modes", "{in}/scenario.toml", "--grid", "joint2=0:90:10;joint2=0:90:10", "-o", "{out}"], 2, "--grid: 'joint2' is given twice"),
    "fit -p duplicate": (["fit", "{in}/measured.toml", "-p", "links[1].EI", "-p", "links[1].EI", "-o", "{out}"], 2, "--param: 'links[1].EI' is given twice"),
    "fit --channel duplicate": (["fit", "{in}/measured.toml", "--channel", "pzt", "--channel", "pzt", "-o", "{out}"], 2, "--channel: 'pzt' is given twice"),
    "compare --map duplicate": (["compare", "{in}/measured.toml", "--map", "beta1=joint1", "--map", "beta1=joint1", "-o", "{out}"], 2, "--map: 'beta1' is given twice"),
    "animate --channels duplicate": (["animate", "{run}", "--channels", "pzt,pzt", "-o", "{out}/a.gif"], 2, "--channels: 'pzt' is given twice"),
    # missing and wrong-type files
    "linearize missing scenario": (["linearize", "{in}/nosuch.toml", "-o", "{out}"], 2, "nosuch.toml"),
    "modes scenario is a CSV file": (["modes", "{in}/measured.csv", "-o", "{out}"], 2, "measured.csv"),
    "optimize missing scenario": (["optimize", "{in}/nosuch.toml", "-o", "{out}"], 2, "nosuch.toml"),
    "compare missing measurement": (["compare", "{in}/measured.toml", "{in}/nosuch.csv", "-o", "{out}"], 2, "nosuch.csv"),
    "fit measurement is a netCDF file": (["fit", "{in}/measured.toml", "{in}/run/results.nc", "-o", "{out}"], 2, "results.nc"),
    "animate missing folder": (["animate", "{in}/nosuch", "-o", "{out}/a.gif"], 2, "nosuch"),
    "report missing folder": (["report", "{in}/nosuch"], 2, "nosuch"),
    "animate a CSV file as a sweep": (["animate", "{in}/measured.csv", "-o", "{out}/a.gif"], 2, "measured.csv"),
    "report a CSV file as a sweep": (["report", "{in}/measured.csv"], 2, "measured.csv"),
    # scenario fields the forward models read
    "free base without mass, driven joint": (["run", "{in}/massless_base_driven.toml", "-o", "{out}"], 2, "base.mass = 0 and base.inertia = 0 with joints[0] driven"),
    "free base without mass, loads, nonlinear": (["modes", "{in}/massless_base_loads.toml", "-o", "{out}"], 2, "base.mass = 0 and base.inertia = 0 with base.loads"),
    "nonlinear driven arm, EI = 1e9": (["run", "{in}/stiff_nonlinear_driven.toml", "-o", "{out}"], 2, "set rigid = true on links[0]"),
    "linearize a driven arm at 5e4 s": (["linearize", "{in}/long_driven.toml", "--at", "5e4", "-o", "{out}"], 2, "simulation.dt_out: the run up to t = 50000 s needs"),
    "modes over a driven arm's 1e5 s": (["modes", "{in}/long_driven.toml", "-o", "{out}"], 2, "simulation.dt_out: the run up to t = 100000 s needs"),
    "run a driven arm for 1e9 s, sampled every 1e6 s": (["run", "{in}/huge_t_end_driven.toml", "-o", "{out}"], 2, "simulation.t_end = 1e+09 s: this forward run tabulates its inputs in pieces of at most 0.25 s, 4e+09 pieces × at least 400 B = 1.6 TB of memory"),
}
CASES["animate: csv only"] = (["animate", "{run}", "-o", "{out}/a.gif"], 2,
                              "holds no link shapes")
CASES.update({
    "fit -p initial outside its bounds": (["fit", "{in}/measured.toml", "-p", "links[1].EI=1:5:50", "-o", "{out}"], 2, "the initial value 50 must lie within its bounds, 1 to 5"),
    "fit -p one field by index and name": (["fit", "{in}/measured.toml", "-p", "links[1].EI", "-p", "links[link2].EI", "-o", "{out}"], 2, "--param: 'links[1].EI' and 'links[link2].EI' are the same field"),
    "optimize --torque-limit 0": (["optimize", "{in}/scenario.toml", "--torque-limit", "1,0", "-o", "{out}"], 2, "torque_Nm of joint 2 must be > 0, got 0: a limit ≤ 0 allows no move (--torque-limit on the command line)"),
    "optimize --rate-limit count": (["optimize", "{in}/scenario.toml", "--rate-limit", "1,2,3", "-o", "{out}"], 2, "rate_deg_s: give one limit for all joints or one per joint (2), got 3 (--rate-limit on the command line)"),
    "compare --time-offset after the data's start": (["compare", "{in}/measured.toml", "--time-offset", "0.2", "-o", "{out}"], 2, "the data start at t = 0.2 s on the simulation clock, but the simulation starts at 0 s; set time_offset = 0 (s)"),
    "compare --time-offset past the data's end": (["compare", "{in}/measured.toml", "--time-offset", "-100", "-o", "{out}"], 2, "the data end at t = -99.5 s on the simulation clock, before the simulation starts at 0 s; set time_offset = 0 (s)"),
    "modes --times names the option": (["modes", "{in}/scenario.toml", "--times", "0,7", "-o", "{out}"], 2, "times (--times): 7.0 s is outside the run [0, 0.5] s"),
    "fit --window past the data": (["fit", "{in}/measured.toml", "--window", "0.1:30", "-o", "{out}"], 2, "fit window end 30 s is past the measured data"),
})
DAMAGES = ("random bytes", "truncated", "bad header", "no shapes", "half a shape",
           "time not increasing", "csv only, truncated", "csv only, unknown kind")
for _how in DAMAGES:
    _file = "channels.csv" if "kind" in _how else "results.csv" if "csv" in _how else "results.nc"
    if _how not in ("no shapes", "half a shape", "csv only, truncated", "csv only, unknown kind"):
        CASES[f"report: {_how}"] = (["report", "{run}"], 2, _file)
    CASES[f"animate: {_how}"] = (["animate", "{run}", "-o", "{out}/a.gif"], 2, _file)


def _no_simulation(*args: object, **kwargs: object) -> None:
    raise AssertionError("a simulation started before the input was refused")


@pytest.mark.parametrize("name", list(CASES))
def test_bad_input_is_refused_with_a_message_and_leaves_nothing(
        name: str, inputs: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str],
        monkeypatch: pytest.MonkeyPatch) -> None:
    argv, status, expected = CASES[name]
    run = tmp_path / "run"
    shutil.copytree(inputs / "run", run)
    damage = name.split(": ", 1)[1] if name.startswith(("report: ", "animate: ")) else None
    if damage:
        _damage(run, damage)
    out = tmp_path / "out"
    out.mkdir()
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(simulation, "path_function", _no_simulation)
    inputs_before = sorted(p.relative_to(inputs) for p in inputs.rglob("*"))
    run_before = sorted(p.relative_to(run) for p in run.rglob("*"))
    argv = [a.format(**{"in": inputs, "out": out, "run": run}) for a in argv]
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse's usage errors
        code = exc.code
    except Exception:  # noqa: BLE001 — the test's point: report it as the user would see it
        pytest.fail(f"traceback:\n{traceback.format_exc()}")
    captured = capsys.readouterr()
    text = captured.out + captured.err
    assert code == status, text
    assert "Traceback" not in text
    assert expected in captured.err, captured.err
    assert list(out.iterdir()) == []
    assert sorted(p.relative_to(run) for p in run.rglob("*")) == run_before
    assert sorted(p.relative_to(inputs) for p in inputs.rglob("*")) == inputs_before
    assert not [p for p in tmp_path.iterdir() if p.name not in ("run", "out")]


def test_report_needs_no_shapes(inputs: Path, tmp_path: Path) -> None:
    """report writes the page of a run folder whose shapes are missing or incomplete (it
    draws none); animate, which draws them, names the missing variables."""
    for how in ("no shapes", "half a shape"):
        run = tmp_path / how.replace(" ", "_")
        shutil.copytree(inputs / "run", run)
        _damage(run, how)
        assert main(["report", str(run)]) == 0
        assert (run / "report.html").stat().st_size > 1000


def test_a_folder_that_cannot_be_written_is_refused_before_any_work(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A read-only folder (simulated: the tests may run as root, whom permissions do not
    stop) is refused naming it, by every command that writes a folder."""
    closed = tmp_path / "closed"
    closed.mkdir()
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, mode: False if Path(p) == closed
                        else real(p, mode))
    with pytest.raises(OptionError, match=f"cannot write in {closed}"):
        check_writable(closed / "x")
    monkeypatch.setattr(simulation, "path_function", _no_simulation)
    for command in (["linearize"], ["modes"], ["optimize", "--paper"], ["run", "--paper"]):
        assert main([*command, "-o", str(closed / "x"), "--no-figures"]) == 2
        assert f"cannot write in {closed}" in capsys.readouterr().err
    assert list(closed.iterdir()) == []


def test_check_writable_accepts_new_nested_folders(tmp_path: Path) -> None:
    check_writable(tmp_path / "a" / "b" / "c")
    assert list(tmp_path.iterdir()) == []


def test_the_documented_limits_are_the_enforced_ones() -> None:
    from flexlink.control.modes import MAX_POINTS
    from flexlink.results.animation import MAX_FRAMES, PAGE_SECONDS, page_speed
    from flexlink.shaping.command import MAX_TRIAL_SAMPLES

    docs = Path(__file__).resolve().parents[2] / "docs"
    assert f"at most {MAX_POINTS:,} points" in (docs / "control.md").read_text()
    assert f"at most {MAX_FRAMES:,} frames" in (docs / "animation.md").read_text()
    assert f"lasts {PAGE_SECONDS:g} s" in (docs / "animation.md").read_text()
    assert page_speed(np.array([0.0, 5.0])) == 1.0
    assert page_speed(np.array([0.0, 1000.0])) * PAGE_SECONDS == pytest.approx(1000.0)
    assert f"within {MAX_TRIAL_SAMPLES:,} output samples" in (docs / "shaping.md").read_text()
