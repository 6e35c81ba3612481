"""Quick timings of the prescribed-motion path in one process (issue 16's rows, without
worker start-up): the paper experiment, sweep-like variants of it and ten links.

    python benchmarks/prescribed.py [--repeat 15] [--cases 40] [--profile paper|sweep|ten]

paper: median wall time of `simulate(load_paper_experiment())` after a warm-up.
sweep: median CPU time of one variant (EI of link 1 ×0.7–1.3 and both move durations drawn as in
benchmarks/batch.py, a new E each case: new modal data), run in this process.
ten: median wall time of the 10-link row of benchmarks/compare.py.
stiff3: median wall time of the paper arm with geometric stiffening over 3 s (the issue's
"paper-like manoeuvre" row, whose Exudyn time — coarsest mesh within 1% — is measured by
benchmarks/nonlinear_vs_fe.py, not here).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))


def _variants(cases: int, seed: int = 1):
    from flexlink import load_paper_experiment

    paper = load_paper_experiment()
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(cases):
        scale = rng.uniform(0.7, 1.3)  # as E of link 1 in 20-40 GPa
        d0, d1 = rng.uniform(0.8, 1.2, 2)
        links = list(paper.chain.links)
        links[0] = replace(links[0], EI=links[0].EI * scale)
        joints = [replace(j, duration=d) for j, d in zip(paper.chain.joints, (d0, d1))]
        chain = replace(paper.chain, links=tuple(links), joints=tuple(joints))
        out.append(replace(paper, chain=chain))
    return out



def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeat", type=int, default=15)
    parser.add_argument("--cases", type=int, default=40)
    parser.add_argument("--profile", choices=["paper", "sweep", "ten"])
    parser.add_argument("--only", default="paper,stiff3,sweep,ten")
    args = parser.parse_args()
    from compare import _ten_links

    from flexlink import load_paper_experiment, simulate

    paper = load_paper_experiment()
    simulate(paper)
    if args.profile:
        import cProfile
        import pstats

        todo = {"paper": [paper] * args.repeat, "sweep": _variants(args.cases),
                "ten": [_ten_links()] * 3}[args.profile]
        simulate(todo[0])
        prof = cProfile.Profile()
        prof.enable()
        for s in todo:
            simulate(s)
        prof.disable()
        pstats.Stats(prof).sort_stats("cumulative").print_stats(45)
        return
    only = args.only.split(",")
    if "paper" in only:
        walls, cpus = [], []
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            simulate(paper)
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        print(f"paper simulate: median {1e3 * statistics.median(walls):.2f} ms, "
              f"best {1e3 * min(walls):.2f} ms, median CPU {1e3 * statistics.median(cpus):.2f} ms")
    if "stiff3" in only:
        stiff = replace(paper, settings=replace(paper.settings, t_end=3.0,
                                                geometric_stiffening=True))
        simulate(stiff)
        walls, cpus = [], []
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            simulate(stiff)
            walls.append(time.perf_counter() - t0)
            cpus.append(time.process_time() - c0)
        print(f"paper arm 3 s, stiffening: median {1e3 * statistics.median(walls):.2f} ms, "
              f"best {1e3 * min(walls):.2f} ms, median CPU {1e3 * statistics.median(cpus):.2f} ms")
    if "sweep" in only:
        variants = _variants(args.cases)
        cpus = []
        for s in variants:
            t0 = time.process_time()
            simulate(s)
            cpus.append(time.process_time() - t0)
        print(f"sweep case (in process): median CPU {1e3 * statistics.median(cpus):.2f} ms, "
              f"best {1e3 * min(cpus):.2f} ms")
    if "ten" in only:
        ten = _ten_links()
        simulate(ten)
        walls = []
        for _ in range(max(3, args.repeat // 5)):
            t0 = time.perf_counter()
            simulate(ten)
            walls.append(time.perf_counter() - t0)
        print(f"ten links: median {statistics.median(walls):.3f} s, best {min(walls):.3f} s")


if __name__ == "__main__":
    main()
