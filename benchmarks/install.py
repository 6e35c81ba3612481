"""The first run of each path after installing: ``pip install`` into a new virtual environment,
then the first run of each example and each model path there, all timed.

    python benchmarks/install.py [--source .] [--kernels all] [--runs 3] [--system-site-packages]

Prints the wall and CPU time (user + system of all processes) of ``pip install SOURCE``
(FLEXLINK_BUILD_KERNELS=--kernels, setup.py) with the build's own record of its compilation
(``_compiled/build.json``: seconds per warm-up run), then of the first and the second run of
every path in that environment — ``flexlink run --paper``, every ``examples/*.toml``, the
paper arm with the nonlinear model, paper_servo with the nonlinear model (nonlinear forward),
active_damping with the nonlinear model and on servo-driven joints (closed loop on those
paths), a free base under torque-driven joints, ``flexlink linearize``, ``flexlink
modes``, and ``flexlink.simulate(..., sensitivities=...)`` and an objective's value and
gradient on the closed loops of examples/four_bar.toml and on held inputs (the servo-driven
PPF variant) — each with how many functions numba compiled in its first run (``NUMBA_DEBUG_CACHE``'s
"data saved" lines; 0 when the wheel carried every kernel it needs: then the order of the rows
does not matter), and the median of ``--runs`` later ``flexlink run --paper``. Packages come
from pip's configured index and cache (``--system-site-packages``: the running Python's
packages serve the dependencies, so the installation time is flexlink's build alone). The
last line records the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

# A scenario variant, written by the new environment's flexlink (its loader and TOML writer):
# argv = source file ("paper" for the built-in one), target file, JSON of the changes (a
# table's keys updated; "joints" replaced; "append:<table>" appended to an array of tables).
_VARIANT = """
import json, sys
from pathlib import Path
from flexlink.scenario import paper_experiment_path
from flexlink.scenario.load import read_toml
from flexlink.scenario.toml_writer import dump_toml
source, target, changes = sys.argv[1], sys.argv[2], json.loads(sys.argv[3])
data = read_toml(paper_experiment_path() if source == "paper" else Path(source))
for key, value in changes.items():
    if key.startswith("append:"):
        data.setdefault(key[7:], []).extend(value)
    elif isinstance(value, dict):
        data.setdefault(key, {}).update(value)
    else:
        data[key] = value
open(target, "w").write(dump_toml(data))
"""

_TORQUE = [{"profile": "bang_bang", "amplitude": 0.02, "start": 0.2, "duration": 1.0}]
_SERVO_PPF = {  # active_damping's actuator and controller on paper_servo's driven joints
    "append:actuators": [{"name": "pzt_actuator", "kind": "piezo", "link": "link2",
                          "x_start": 0.045, "x_end": 0.095, "width": 0.025, "E_p": 30.33e9,
                          "d31": 265e-12, "limit": 200.0}],
    "append:sensors": [{"name": "pzt", "kind": "piezo", "link": "link2", "x_start": 0.01,
                        "x_end": 0.04, "width": 0.025, "E_p": 30.33e9, "d31": 265e-12,
                        "thickness": 0.001, "capacitance": 1.0e-6}],
    "append:controllers": [{"name": "ppf", "kind": "ppf", "sensor": "pzt",
                            "actuator": "pzt_actuator", "frequency_hz": 2.483,
                            "damping": 0.3, "gain": 1029.0, "sample_rate": 1000.0}]}


# Sensitivities in the new environment: argv = scenario file, JSON of the fields, an
# objective's channel ("": none): flexlink.simulate(..., sensitivities=fields), then the
# objective's value and gradient (`simulation.objective`).
_SENSITIVITIES = """
import json, sys
import flexlink
from flexlink.scenario import load_scenario
from flexlink.simulation.objective import MeanSquare, Objective
scenario, fields = load_scenario(sys.argv[1]), json.loads(sys.argv[2])
if sys.argv[3]:
    objective = Objective(scenario, fields, MeanSquare(sys.argv[3]))
    objective(objective.x0)
else:
    flexlink.simulate(scenario, shapes=False, sensitivities=fields)
"""


def _variants(examples: Path) -> list[tuple[str, str, dict]]:
    """(label, source, changes) of the paths no example runs as it is."""
    free_base = {"base": {"type": "free", "mass": 20.0, "inertia": 2.0},
                 "simulation": {"t_end": 2.0, "geometric_stiffening": True},
                 "joints": [{"drive": "torque", "torque": _TORQUE},
                            {"drive": "torque", "torque": _TORQUE}]}
    return [
        ("paper, nonlinear model", "paper", {"simulation": {"model": "nonlinear"}}),
        ("paper_servo, nonlinear model (nonlinear forward)", str(examples / "paper_servo.toml"),
         {"simulation": {"model": "nonlinear"}}),
        ("active_damping, nonlinear model (closed loop)",
         str(examples / "active_damping.toml"), {"simulation": {"model": "nonlinear"}}),
        ("paper_servo with active_damping's PPF (closed loop, driven)",
         str(examples / "paper_servo.toml"), _SERVO_PPF),
        ("free base, torque-driven joints", "paper", free_base),
    ]


def _children_cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def timed(argv: list[str], env: dict[str, str], cwd: str) -> tuple[float, float, str]:
    """(wall s, CPU s of all its processes, standard output and error) of one command."""
    cpu = _children_cpu()
    start = time.perf_counter()
    done = subprocess.run(argv, check=False, env=env, cwd=cwd, capture_output=True, text=True)
    wall, used = time.perf_counter() - start, _children_cpu() - cpu
    if done.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)} failed ({done.returncode}):\n{done.stderr}")
    return wall, used, done.stdout + done.stderr


def _first_run(label: str, argv: list[str], env: dict[str, str], cwd: str,
               ) -> tuple[str, float, float, float, float]:
    """(label with how many functions numba compiled, wall s and CPU s of the first run,
    of the second)."""
    # unbuffered: numba prints its cache events to standard output, and `flexlink run`
    # leaves through os._exit, which flushes nothing
    wall, cpu, log = timed(argv, dict(env, NUMBA_DEBUG_CACHE="1", PYTHONUNBUFFERED="1"), cwd)
    compiled = sum("data saved" in line for line in log.splitlines())
    again, again_cpu, _ = timed(argv, env, cwd)
    return f"{label} ({compiled} functions compiled)", wall, cpu, again, again_cpu


def measure(source: Path, kernels: str | None = None, runs: int = 3,
            system_site_packages: bool = False) -> tuple[list[tuple[str, float, float]], dict]:
    """(rows of (what, wall s, CPU s), the build's record): ``pip install source`` into a new
    virtual environment, the first run of every path there (with how many functions numba
    compiled) and the median of ``runs`` later ``flexlink run --paper``."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("NUMBA_", "PYTHONPATH", "VIRTUAL_ENV", "FLEXLINK_"))}
    if kernels is not None:
        env["FLEXLINK_BUILD_KERNELS"] = kernels
    examples = source.resolve() / "examples"
    with tempfile.TemporaryDirectory() as tmp:
        venv = Path(tmp) / "venv"
        subprocess.run([sys.executable, "-m", "venv", str(venv)]
                       + ["--system-site-packages"] * system_site_packages, check=True)
        python = str(venv / "bin" / "python")
        flexlink = str(venv / "bin" / "flexlink")
        wall, cpu, _ = timed([python, "-m", "pip", "install", "-q", str(source.resolve())],
                             env, tmp)
        rows = [("pip install", wall, cpu)]
        where = ("import flexlink, pathlib; "
                 "print(pathlib.Path(flexlink.__file__).parent / '_compiled' / 'build.json')")
        found = subprocess.run(
            [python, "-c", where],
            env=env, cwd=tmp, capture_output=True, text=True, check=True).stdout.strip()
        record = json.loads(Path(found).read_text()) if Path(found).is_file() else {}
        out = ["-o", "out", "-q", "--overwrite"]
        rows.append(_first_run("flexlink run --paper", [flexlink, "run", "--paper"] + out,
                               env, tmp))
        for example in sorted(examples.glob("*.toml")):
            rows.append(_first_run(f"examples/{example.name}",
                                   [flexlink, "run", str(example)] + out, env, tmp))
        written = {}
        for number, (label, scenario, changes) in enumerate(_variants(examples)):
            target = written[label] = str(Path(tmp) / f"variant{number}.toml")
            subprocess.run([python, "-c", _VARIANT, scenario, target, json.dumps(changes)],
                           env=env, cwd=tmp, check=True)
            rows.append(_first_run(label, [flexlink, "run", target] + out, env, tmp))
        four_bar = str(examples / "four_bar.toml")
        coupler = json.dumps(["links[1].EI", "links[1].mass_per_length"])
        held = written["paper_servo with active_damping's PPF (closed loop, driven)"]
        for label, argv in (
                ("four_bar: sensitivities to the coupler's EI and mass (closed loop)",
                 [four_bar, coupler, ""]),
                ("four_bar: an objective's value and gradient (pin_force_x)",
                 [four_bar, coupler, "pin_force_x"]),
                ("paper_servo with PPF: sensitivities to link 2's EI, the gain (held inputs)",
                 [held, json.dumps(["links[1].EI", "controllers[0].gain"]), ""])):
            rows.append(_first_run(label, [python, "-c", _SENSITIVITIES, *argv], env, tmp))
        servo = str(examples / "paper_servo.toml")
        rows.append(_first_run("flexlink linearize examples/paper_servo.toml --at 1.0",
                               [flexlink, "linearize", servo, "--at", "1.0"] + out, env, tmp))
        rows.append(_first_run("flexlink modes (paper, --times 0:1.5:0.5)",
                               [flexlink, "modes", "--times", "0:1.5:0.5"] + out, env, tmp))
        run = [flexlink, "run", "--paper"] + out
        later = [timed(run, env, tmp) for _ in range(runs)]
        if later:
            rows.append((f"later flexlink run --paper (median of {runs})",
                         statistics.median(w for w, _, _ in later),
                         statistics.median(c for _, c, _ in later)))
    return rows, record


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", type=Path, default=Path(__file__).resolve().parents[1])
    parser.add_argument("--kernels", default=None,
                        help="FLEXLINK_BUILD_KERNELS for the build (default: setup.py's)")
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--system-site-packages", action="store_true",
                        help="the new environment sees this Python's packages")
    args = parser.parse_args()
    load = os.getloadavg()[0]
    rows, record = measure(args.source, args.kernels, args.runs, args.system_site_packages)
    width = max(len(row[0]) for row in rows)
    print(f"{'what (first run, then the second)':<{width}}  wall [s]  CPU [s]  "
          "2nd wall  2nd CPU")
    for label, wall, cpu, *second in rows:
        tail = "".join(f"  {value:8.2f}" for value in second)
        print(f"{label:<{width}}  {wall:8.2f}  {cpu:7.2f}{tail}")
    kept = ("seconds", "workers", "kernels", "runs", "failed", "uncompiled")
    print(f"build record: {json.dumps({k: record[k] for k in kept if k in record})}")
    print(f"source {args.source}, kernels {args.kernels or 'default'!r}; "
          f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}; load average {load:.2f} before, "
          f"{os.getloadavg()[0]:.2f} after")


if __name__ == "__main__":
    main()
