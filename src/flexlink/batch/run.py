"""`sweep`: many variants of one scenario, on all local cores or a Dask cluster, into one
labelled Dataset (and netCDF file). Orchestration only; each case is `flexlink.simulate`."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Iterable, Iterator, Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._version import package_version
from ..channels import Channel
from ..channels.catalogue import catalogue
from ..model import Scenario
from ..results.atomic import check_writable
from ..results.matlab import write_mat_atomic
from ..results.netcdf import write_netcdf_atomic
from ..results.variables import Layout
from ..scenario.toml_writer import dump_toml
from ..simulation.common import MemoryEstimate, memory_problem, output_times, run_memory
from . import executors
from .cases import (
    BaseScenario,
    CaseChecks,
    LazyCases,
    case_problems,
    case_scenarios,
    check_paths,
    invalid_message,
    load_base,
    valid_cases,
)
from .dataset import SweepCollector
from .errors import SweepError, SweepInterrupted
from .parameters import GridParameter, RandomParameter, case_table, from_mappings
from .summaries import EXAMPLE as SUMMARY_EXAMPLE
from .summaries import Summary, parse_summaries
from .summaries import check_channels as check_summary_channels
from .worker import Case, ChunkResult, Kept, SharedResults

if TYPE_CHECKING:
    import xarray as xr

GridSpec = Mapping[str, Any] | Sequence[GridParameter] | None
RandomSpec = Mapping[str, Any] | Sequence[RandomParameter] | None


def sweep(base: str | Path | Mapping[str, Any], grid: GridSpec = None, random: RandomSpec = None,
          *, samples: int | None = None, seed: int | None = None, sampler: str = "random",
          channels: Sequence[str] | None = None,
          summaries: Sequence[str | Summary] = (), histories: bool = True,
          output: str | Path | None = None,
          workers: int | None = None, scheduler: Any = None, progress: bool = False,
          checkpoint_interval: float = 60.0, base_dir: Path | None = None,
          skip_invalid: bool = False) -> xr.Dataset:
    """Simulate every case of a grid and/or random sweep over numeric fields of ``base``.

    ``base``: a scenario file, or a parsed scenario dict (CSV paths relative to ``base_dir``).
    ``grid``: {path: values or 'linspace:a:b:n' / 'geomspace:a:b:n'}; ``random``: {path:
    'uniform:low:high' | 'loguniform:low:high' | 'normal:mean:std'} drawn ``samples`` times
    (``sampler`` 'random' or 'lhs', reproducible with ``seed``). ``channels``: keep only these.
    ``summaries``: per-case metrics ('peak:link2_tip_deflection', 'residual:CHANNEL:after=3',
    `flexlink.batch.summaries`), one variable over ``case`` each; ``histories=False`` keeps
    only them (no time axis: a 10⁵-case study in little memory and disk).
    Runs on ``workers`` local processes (default: every core) or, given ``scheduler`` (an
    address or a ``distributed.Client``), on a Dask cluster. Every case is validated first
    (SweepError). A failing case is recorded and the rest go on; on Ctrl-C the finished cases
    are written and `SweepInterrupted` (a KeyboardInterrupt) carries them. With ``output``
    the netCDF file is also replaced every ``checkpoint_interval`` s while the sweep runs.
    ``skip_invalid``: instead of refusing the sweep when some cases are invalid (a value out
    of range), run the valid ones and record the others as failed with their problems.
    Returns the Dataset described in `flexlink.batch.dataset`.
    """
    return run_sweep(base, grid, random, samples=samples, seed=seed, sampler=sampler,
                     channels=channels, summaries=summaries, histories=histories,
                     output=output, workers=workers, scheduler=scheduler, progress=progress,
                     checkpoint_interval=checkpoint_interval, base_dir=base_dir,
                     skip_invalid=skip_invalid, dataset=True).to_xarray()


def run_sweep(base: str | Path | Mapping[str, Any], grid: GridSpec = None,
              random: RandomSpec = None, *, samples: int | None = None, seed: int | None = None,
              sampler: str = "random", channels: Sequence[str] | None = None,
              summaries: Sequence[str | Summary] = (), histories: bool = True,
              output: str | Path | None = None, workers: int | None = None,
              scheduler: Any = None, progress: bool = False, checkpoint_interval: float = 60.0,
              base_dir: Path | None = None, skip_invalid: bool = False,
              dataset: bool = False) -> Layout:
    """`sweep`, returning the result's `Layout` (what its file holds) instead of the Dataset:
    the command, which writes the file and prints a summary, then never imports xarray and
    pandas (~0.7 s of CPU). ``dataset``: the caller makes a Dataset of it, so xarray is
    imported while the cases run. Ctrl-C raises `SweepInterrupted` with a Dataset either way.
    """
    if output is not None and Path(output).suffix.lower() not in (".nc", ".mat"):
        raise SweepError([(f"output {output}: name a netCDF file (.nc) or a MATLAB file "
                           "(.mat); the sweep writes no other format")])
    grids, randoms = _parameters(grid, random)
    table = case_table(grids, randoms, samples, seed, sampler)
    scenario_base = load_base(base, base_dir)
    check_paths(scenario_base, table)
    # What every case shares (numeric fields change neither the channels nor the time axis
    # nor the model path), from the base scenario, so that the workers can start first.
    template = scenario_base.build()
    _check_loops_close(template)
    selected = _check_channels(template, channels)
    metrics = _check_summaries(template, summaries, histories)
    kept = Kept(None if selected is None else tuple(selected), tuple(metrics), histories)
    local = _local_workers(workers, scheduler, table.count)
    check_sweep_memory(template, table.count,
                       (len(selected) if selected else None) if histories else 0)
    time_ = output_times(template.settings.t_end, template.settings.dt_out)
    shared, probed = None, ()
    if local > 1 and histories:  # worker processes: let them write into one shared array
        probed = _probe_channels(template, selected)
        if probed:
            shared = SharedResults.allocate(probed, table.count, time_.size)
    with contextlib.ExitStack() as stack:
        pool = None
        if local > 1:  # started now, with the compiled code, before the cases are checked
            pool = stack.enter_context(contextlib.closing(
                executors.local_processes(local, shared, preload=template)))
        # forked workers are idle until their first chunk: they check the cases; others
        # load the compiled code meanwhile, while this process checks them
        checks = pool.check_cases if pool is not None and pool.forked else None
        scenarios, invalid = _cases(scenario_base, table, skip_invalid, lazy=not histories,
                                    checks=checks)
        collector = SweepCollector(table, time_ if histories else None,
                                   _attributes(scenario_base, table), shared, probed,
                                   _summary_records(template, metrics), scenario_base)
        collector.add(ChunkResult(failed={i: invalid_message(m) for i, m in invalid.items()}))
        indexed = scenarios.indexed() if isinstance(scenarios, LazyCases) \
            else list(scenarios.items())
        checkpoint = _Checkpoint(output, checkpoint_interval)
        if output is not None:  # fail now, not after the cases ran
            check_writable(output)
        try:  # Ctrl-C while the workers start counts too (a forked worker may be quick)
            results = _executor(stack, indexed, kept, local, scheduler, pool)
            if dataset:
                _import_xarray_meanwhile()  # after the workers forked: a thread forbids fork
            bar = stack.enter_context(_progress(table.count, progress))
            bar.update(len(invalid))
            started = time.perf_counter()
            for chunk in results:
                collector.add(chunk)
                bar.update(len(chunk.done) + len(chunk.failed))
                checkpoint.maybe_write(collector)
            # what the progress bar's rate measures, for the summary
            collector.attrs["running_time_s"] = time.perf_counter() - started
        except KeyboardInterrupt:
            collector.attrs["sweep_state"] = "interrupted"
            stack.close()  # stop the workers before writing
            collector.settle()
            raise SweepInterrupted(checkpoint.write(collector).to_xarray()) from None
    collector.settle()
    collector.attrs["sweep_state"] = "finished"
    layout = checkpoint.write(collector)
    if output is not None:  # the sweep's page beside its file (results/report_html.py)
        from ..results.report_html import write_sweep_report

        write_sweep_report(Path(output), layout=layout)
    return layout


def check_sweep_memory(scenario: Scenario, cases: int, channels: int | None) -> None:
    """SweepError, before any case runs, if the sweep's result array (cases × channels ×
    samples × 8 bytes, twice: collected and in the Dataset written) and a run would not fit
    in memory; ``channels`` kept (None: all)."""
    run = run_memory(scenario)
    kept = channels if channels is not None else len(catalogue(scenario))
    per_sample = run.per_sample + 2 * 8 * kept * cases
    problem = memory_problem(MemoryEstimate(run.samples, per_sample), scenario.settings.t_end,
                             f"a sweep of {cases} cases × {kept} channels")
    if problem:
        raise SweepError([f"{problem}; or fewer cases or channels (--channels)"])


def _cases(base: BaseScenario, table: Any, skip_invalid: bool, lazy: bool,
           checks: CaseChecks | None = None
           ) -> tuple[Mapping[int, Case], dict[int, list[str]]]:
    """The scenario of every case to run (``lazy``: built where it runs, and checked by
    ``checks``: the workers, `cases.valid_cases`) and, with ``skip_invalid``, the problems
    of the invalid cases (without it an invalid case refuses the sweep: SweepError)."""
    if skip_invalid or lazy:
        scenarios, invalid = valid_cases(base, table, lazy, checks)
        if invalid and not skip_invalid:
            raise SweepError(case_problems(invalid, table))
        return scenarios, invalid
    return dict(enumerate(case_scenarios(base, table))), {}


def _parameters(grid: GridSpec, random: RandomSpec
                ) -> tuple[list[GridParameter], list[RandomParameter]]:
    grid_map = grid if isinstance(grid, Mapping) else None
    random_map = random if isinstance(random, Mapping) else None
    grids, randoms = from_mappings(grid_map, random_map)
    if grid is not None and grid_map is None:
        grids = list(grid)  # type: ignore[arg-type]
    if random is not None and random_map is None:
        randoms = list(random)  # type: ignore[arg-type]
    return grids, randoms


def _check_channels(scenario: Scenario, channels: Sequence[str] | None) -> list[str] | None:
    """Requested channels must be among those a run of the scenario produces."""
    if channels is None:
        return None
    known = [c.name for c in catalogue(scenario)]
    unknown = [c for c in channels if c not in known]
    if unknown or not channels:
        raise SweepError([f"unknown channel {c!r}; available: {', '.join(known)}"
                          for c in unknown] or ["channels: give at least one channel"])
    return list(dict.fromkeys(channels))


def _check_summaries(scenario: Scenario, summaries: Sequence[str | Summary],
                     histories: bool) -> list[Summary]:
    """The parsed summaries, each of a channel the scenario produces; a sweep must keep
    histories or some summary."""
    parsed = parse_summaries(summaries)
    check_summary_channels(parsed, [c.name for c in catalogue(scenario)],
                           scenario.settings.t_end)
    if not histories and not parsed:
        raise SweepError([("histories = false keeps nothing of the cases: give summaries "
                           f"(e.g. {SUMMARY_EXAMPLE}) or keep the histories")])
    return parsed


def _summary_records(scenario: Scenario, summaries: Sequence[Summary]
                     ) -> list[tuple[Summary, Channel]]:
    records = {c.name: c for c in catalogue(scenario)}
    return [(s, records[s.channel]) for s in summaries]


def _local_workers(workers: int | None, scheduler: Any, cases: int) -> int:
    """Local worker processes to start (0 on a Dask cluster, 1: run here)."""
    if scheduler is not None and workers is not None:
        raise SweepError([("give workers (local processes) or scheduler (a Dask cluster), "
                           "not both: a cluster's workers are set up when it is started")])
    if scheduler is not None:
        return 0
    count = workers if workers is not None else executors.available_cores()
    if isinstance(count, bool) or not isinstance(count, int) or count < 1:
        raise SweepError([f"workers must be an integer >= 1, got {workers!r}"])
    return min(count, cases)


def _import_xarray_meanwhile() -> None:
    """Import xarray (and the dask it probes for) and build a first Dataset in a background
    thread while the cases run: imports the collecting process would otherwise pay
    before the first case or, worse, when Ctrl-C is pressed. Whoever needs xarray first
    waits for the import there (Python's import lock)."""
    import threading

    def warm() -> None:
        try:
            import xarray

            xarray.Dataset({"case": ("case", [0])})
        except Exception:  # noqa: BLE001, S110 — the Dataset's writer reports it
            pass

    threading.Thread(target=warm, name="flexlink-import-xarray", daemon=True).start()


def _check_loops_close(template: Scenario) -> None:
    """Refuse the sweep when the base scenario's loops cannot be held at t = 0 (the check of
    its run): every case would fail with that reason. Cases whose drawn values open the
    loop fail on their own."""
    if not template.closures:
        return
    from ..dynamics.loops import LoopSystem
    from ..errors import SimulationError

    try:  # the loop system of the base's model, as its run builds it
        if template.settings.model == "nonlinear":
            from ..dynamics.nonlinear_loops import NonlinearLoopSystem
            from ..simulation.nonlinear_forward import nonlinear_forward_system

            NonlinearLoopSystem(nonlinear_forward_system(template), template.closures)
        else:
            from ..simulation.forward import forward_system

            LoopSystem(forward_system(template), template.closures)
    except SimulationError as exc:
        raise SweepError([f"the base scenario cannot run: {exc}"]) from None


def _probe_channels(scenario: Scenario, channels: list[str] | None) -> tuple[Channel, ...]:
    """The records of the channels every case produces (the catalogue's, in its order, or the
    requested ones in the requested order)."""
    records = {c.name: c for c in catalogue(scenario)}
    return tuple(records.values()) if channels is None else tuple(records[n] for n in channels)


def _executor(stack: contextlib.ExitStack, indexed: list[Any], kept: Kept,
              local: int, scheduler: Any, pool: executors.PoolResults | None
              ) -> Iterable[ChunkResult]:
    if scheduler is not None:
        client, opened = executors.connect(scheduler)
        if opened:
            stack.callback(client.close)
        cores = executors.dask_cores(client)
        generator = executors.dask_cluster(executors.make_chunks(indexed, cores), kept, client,
                                           cores)
    elif pool is not None:
        pool.submit(executors.make_chunks(indexed, local), kept)
        return pool
    else:
        generator = executors.in_process(executors.make_chunks(indexed, 1), kept)
    return stack.enter_context(contextlib.closing(generator))


def _attributes(base: BaseScenario, table: Any) -> dict[str, Any]:
    """The sweep's metadata: title and date_created (for the layout's CF attributes), then
    what defines the sweep. The seed is text: it has 64 bits, netCDF-3 integers 32."""
    parameters = "; ".join(f"{p.path} {p.description}" for p in table.parameters)
    attrs = {
        "title": f"flexlink sweep of {base.name}",
        "date_created": datetime.now(UTC).isoformat(timespec="seconds"),
        "flexlink_version": package_version(),
        "base_scenario_source": base.source,
        "base_scenario": dump_toml(base.resolved()),
        "parameters": parameters,
        "sampler": table.sampler,
        "sweep_state": "running",
    }
    if table.seed is not None:  # None: no random parameters
        attrs["seed"] = str(table.seed)
    return attrs


@contextlib.contextmanager
def _progress(total: int, enabled: bool) -> Iterator[Any]:
    from tqdm import tqdm

    class Bar(tqdm):  # type: ignore[misc, type-arg]
        # No monitor thread (tqdm keeps it after the last bar closes): it would stop the
        # command's process from ending without teardown (`cli._exit`). It only refreshes a
        # bar left without updates for 10 s; this one moves with every chunk.
        monitor_interval = 0

    bar = Bar(total=total, unit="case", disable=not enabled, smoothing=0.1)
    try:
        yield bar
    finally:
        bar.close()


class _Checkpoint:
    """Writes the Dataset to ``output`` atomically: at the end, and while running at most every
    ``interval`` seconds, so a crash keeps the finished cases. A MATLAB file if ``output``
    ends in ``.mat``, else netCDF; the same layout either way."""

    def __init__(self, output: str | Path | None, interval: float) -> None:
        self.output = None if output is None else Path(output)
        self.interval = interval
        self._last = time.monotonic()
        self._cost = 0.0

    def maybe_write(self, collector: SweepCollector) -> None:
        # never spend more than a tenth of the time writing; interval 0: after every chunk
        wait = max(self.interval, 10.0 * self._cost) if self.interval > 0 else 0.0
        if self.output is not None and time.monotonic() - self._last >= wait:
            self.write(collector)

    def write(self, collector: SweepCollector) -> Layout:
        """Write what was collected (if there is an output file); return its layout."""
        layout = collector.layout()
        if self.output is None:
            return layout
        started = time.monotonic()
        write = write_mat_atomic if self.output.suffix.lower() == ".mat" else write_netcdf_atomic
        write(layout, self.output)
        self._last = time.monotonic()
        self._cost = self._last - started
        return layout
