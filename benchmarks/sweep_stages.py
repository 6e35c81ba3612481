"""Where a sweep case's CPU time goes: the stages of a worker's chunks, timed in one process.

    python benchmarks/sweep_stages.py [--cases 192] [--vary numbers|model|sensors] [--chunk 32]

Draws the paper-experiment variants of ``benchmarks/batch.py`` (same kinds, seed 1), runs them
through a worker's `run_chunk` in chunks of ``--chunk`` cases keeping the four summaries of
``batch.py --summaries-only`` (one chunk first, untimed, to load the kernels), and prints the
CPU time (``time.thread_time``) of each stage per case, inclusive of the stages called inside
it, with its calls per case, then the process's CPU per case over the timed chunks. Indented
stages run inside the stage above them. The timers themselves add a few µs a call; on a
shared machine CPU times still vary by ±10 % between runs. To compare two trees, run the
script with each tree's ``src`` first on ``PYTHONPATH``.
"""

from __future__ import annotations

import argparse
import collections
import functools
import importlib
import time
from collections.abc import Callable
from typing import Any

from batch import KINDS, SENSOR_SUMMARIES, SUMMARIES

# (module, attribute — "Class.method" for a method, depth in the call tree): patched where the
# callers look them up (a name imported inside a function body is looked up at each call).
STAGES = [
    ("flexlink.batch.worker", "LazyCase.build", 0),
    ("flexlink.batch.grouped", "_system", 0),
    ("flexlink.simulation.rigid", "chain_modal_data", 1),
    ("flexlink.simulation.prescribed", "prescribed_system", 1),
    ("flexlink.solvers.lawson", "prepare", 0),
    ("flexlink.solvers.coefficient_table", "_initial_blocks", 1),
    ("flexlink.dynamics.first_order", "FirstOrderSystem.coefficient_keys", 2),
    ("flexlink.dynamics.first_order", "FirstOrderSystem.resting_intervals", 2),
    ("flexlink.solvers.coefficient_table", "_Sampler.at", 1),
    ("flexlink.dynamics.prescribed_kernel", "forward_data", 2),
    ("flexlink.dynamics._prescribed_numba", "state_rows", 2),
    ("flexlink.solvers.coefficient_table", "_assemble_table", 1),
    ("flexlink.solvers.lawson_batch", "with_propagators", 0),
    ("flexlink.solvers.lawson_batch", "expm_balanced_many", 1),
    ("flexlink.solvers.lawson_batch", "first_passes", 0),
    ("flexlink.solvers._lawson_batch_numba", "lawson_blocks_batch", 1),
    ("flexlink.solvers.lawson", "first_pass", 0),
    ("flexlink.solvers._lawson_numba", "lawson_blocks", 1),
    ("flexlink.solvers.lawson", "finish", 0),
    ("flexlink.batch.runner", "CaseRunner.run", 0),
    ("flexlink.simulation.prescribed", "prescribed_readings", 1),
    ("flexlink.dynamics._prescribed_numba", "channels", 2),
    ("flexlink.dynamics.first_order", "FirstOrderSystem.joint_history", 0),
]


def timed(totals: dict[str, float], calls: collections.Counter[str], label: str,
          function: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(function)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        started = time.thread_time()
        try:
            return function(*args, **kwargs)
        finally:
            totals[label] += time.thread_time() - started
            calls[label] += 1
    return wrapper


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=192)
    parser.add_argument("--vary", default="numbers", choices=sorted(KINDS))
    parser.add_argument("--chunk", type=int, default=32)
    args = parser.parse_args()

    from flexlink.batch.cases import check_paths, load_base
    from flexlink.batch.parameters import case_table, from_mappings
    from flexlink.batch.summaries import parse_summaries
    from flexlink.batch.worker import Kept, LazyCase, run_chunk
    from flexlink.scenario import paper_experiment_path

    random, summaries, _ = KINDS[args.vary]
    base = load_base(paper_experiment_path())
    grids, randoms = from_mappings(None, random)
    table = case_table(grids, randoms, args.cases + args.chunk, seed=1)
    paths = check_paths(base, table)
    cases = [(i, LazyCase(base, {paths[p]: v for p, v in table.case(i).items()}))
             for i in range(table.count)]
    metrics = parse_summaries(SENSOR_SUMMARIES if summaries is SENSOR_SUMMARIES else SUMMARIES)
    kept = Kept(summaries=tuple(metrics), histories=False)

    totals: dict[str, float] = collections.defaultdict(float)
    calls: collections.Counter[str] = collections.Counter()
    for module_name, attribute, _ in STAGES:
        owner: Any = importlib.import_module(module_name)
        *outer, name = attribute.split(".")
        for part in outer:
            owner = getattr(owner, part)
        if hasattr(owner, name):  # a stage another tree may not have
            setattr(owner, name, timed(totals, calls, attribute, getattr(owner, name)))

    run_chunk(cases[:args.chunk], kept)  # loads the kernels, fills the per-process caches
    totals.clear()
    calls.clear()
    timed_cases = cases[args.chunk:]
    started = time.process_time()
    failed = 0
    for lo in range(0, len(timed_cases), args.chunk):
        failed += len(run_chunk(timed_cases[lo: lo + args.chunk], kept).failed)
    cpu = time.process_time() - started
    count = len(timed_cases)
    print(f"{count} paper-experiment {args.vary} variants in chunks of {args.chunk}, "
          f"{failed} failed; CPU per case [ms], inclusive, and calls per case")
    for _, attribute, depth in STAGES:
        if calls[attribute]:
            print(f"{'  ' * depth + attribute:48s} {1e3 * totals[attribute] / count:7.3f} "
                  f"{calls[attribute] / count:6.2f}")
    print(f"{'process CPU per case':48s} {1e3 * cpu / count:7.3f}")


if __name__ == "__main__":
    main()
