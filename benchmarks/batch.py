"""Batch throughput: N variants of the paper experiment through `flexlink.sweep` on all cores.

    python benchmarks/batch.py [--cases 1000] [--workers N] [--channels a,b] [--scheduler ADDR]

The variants draw link 1's unknown modulus E (20-40 GPa, the paper gives none) and both joint
move durations (0.8-1.2 s) at random (seed 1). Prints one line per quantity: wall time of the
whole sweep (validation, worker start-up, runs, collection), runs per second, the sum of the
cases' own run times (their serial cost), the parallel efficiency, the median wall and CPU
time of one case (on a shared machine CPU time shows the work, wall time the wait), the peak memory
(resident set of this process plus its worker processes, sampled every 20 ms).
"""

from __future__ import annotations

import argparse
import platform
import threading
import time

import numpy as np

from flexlink import sweep
from flexlink.batch.executors import available_cores
from flexlink.scenario import paper_experiment_path

RANDOM = {
    "links[0].E": "uniform:20e9:40e9",
    "joints[0].motion[0].duration": "uniform:0.8:1.2",
    "joints[1].motion[0].duration": "uniform:0.8:1.2",
}


class PeakMemory:
    """Peak summed resident memory (bytes) of this process and its descendants."""

    def __init__(self, interval: float = 0.02) -> None:
        self.interval = interval
        self.peak = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._sample, daemon=True)

    def __enter__(self) -> PeakMemory:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def _sample(self) -> None:
        try:
            import psutil  # comes with dask[distributed]; else only this process is measured
        except ImportError:
            psutil = None
        while not self._stop.is_set():
            if psutil is None:
                import resource

                self.peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
            else:
                me = psutil.Process()
                total = 0
                for process in [me, *me.children(recursive=True)]:
                    try:
                        total += process.memory_info().rss
                    except psutil.Error:  # a worker that just exited
                        pass
                self.peak = max(self.peak, total)
            self._stop.wait(self.interval)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=1000)
    parser.add_argument("--workers", type=int, default=None, help="default: every core")
    parser.add_argument("--channels", default=None, help="comma-separated (default: all)")
    parser.add_argument("--scheduler", default=None, help="Dask scheduler address")
    args = parser.parse_args()
    channels = args.channels.split(",") if args.channels else None
    workers = args.workers or available_cores()

    with PeakMemory() as memory:
        started = time.perf_counter()
        dataset = sweep(paper_experiment_path(), random=RANDOM, samples=args.cases, seed=1,
                        channels=channels, workers=workers, scheduler=args.scheduler,
                        progress=True)
        wall = time.perf_counter() - started
    ok = int(dataset.attrs["cases_ok"])
    serial = float(dataset.wall_time.sum())
    where = args.scheduler or f"{workers} local worker processes"
    print(f"batch of {args.cases} paper-experiment variants (t_end = "
          f"{float(dataset.time[-1]):g} s, {dataset.sizes['time']} samples, "
          f"{sum(1 for v in dataset.data_vars.values() if v.dims == ('case', 'time'))} "
          f"channels) on {where}; {platform.processor() or platform.machine()}, "
          f"python {platform.python_version()}")
    print(f"{'cases ok / failed':34s} {ok} / {int(dataset.attrs['cases_failed'])}")
    print(f"{'wall time, whole sweep [s]':34s} {wall:.3f}")
    print(f"{'runs per second':34s} {args.cases / wall:.1f}")
    print(f"{'sum of case run times [s]':34s} {serial:.3f}")
    print(f"{'parallel efficiency':34s} {serial / (wall * workers):.2f}")
    print(f"{'median case run time [ms]':34s} {1e3 * float(np.median(dataset.wall_time)):.1f}")
    print(f"{'median case CPU time [ms]':34s} {1e3 * float(np.median(dataset.cpu_time)):.1f}")
    print(f"{'peak memory, all processes [MB]':34s} {memory.peak / 1e6:.0f}")


if __name__ == "__main__":
    main()
