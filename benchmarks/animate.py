"""Time of ``flexlink animate`` on the paper run: a 5 s GIF (real time, 20 frames/s, the four
sensor traces under the arm), and what the link shapes add to a paper run.

    python benchmarks/animate.py             # 5 repeats
    python benchmarks/animate.py --repeat 3

Target (issue 19): at most 10 s for the GIF on a 2-core machine. Each animate row is the whole
command in a fresh process (start-up and imports included), median of ``--repeat`` runs. The
shape rows: the cost of computing every link's shape inside a paper simulation (median over
repeats, in this process) and what the shape variables add to writing the run folder's files
and to their sizes.
"""

from __future__ import annotations

import argparse
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

COMMAND = "import sys; from flexlink.cli import main; sys.exit(main(sys.argv[1:]))"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    args = parser.parse_args()
    work = Path(tempfile.mkdtemp(prefix="flexlink-animate-bench-"))
    try:
        run = work / "paper"
        subprocess.run([sys.executable, "-c", COMMAND, "paper", "-o", str(run), "-q"],
                       check=True, capture_output=True)
        times = []
        for _ in range(args.repeat):
            started = time.perf_counter()
            subprocess.run([sys.executable, "-c", COMMAND, "animate", str(run), "-o",
                            str(work / "paper.gif")], check=True, capture_output=True)
            times.append(time.perf_counter() - started)
        size = (work / "paper.gif").stat().st_size
        print(f"flexlink animate, paper run, 5 s GIF: median {statistics.median(times):.2f} s "
              f"(min {min(times):.2f}, max {max(times):.2f}, {args.repeat} runs); "
              f"{size / 1e6:.2f} MB")
        shape_costs(run, work, args.repeat)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def shape_costs(run: Path, work: Path, repeat: int) -> None:
    from flexlink.results.writers import write_run
    from flexlink.scenario import load_scenario, paper_experiment_path, resolve_scenario_dict
    from flexlink.simulation import prescribed, simulate

    scenario = load_scenario(paper_experiment_path())
    resolved = resolve_scenario_dict(paper_experiment_path())
    spent: list[float] = []
    compute = prescribed.shape_values

    def timed(*a, **k):  # type: ignore[no-untyped-def]
        started = time.perf_counter()
        out = compute(*a, **k)
        spent.append(time.perf_counter() - started)
        return out

    prescribed.shape_values = timed
    runs = []
    for _ in range(repeat + 2):
        started = time.perf_counter()
        results = simulate(scenario)
        runs.append(time.perf_counter() - started)
    prescribed.shape_values = compute
    print(f"paper simulation: median {1e3 * statistics.median(runs):.1f} ms, of which the "
          f"link shapes {1e3 * statistics.median(spent):.2f} ms")

    def write(with_shapes: bool) -> tuple[float, dict[str, int]]:
        shapes = results.shapes
        if not with_shapes:
            results.shapes = []
        costs, sizes = [], {}
        for k in range(repeat + 2):
            out = work / f"w{with_shapes}{k}"
            started = time.perf_counter()
            write_run(results, out, resolved, figures=False, report=False)
            costs.append(time.perf_counter() - started)
            sizes = {p.name: p.stat().st_size for p in out.iterdir()}
        results.shapes = shapes
        return statistics.median(costs), sizes

    (with_t, with_s), (without_t, without_s) = write(True), write(False)
    print(f"writing the folder (no figures, no report): {1e3 * with_t:.1f} ms with shapes, "
          f"{1e3 * without_t:.1f} ms without")
    for name in ("results.nc", "results.mat", "results.csv"):
        print(f"  {name}: {with_s[name] / 1e6:.2f} MB with shapes, "
              f"{without_s[name] / 1e6:.2f} MB without")
    report = work / "r"
    started = time.perf_counter()
    write_run(results, report, resolved, figures=True, report=True)
    total = time.perf_counter() - started
    print(f"run folder with figures and report.html: {total:.2f} s; report.html "
          f"{(report / 'report.html').stat().st_size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
