"""`flexlink fit` and `flexlink optimize` (issue 28's rows), before and after, side by side.

    python benchmarks/fit_optimize.py                    # this tree only
    python benchmarks/fit_optimize.py --before 497667b   # and the code of that commit
    python benchmarks/fit_optimize.py --before ../main   # or of that checkout
    python benchmarks/fit_optimize.py --only fit         # or --only optimize, --only command
    python benchmarks/fit_optimize.py --repeat 3         # each command's median of 3

Rows, each measured in fresh processes for each version of the code (``--before REV``: the
sources of REV unpacked next to the system's temporary files, numba's caches warmed there by
one untimed run of each kind first):

- ``command``: `flexlink fit examples/lab_arm.toml` (its record examples/lab_run3.csv) with
  the README's six parameters (figures and report written; and again with
  ``--no-figures``), then the same command (with figures) of every other case below: wall
  time and CPU time (user + system) of the whole process and its children (the figures'
  worker): start-up, loading, fit and writing; the estimates and intervals it wrote
  (fit.json), and with ``--before`` whether both versions' agree to the printed digits;
  also the CPU time of the command's own process and of its main thread (the figures are
  drawn in other processes, numba's cache loaded in another thread): on an idle machine
  the wall time lies near the main thread's, plus the last figure's drawing;
- ``fit() <case>``: `flexlink.experiment.fit` alone, in process, of the lab record, of the
  synthetic lab manoeuvres of tests/experiment/synthetic.py (seven parameters each, with the
  truth known) and of the one-link arm of tests/experiment/test_compare_fit.py: wall and CPU
  time, simulations, how the Jacobians were computed (exact from the runs' sensitivities, or
  differences, with the reason), each estimate with its 95 % interval and its error against
  the truth with whether the interval covers it (the judged tolerances: EI 3 %, damping
  20 %, gains 3 %);
- ``optimize``: `flexlink.shaping.optimize_move` of the paper manoeuvre (90° / 80° in 1.2 s,
  `--robust 10`, the seed and limits of `flexlink.shaping.paper`) on every core: wall time,
  iterations, evaluations (each runs every plant) and runs; the residual energy of each plant
  relative to the cycloid's; and the peak link-2 tip deflection over 2 s after the move
  (independent runs of the first-order model with and without stiffening, every frequency
  off by −10, 0, +10 %);
- ``optimize command`` (also alone: ``--only command``): the whole `flexlink optimize
  --paper` command of that manoeuvre (the README's options: --duration 1.2 and the paper's
  limits) in a fresh process, with its figures and again with ``--no-figures``, the versions
  run after run (``--repeat N``: the median by wall time, and every run): wall and CPU time
  of all its processes, of its own process and of its main thread, and the same split by
  stage (start-up, imports and scenario, optimisation, the report's runs, figures and files,
  exit: `STAGE_PROBE`); iterations and the optimised move's residual tip deflection
  (summary.json), and with ``--before`` whether every run's summary.json (but its run time)
  and printed summary agree.

The machine is shared: CPU time is the figure that load moves least; the load average is
printed with every row.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tarfile
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
FIT_PARAMS = ("links[0].EI", "links[0].damping_ratio", "links[1].damping_ratio", "pzt:gain",
              "pzt:offset", "link1_tip_acceleration:gain")
MANOEUVRE_PARAMS = ("links[0].EI", "links[0].damping_ratio", "links[1].damping_ratio",
                    "pzt:gain", "pzt:offset", "pzt:drift", "link1_tip_acceleration:gain")
SINGLE_PARAMS = ("links[0].EI", "links[0].damping_ratio", "strain:gain")
TOLERANCE = {"links[0].EI": 0.03, "links[0].damping_ratio": 0.2,
             "links[1].damping_ratio": 0.2, "pzt:gain": 0.03,
             "link1_tip_acceleration:gain": 0.03, "strain:gain": 0.03}
ERRORS = (-0.10, 0.0, 0.10)


# -- children ----------------------------------------------------------------------------
def _cpu(children: bool = False) -> float:
    """CPU seconds (user + system) of this process, or of its finished children."""
    usage = resource.getrusage(resource.RUSAGE_CHILDREN if children else resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


Case = tuple[str, Path, tuple[str, ...], "dict[str, float] | None"]


def fit_cases() -> list[Case]:
    """(name, scenario file, parameters, truth or None) of every case: the lab record (its
    CSV named in its file), the synthetic manoeuvres and the one-link arm, their files
    written to a new temporary folder."""
    sys.path.insert(0, str(ROOT))
    from tests.experiment.synthetic import (
        MANOEUVRES,
        MAPPING,
        SINGLE_LINK_MAPPING,
        measured_columns,
        scenario_text,
        single_link_measurement,
        single_link_text,
        write_csv,
    )

    cases: list[Case] = [("lab_run3", ROOT / "examples" / "lab_arm.toml", FIT_PARAMS, None)]
    folder = Path(tempfile.mkdtemp(prefix="flexlink-fit-bench-"))
    for name, truth in MANOEUVRES.items():
        columns, _ = measured_columns(truth)
        write_csv(folder / f"{name}.csv", columns)
        text = scenario_text(truth) + MAPPING.replace("measured.csv", f"{name}.csv")
        (folder / f"{name}.toml").write_text(text, encoding="utf-8")
        true = {"links[0].EI": truth.EI1, "links[0].damping_ratio": truth.zeta1,
                "links[1].damping_ratio": truth.zeta2, "pzt:gain": truth.pzt_gain,
                "pzt:offset": truth.pzt_offset, "pzt:drift": truth.pzt_drift,
                "link1_tip_acceleration:gain": truth.acc_gain}
        cases.append((name, folder / f"{name}.toml", MANOEUVRE_PARAMS, true))
    # the one-link arm of tests/experiment/test_compare_fit.py (its truth: EI 262 N·m²,
    # damping ratio 0.03, strain gauge read with gain 0.9)
    write_csv(folder / "measured.csv", single_link_measurement(262.0, 0.03))
    (folder / "single.toml").write_text(single_link_text() + SINGLE_LINK_MAPPING + (
        '[[measurement.columns]]\ncolumn = "strain"\nsensor = "strain"\nunit = "ustrain"\n'),
        encoding="utf-8")
    cases.append(("one link", folder / "single.toml", SINGLE_PARAMS,
                  {"links[0].EI": 262.0, "links[0].damping_ratio": 0.03, "strain:gain": 0.9}))
    return cases


def _judged(path: str, value: float, low: float, high: float,
            true: dict[str, float] | None) -> dict[str, Any]:
    """An estimate's row: value and interval, with its error against the truth if known."""
    row: dict[str, Any] = {"value": value, "low": low, "high": high}
    if true is not None:
        row["error"] = value / true[path] - 1.0 if true[path] else None
        row["covers"] = bool(low <= true[path] <= high)
        row["within"] = (abs(row["error"]) <= TOLERANCE[path]
                         if path in TOLERANCE else None)
    return row


def child_fit() -> dict[str, Any]:
    """fit() of the lab record and of every synthetic manoeuvre, timed in this process."""
    from flexlink.experiment.identification import fit
    from flexlink.experiment.loading import load_experiment
    from flexlink.experiment.parameters import parse_parameter_option

    out: dict[str, Any] = {}
    for name, toml, paths, true in fit_cases():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            experiment = load_experiment(toml)
            params = [parse_parameter_option(p, experiment.file, experiment.measurement.units)
                      for p in paths]
            wall, cpu = time.perf_counter(), _cpu()
            result = fit(experiment.file, experiment.measurement, params)
            wall, cpu = time.perf_counter() - wall, _cpu() - cpu
        estimates = {e.path: _judged(e.path, e.value, e.ci_low, e.ci_high, true)
                     for e in result.estimates}
        out[name] = {"wall": wall, "cpu": cpu, "simulations": result.simulations,
                     "estimates": estimates, "load": os.getloadavg()[0],
                     "jacobian": result.info.get("jacobian", "differences")}
    return out


def child_optimize() -> dict[str, Any]:
    """optimize_move of the paper manoeuvre and the residual vibration it leaves."""
    import numpy as np

    import flexlink
    from flexlink.scenario import load_scenario, paper_experiment_path
    from flexlink.shaping import optimize_move
    from flexlink.shaping.compare import cycloidal_version, residuals
    from flexlink.shaping.paper import DURATION_S, LIMITS, SEED

    scenario = load_scenario(paper_experiment_path())
    flexlink.simulate(scenario, shapes=False)  # numba's cache loaded before the clock
    wall, cpu, workers = time.perf_counter(), _cpu(), _cpu(children=True)
    result = optimize_move(scenario, DURATION_S, LIMITS, seed=SEED, robust=0.1)
    wall, cpu = time.perf_counter() - wall, _cpu() - cpu
    workers = _cpu(children=True) - workers  # the pool's processes, ended by now
    import dataclasses

    peaks = {}
    for label, stiff in (("paper's model", False), ("stiffened", True)):
        versions = {k: dataclasses.replace(v, settings=dataclasses.replace(
            v.settings, geometric_stiffening=stiff)) for k, v in (
            ("cycloidal", cycloidal_version(result.scenario, result.moves)),
            ("optimised", result.scenario))}
        peaks[label] = {k: list(v) for k, v in
                        residuals(versions, result.move_end, ERRORS, "first_order").items()}
    return {"wall": wall, "cpu_main": cpu, "cpu_workers": workers, "iterations": result.iterations,
            "evaluations": result.evaluations, "plants": len(result.plants),
            "workers": result.workers,
            "energy_ratio": list(np.asarray(result.energy) /
                                 np.asarray(result.energy_cycloidal)),
            "peaks": peaks, "message": result.message, "load": os.getloadavg()[0]}


# `python -m flexlink` that also writes, at its exit (its atexit handlers run: cli._exit), the
# CPU time of its main thread and of its whole process: the command's critical path lies
# between the two on an idle machine (the other threads, the preload's, run beside it)
PROBE = """
import atexit, json, resource, sys, time
path = sys.argv.pop(1)
def record():
    usage = resource.getrusage(resource.RUSAGE_SELF)
    with open(path, "w") as f:
        json.dump({"main": time.thread_time(), "process": usage.ru_utime + usage.ru_stime}, f)
atexit.register(record)
from flexlink.cli import command
command()
"""


def child_command(src: Path, figures: bool = True, case: Case | None = None
                  ) -> dict[str, Any]:
    """The whole `flexlink fit` command in a fresh process (of ``case``, default the lab
    record): wall and CPU time (all its processes; its own process and main thread), and
    the estimates it wrote (fit.json)."""
    name, toml, paths, true = case or ("lab_run3", ROOT / "examples" / "lab_arm.toml",
                                       FIT_PARAMS, None)
    out = Path(tempfile.mkdtemp(prefix="flexlink-fit-cmd-")) / "fitted"
    record = out.parent / "cpu.json"
    args = [sys.executable, "-c", PROBE, str(record), "fit", str(toml), "-o", str(out), "-q"]
    if not figures:
        args.append("--no-figures")
    for p in paths:
        args += ["-p", p]
    env = {**os.environ, "PYTHONPATH": str(src)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    subprocess.run(args, env=env, check=True, capture_output=True, cwd=toml.parent)
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    fitted = json.loads((out / "fit.json").read_text(encoding="utf-8"))
    estimates = {e["path"]: _judged(e["path"], e["value"], e["ci_low"], e["ci_high"], true)
                 for e in fitted["parameters"]}
    own = json.loads(record.read_text(encoding="utf-8"))
    return {"wall": wall, "cpu": cpu, "load": os.getloadavg()[0], "estimates": estimates,
            "case": name, "cpu_process": own["process"], "cpu_main": own["main"]}


OPTIMIZE_OPTIONS = ("--paper", "--duration", "1.2", "--rate-limit", "200",
                    "--acceleration-limit", "1000", "--torque-limit", "12,0.25")

# PROBE with a clock at each stage of `flexlink optimize` (wall since the interpreter
# started, CPU of the main thread, of the whole own process and of its ended children: the
# optimiser's and the runs' pools, the figure processes): the handler called (interpreter and
# command line started), the optimiser called (imports and scenario read), it returned, the
# report's runs done (the last residual run in this process, or the pool of them), the
# report written (figures drawn and files written), exit. Wrappers of module functions that
# both versions have, or left out where a version has none.
STAGE_PROBE = PROBE.replace("from flexlink.cli import command", """
import os
marks = []
def mark(name):
    usage = resource.getrusage(resource.RUSAGE_SELF)
    child = resource.getrusage(resource.RUSAGE_CHILDREN)
    marks.append((name, time.perf_counter() - START, time.thread_time(),
                  usage.ru_utime + usage.ru_stime, child.ru_utime + child.ru_stime))
def wrap(module, attr, start=None, end=None):
    f = getattr(module, attr, None)
    if f is None:
        return
    def timed(*a, **k):
        if os.getpid() == PID and start:
            mark(start)
        try:
            return f(*a, **k)
        finally:
            if os.getpid() == PID and end:
                mark(end)
    setattr(module, attr, timed)
PID = os.getpid()
import flexlink.cli as cli
import flexlink.shaping.command as sc
import flexlink.shaping.compare as cmp
import flexlink.shaping.optimize as opt
wrap(sc, "run_optimize", "handler")
wrap(opt, "optimize_move", "optimiser", "optimised")
wrap(sc, "write_outputs", None, "written")
wrap(cmp, "run_residual", None, "runs done")
wrap(cmp, "residual_runs", None, "runs done")
build = cli.build_parser
def parser():
    p = build()
    p._subparsers._group_actions[0].choices["optimize"].set_defaults(handler=sc.run_optimize)
    return p
cli.build_parser = parser
def stages():
    mark("exit")
    with open(path + ".stages", "w") as f:
        json.dump(marks, f)
atexit.register(stages)
from flexlink.cli import command""").replace("import atexit, json, resource, sys, time",
                                             "import time\nSTART = time.perf_counter()\n"
                                             "import atexit, json, resource, sys")
STAGES = (("handler", "start-up"), ("optimiser", "imports, scenario"),
          ("optimised", "optimisation"), ("runs done", "report's runs"),
          ("written", "figures, files"), ("exit", "exit"))


def stage_split(marks: list[list[Any]]) -> dict[str, list[float]]:
    """Per stage: [wall, main thread CPU, own process CPU, ended children's CPU] (s) from
    the previous stage's end (the last mark of each name)."""
    last = {m[0]: m[1:] for m in marks}
    out, previous = {}, [0.0, 0.0, 0.0, 0.0]
    for name, label in STAGES:
        if name in last:
            out[label] = [a - b for a, b in zip(last[name], previous, strict=True)]
            previous = last[name]
    return out


def child_optimize_command(src: Path, figures: bool = True) -> dict[str, Any]:
    """The whole `flexlink optimize` command of the paper manoeuvre in a fresh process: wall
    and CPU time (all its processes: the pool's and the figures' too; its own process and
    main thread), per stage (`STAGE_PROBE`), and what its summary reports."""
    out = Path(tempfile.mkdtemp(prefix="flexlink-opt-cmd-")) / "opt"
    record = out.parent / "cpu.json"
    args = [sys.executable, "-c", STAGE_PROBE, str(record), "optimize", *OPTIMIZE_OPTIONS,
            "-o", str(out)]
    if not figures:
        args.append("--no-figures")
    env = {**os.environ, "PYTHONPATH": str(src)}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = time.perf_counter()
    done = subprocess.run(args, env=env, check=True, capture_output=True, text=True)
    wall = time.perf_counter() - wall
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    summary = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    pictures = sorted(p.name for p in out.glob("*.png"))
    own = json.loads(record.read_text(encoding="utf-8"))
    marks = json.loads(Path(str(record) + ".stages").read_text(encoding="utf-8"))
    summary["optimiser"].pop("wall_time_s")
    printed = [line for line in done.stdout.splitlines()
               if not line.startswith(("flexlink optimize:", "files in"))]
    return {"wall": wall, "cpu": cpu, "load": os.getloadavg()[0], "cpu_process":
            own["process"], "cpu_main": own["main"], "pictures": pictures,
            "iterations": summary["optimiser"]["iterations"],
            "residual": summary["residual_tip_deflection_m"],
            "band": summary["robustness_band"], "summary": summary, "printed": printed,
            "stages": stage_split(marks)}


# -- parent ------------------------------------------------------------------------------
def source_of(rev: str) -> Path:
    """The src/ folder of commit ``rev``, unpacked once into the temporary folder (its numba
    caches stay with it between runs of this benchmark); or of the checkout ``rev`` names
    (a folder holding src/flexlink)."""
    if (Path(rev) / "src" / "flexlink").is_dir():
        return Path(rev).resolve() / "src"
    full = subprocess.run(["git", "-C", str(ROOT), "rev-parse", rev], check=True,
                          capture_output=True, text=True).stdout.strip()
    folder = Path(tempfile.gettempdir()) / f"flexlink-src-{full[:12]}"
    if not (folder / "src" / "flexlink").is_dir():
        archive = subprocess.run(["git", "-C", str(ROOT), "archive", full, "src"], check=True,
                                 capture_output=True).stdout
        folder.mkdir(parents=True, exist_ok=True)
        tar = folder / "src.tar"
        tar.write_bytes(archive)
        with tarfile.open(tar) as t:
            t.extractall(folder, filter="data")
        tar.unlink()
    return folder / "src"


def run_child(kind: str, src: Path, repeat: int = 1, case: Case | None = None
              ) -> dict[str, Any]:
    if kind in ("command", "no figures"):  # the median run by CPU time of ``repeat``
        runs = sorted((child_command(src, kind == "command", case) for _ in range(repeat)),
                      key=lambda r: r["cpu"])
        return {**runs[len(runs) // 2], "runs": runs}
    env = {**os.environ, "PYTHONPATH": str(src)}
    done = subprocess.run([sys.executable, __file__, "--child", kind], env=env, check=True,
                          capture_output=True, text=True)
    return json.loads(done.stdout.strip().splitlines()[-1])


def _estimates(row: dict[str, Any]) -> str:
    parts = []
    for path, e in row["estimates"].items():
        text = (f"{path.split('.')[-1] if path.startswith('links') else path}={e['value']:.6g}"
                f" [{e['low']:.6g}, {e['high']:.6g}]")
        if "error" in e and e["error"] is not None:
            text += (f" ({100 * e['error']:+.1f} %{'' if e['covers'] else ', NOT covered'}"
                     f"{', OUT of tolerance' if e['within'] is False else ''})")
        parts.append(text)
    return "; ".join(parts)


def _own(row: dict[str, Any]) -> str:
    """The command's own process and main thread, CPU s."""
    return f"own process {row['cpu_process']:.2f}, its main thread {row['cpu_main']:.2f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", metavar="REV",
                        help="also measure the code of commit REV (or of the checkout REV)")
    parser.add_argument("--only", choices=("fit", "optimize", "command"),
                        help="only the fit rows, the optimize rows, or of these only the "
                             "optimize command's")
    parser.add_argument("--repeat", type=int, default=1, metavar="N",
                        help="run each command N times: the median (fit: by CPU time, "
                             "optimize: by wall time), and all")
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps({"fit": child_fit, "optimize": child_optimize}[args.child]()))
        return
    versions = {"after": ROOT / "src"}
    if args.before:
        versions = {f"before ({args.before})": source_of(args.before), **versions}
    print(f"Python {platform.python_version()}, {os.cpu_count()} cores, "
          f"{platform.platform()}; load average {os.getloadavg()[0]:.1f}")
    kinds = [k for k in ("fit", "optimize") if args.only in (None, k)]
    commands = args.only in (None, "optimize", "command")
    for label, src in versions.items():  # numba's caches of each version, untimed
        for kind in (["command"] if "fit" in kinds else []) + (
                ["optimize"] if "optimize" in kinds or commands else []):
            if kind == "command":
                child_command(src)
            else:
                env = {**os.environ, "PYTHONPATH": str(src)}
                warm = ("import flexlink; "
                        "flexlink.simulate(flexlink.load_paper_experiment(), shapes=False)")
                subprocess.run([sys.executable, "-c", warm], env=env, check=True,
                               capture_output=True)
        if commands:  # every kernel the command's optimiser and report runs use
            child_optimize_command(src, False)
    results: dict[str, dict[str, Any]] = {label: {} for label in versions}
    cases = fit_cases() if "fit" in kinds else []
    for label, src in versions.items():
        if "fit" in kinds:
            results[label]["command"] = run_child("command", src, args.repeat)
            results[label]["no figures"] = run_child("no figures", src, args.repeat)
            results[label]["commands"] = [run_child("command", src, args.repeat, case)
                                          for case in cases[1:]]
            results[label]["fit"] = run_child("fit", src)
        if "optimize" in kinds:
            results[label]["optimize"] = run_child("optimize", src)
    if commands:  # the versions in turn, run after run, so that both see the same load
        runs: dict[str, dict[str, list[dict[str, Any]]]] = {
            label: {"optimize command": [], "optimize no figures": []} for label in versions}
        for _ in range(args.repeat):
            for kind in ("optimize command", "optimize no figures"):
                for label, src in versions.items():
                    runs[label][kind].append(child_optimize_command(
                        src, kind == "optimize command"))
        for label in versions:
            for kind, done in runs[label].items():  # the median by wall time, and all
                done.sort(key=lambda r: r["wall"])
                results[label][kind] = {**done[len(done) // 2], "runs": done}
    if "fit" in kinds:
        print("\nflexlink fit (target: at most 2 s, the same estimates)")
        for kind, what in (("command", ""), ("no figures", " --no-figures")):
            for label, res in results.items():
                c = res[kind]
                print(f"  {label:<22} command{what}, lab_run3, 6 parameters: {c['wall']:.2f} s "
                      f"wall, {c['cpu']:.2f} s CPU ({_own(c)}; load {c['load']:.1f})"
                      + ("; runs: " + ", ".join(f"{r['wall']:.2f}/{r['cpu']:.2f} s"
                                                 for r in c["runs"]) if len(c["runs"]) > 1
                         else "") + (f"\n  {'':<22}   {_estimates(c)}" if not what else ""))
        for i in range(len(cases) - 1):
            for label, res in results.items():
                c = res["commands"][i]
                print(f"  {label:<22} command, {c['case']}: {c['wall']:.2f} s wall, "
                      f"{c['cpu']:.2f} s CPU ({_own(c)}; load {c['load']:.1f})"
                      + ("; runs: " + ", ".join(f"{r['wall']:.2f}/{r['cpu']:.2f} s"
                                                 for r in c["runs"]) if len(c["runs"]) > 1
                         else "") + f"\n  {'':<22}   {_estimates(c)}")
        if len(versions) > 1:  # the printed digits of both versions' commands
            shown = {label: [_estimates(c) for c in (res["command"], *res["commands"])]
                     for label, res in results.items()}
            first, second = shown.values()
            print("  estimates and intervals of every command identical to the printed "
                  f"digits: {'yes' if first == second else 'NO'}")
        for case in results["after"]["fit"]:
            for label, res in results.items():
                row = res["fit"][case]
                print(f"  {label:<22} fit() {case}: {row['wall']:.2f} s wall, {row['cpu']:.2f} s "
                      f"CPU, {row['simulations']} simulations, Jacobian: "
                      f"{row.get('jacobian', 'differences')} (load {row['load']:.1f})\n"
                      f"  {'':<22}   {_estimates(row)}")
    if "optimize" in kinds:
        print("\nflexlink optimize, paper manoeuvre, --robust 10 (target: at most 5 s, residual "
              "vibration at least as small)")
        for label, res in results.items():
            o = res["optimize"]
            print(f"  {label:<22} {o['wall']:.2f} s wall on {o['workers']} processes "
                  f"({o['cpu_main']:.2f} s CPU in the main one, {o['cpu_workers']:.2f} s in "
                  f"the pool's; load {o['load']:.1f}), "
                  f"{o['iterations']} iterations, {o['evaluations']} evaluations × "
                  f"{o['plants']} plants = {o['evaluations'] * o['plants']} runs; "
                  f"{o['message']}")
            print(f"  {'':<22}   residual energy / cycloid's per plant: "
                  + ", ".join(f"{v:.3g}" for v in o["energy_ratio"]))
            for model, peaks in o["peaks"].items():
                print(f"  {'':<22}   peak link-2 tip deflection after the move, {model}: "
                      + ", ".join(f"{100 * e:+.0f} %: {1e3 * a:.3g} mm (cycloid {1e3 * c:.3g})"
                                  for e, a, c in zip(ERRORS, peaks["optimised"],
                                                     peaks["cycloidal"], strict=True)))
    if commands:
        print("\nflexlink optimize --paper (the paper manoeuvre, README's options), the whole "
              "command (target: at most 5 s)")
        for kind, what in (("optimize command", ""), ("optimize no figures", " --no-figures")):
            for label, res in results.items():
                c = res[kind]
                residual = c["residual"]
                print(f"  {label:<22} command{what}: {c['wall']:.2f} s wall, {c['cpu']:.2f} s "
                      f"CPU ({_own(c)}; load {c['load']:.1f}); {c['iterations']} iterations, "
                      f"figures {', '.join(c['pictures']) or 'none'}; residual tip deflection "
                      + ", ".join(f"{m}: optimised {1e3 * v['optimised']:.4g} mm"
                                  for m, v in residual.items())
                      + ("; runs (wall/CPU/own process/main thread): " + ", ".join(
                          f"{r['wall']:.2f}/{r['cpu']:.2f}/{r['cpu_process']:.2f}/"
                          f"{r['cpu_main']:.2f} s" for r in c["runs"])
                         if len(c["runs"]) > 1 else ""))
                print(f"  {'':<22}   stages (wall/main thread/own process/ended children, "
                      "s): " + "; ".join(f"{name} {w:.2f}/{m:.2f}/{p:.2f}/{ch:.2f}"
                                         for name, (w, m, p, ch) in c["stages"].items()))
        if len(versions) > 1:  # every run of both versions: summary.json and printed lines
            same = True
            for kind in ("optimize command", "optimize no figures"):
                seen = [(r["summary"], r["printed"]) for res in results.values()
                        for r in res[kind]["runs"]]
                same = same and all(x == seen[0] for x in seen)
            print("  summary.json (but the run time) and the printed summary of every run of "
                  f"both versions identical: {'yes' if same else 'NO'}")


if __name__ == "__main__":
    main()
