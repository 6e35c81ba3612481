"""What every model path shares: the output grid, progress, the validity check of the
first-order model, and the assembly of `Results` from the channel catalogue."""

from __future__ import annotations

import functools
import time
from collections.abc import Callable, Collection, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Self

import numpy as np

from .._version import package_version
from ..channels import Channel
from ..channels.catalogue import catalogue
from ..channels.shapes import LazyShapes, LinkShape
from ..errors import RunTooLarge, SimulationError
from ..model import Link, Scenario, Sensor
from ..results import Results
from ..results.mechanism_parts import parts_metadata
from ..solvers import Solution
from ..solvers.solution import StepReach
from .accuracy import accuracy_metadata, unestimated_metadata

_version = functools.lru_cache(maxsize=1)(package_version)  # the metadata lookup is slow

Progress = Callable[[float], None]


MEMORY_SHARE = 0.5  # of the memory available when a run starts: the rest for everything else


@dataclass(frozen=True)
class MemoryEstimate:
    """What a run's arrays take: ``samples`` output times of ``per_sample`` bytes each."""

    samples: int
    per_sample: int  # bytes per output time

    @property
    def total(self) -> float:
        """Bytes (a float: a grid of 10¹⁵ samples must not overflow)."""
        return float(self.samples) * self.per_sample


def sample_count(t_end: float, dt_out: float) -> int:
    """How many output times ``output_times`` makes, without making them."""
    return int(np.floor(t_end / dt_out + 1e-9)) + 2


def run_memory(scenario: Scenario) -> MemoryEstimate:
    """The arrays of one run per output time, 8 bytes each: every channel three times (the
    paths' values, `Results`, the writers' tables); the integrators' states and
    accelerations (Lawson keeps two solutions, 2 × (3n + 1)), the solution (3n), the joint
    history and frame motion (~16 per link) and the kinematical maps (9 n per link)."""
    n = sum(link.modes for link in scenario.chain.links)
    links = len(scenario.chain.links)
    values = 3 * len(catalogue(scenario)) + 9 * n + 2 + 16 * links + 9 * n * links
    settings = scenario.settings
    return MemoryEstimate(sample_count(settings.t_end, settings.dt_out), 8 * values)


# Bytes a run may need without asking the system how much is available.
ALWAYS_FITS = 50e6


def available_memory() -> int:
    """Bytes of memory available now (psutil if installed, else the free physical pages)."""
    try:
        import psutil

        return int(psutil.virtual_memory().available)
    except ImportError:
        import os

        return int(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))


def memory_problem(estimate: MemoryEstimate, t_end: float, what: str,
                   available: int | None = None) -> str | None:
    """Why ``what`` would not fit in memory, with the numbers and a coarser dt_out that
    fits; None if it fits within MEMORY_SHARE of the available memory."""
    available = available_memory() if available is None else available
    budget = MEMORY_SHARE * available
    if estimate.total <= budget:
        return None
    fit = max(1, int(budget // estimate.per_sample) - 2)  # intervals (sample_count: + 2)
    return (f"simulation.dt_out: {what} needs {estimate.samples:.3g} output samples × "
            f"{_size(estimate.per_sample)} = {_size(estimate.total)} of memory, more than "
            f"{MEMORY_SHARE:.0%} of the {_size(available)} available; dt_out = "
            f"{_round_up(t_end / fit):g} s or coarser fits (or a shorter t_end)")


def check_run_memory(scenario: Scenario) -> None:
    """RunTooLarge, before anything runs, if the run's arrays would not fit in memory."""
    check_input_table(scenario)
    estimate = run_memory(scenario)
    if estimate.total <= ALWAYS_FITS:
        return  # asking the system how much is free costs a noticeable part of a small run
    problem = memory_problem(estimate, scenario.settings.t_end, "this run")
    if problem:
        raise RunTooLarge(problem)


# Bytes per piece of a forward run's input table while it is made (solvers/input_table.py):
# its ends, times and values at 17 points and 9 coefficients of one input column, at least.
TABLE_PIECE_BYTES = 400


def check_input_table(scenario: Scenario) -> None:
    """RunTooLarge if the compiled forward integrator's input table, pieces of at most
    `input_table.MAX_PIECE` over the whole run whatever dt_out, would not fit in memory
    (a t_end of 1e9 s)."""
    settings = scenario.settings
    if not (scenario.is_forward and settings.model != "nonlinear"
            and settings.method in ("lawson", "magnus")):
        return  # the paths without the table
    from ..solvers.input_table import MAX_PIECE

    pieces = float(np.ceil(settings.t_end / MAX_PIECE))
    need = pieces * TABLE_PIECE_BYTES
    if need <= ALWAYS_FITS:
        return
    available = available_memory()
    budget = MEMORY_SHARE * available
    if need > budget:
        fits = budget / TABLE_PIECE_BYTES * MAX_PIECE
        raise RunTooLarge(
            f"simulation.t_end = {settings.t_end:g} s: this forward run tabulates its inputs "
            f"in pieces of at most {MAX_PIECE:g} s, {pieces:.3g} pieces × at least "
            f"{TABLE_PIECE_BYTES} B = {_size(need)} of memory, more than "
            f"{MEMORY_SHARE:.0%} of the {_size(available)} available; t_end = "
            f"{_round_down(fits):g} s or shorter fits")


def _round_down(value: float) -> float:
    """``value`` to one significant digit, rounded down."""
    decade = 10.0 ** np.floor(np.log10(value))
    return float(np.floor(value / decade) * decade)


def _size(count: float) -> str:
    """Bytes as B, kB, MB, GB, TB, PB (decimal)."""
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if count < 1000:
            return f"{count:.3g} {unit}"
        count /= 1000
    return f"{count:.3g} PB"


def _round_up(value: float) -> float:
    """The next number of the 1–2–5 series at or above ``value``."""
    decade = 10.0 ** np.floor(np.log10(value))
    for step in (1.0, 2.0, 5.0, 10.0):
        if step * decade >= value * (1 - 1e-12):
            return float(step * decade)
    return float(10 * decade)


def output_times(t_end: float, dt_out: float) -> np.ndarray:
    """0, dt_out, 2 dt_out, … up to and including t_end (s)."""
    count = int(np.floor(t_end / dt_out + 1e-9))
    t = np.arange(count + 1) * dt_out
    # np.isclose(t[-1], t_end) on two numbers, without its array machinery (~20 µs)
    close = abs(float(t[-1]) - t_end) <= 1e-8 + 1e-5 * abs(t_end)
    return t if close else np.append(t, t_end)


@dataclass(frozen=True)
class PathRun:
    """What a model path hands back: its solution, every channel's values by name (the
    catalogue's names), what it adds to the metadata, and every link's deformed shape on a
    grid of points (channels/shapes.py: what the animation draws)."""

    solution: Solution
    values: Mapping[str, np.ndarray]
    metadata: Mapping[str, Any] = field(default_factory=dict)
    shapes: Sequence[LinkShape] = ()
    # The sensors' readings of this run's motion for other sensors (sensors read the motion
    # and change none of it): where a path offers it, a sweep whose cases differ only in
    # their sensors reads each case's sensors from one run.
    read_sensors: Callable[[tuple[Sensor, ...]], dict[str, np.ndarray]] | None = None


def _check_finite(name: str, values: np.ndarray, t: np.ndarray) -> None:
    """NonFiniteResult naming the channel and the first time it is NaN or infinite: no run
    writes such values."""
    bad = ~np.isfinite(values)
    if bad.any():
        from ..options import NonFiniteResult

        first = int(np.argmax(bad.reshape(bad.shape[0], -1).any(axis=1))) if bad.ndim else 0
        when = f" from t = {t[first]:.6g} s" if bad.ndim and first < t.size else ""
        raise NonFiniteResult(f"channel {name} is not finite (NaN or infinity){when}: the "
                              "model diverged there; nothing was written")


def assemble_results(scenario: Scenario, run: PathRun, wall_time: float) -> Results:
    """`Results` with the catalogue's channels in its order and the common metadata."""
    solution = run.solution
    results = Results(time=solution.t, metadata={
        "scenario": scenario.name,
        "flexlink_version": _version(),
        "model": scenario.settings.model,
        "method": solution.method,
        **run.metadata,
        **solution.stats,
        **integration_metadata(solution),
        "wall_time_s": wall_time,
        **parts_metadata(scenario),  # what the animation draws besides the links
    })
    for channel, value in catalogue_values(scenario, run):
        results.add(channel, value)
    # LazyShapes stay lazy: most callers of simulate() never read them
    results.shapes = run.shapes if isinstance(run.shapes, LazyShapes) else list(run.shapes)
    return results


def catalogue_values(scenario: Scenario, run: PathRun,
                     kept: Collection[str] | None = None) -> list[tuple[Channel, np.ndarray]]:
    """The run's channels in the catalogue's order with their values, each checked finite
    (NonFiniteResult); ``kept``: those of these names only (the run may hold others)."""
    values = dict(run.values) if kept is None else \
        {name: v for name, v in run.values.items() if name in kept}
    out = []
    for channel in catalogue(scenario):
        if kept is not None and channel.name not in kept:
            continue
        value = values.pop(channel.name)
        _check_finite(channel.name, value, run.solution.t)
        out.append((channel, value))
    if values:  # a path computed a channel the catalogue does not list
        raise AssertionError(f"channels outside the catalogue: {', '.join(values)}")
    return out


def integration_metadata(solution: Solution) -> dict[str, Any]:
    """The tolerance the integrator was asked for (``rtol``) and the error estimate it reached
    (``error_estimate``, a fraction of the peak as rtol; absent where it makes none) with what
    that estimate measures (``error_estimate_measure``)."""
    accuracy = solution.accuracy
    if accuracy is None:
        return {}
    out: dict[str, Any] = {"rtol": accuracy.rtol}
    if accuracy.estimate is not None:
        out["error_estimate"] = accuracy.estimate
    out["error_estimate_measure"] = accuracy.measure
    return out


def check_tip_deflection(links: tuple[Link, ...], t: np.ndarray, deflection: np.ndarray,
                         geometric_stiffening: bool, axial_load: np.ndarray | None = None,
                         estimate: bool = True, inboard: np.ndarray | None = None,
                         shares: np.ndarray | None = None,
                         steps: StepReach | None = None) -> dict[str, Any]:
    """Metadata on the first-order model's validity: the largest tip deflection relative to
    its link's length and the expected error against the nonlinear model with its statement
    (`accuracy.accuracy_metadata`; a warning where it is large). A SimulationError where a
    deflection exceeds the length: the linear model has diverged (e.g. centrifugal softening
    without geometric stiffening above the first frequency).
    ``deflection``: |w(L)| of every link, (nt, links), m; ``axial_load``: each link's
    `accuracy.axial_load_parameter` (zero if not given); ``estimate``: False for a forward
    run, where the estimate is not calibrated (`accuracy.unestimated_metadata`);
    ``inboard``: `accuracy.hangs_on_elastic` of each link (none if not given); ``shares``:
    a forward run's `ForwardSystem.inertia_shares` (none if not given); ``steps``: the
    integrator's reach of the tips over every step (`solvers.solution.tip_bounds`, one row
    per link; none if it keeps none): a tip beyond its length between output samples is
    refused at the end of the first step beyond it."""
    lengths = np.array([link.length for link in links])
    ratio = deflection / lengths
    # Column by column: numpy's max over axis 0 of a (nt, few) array is slower.
    peaks = np.array([ratio[:, k].max() for k in range(len(links))]) if ratio.size \
        else np.zeros(len(links))
    # the first instant each tip was beyond its length: at an output sample, or at the end
    # of an integrator's step between samples (inf: never)
    first = np.full(len(links), np.inf)
    for k in range(len(links)):
        if not peaks[k] <= 1.0:  # (a NaN deflection is caught where the values are checked)
            beyond = ratio[:, k] > 1.0
            if beyond.any():
                first[k] = t[int(np.argmax(beyond))]
    stepped = np.full(len(links), np.inf) if steps is None else steps.beyond
    # a step ending at a sample (to round-off) is that sample
    between = stepped < first - 1e-9 * np.abs(np.where(np.isfinite(first), first, 0.0))
    when = np.where(between, stepped, first)
    if np.isfinite(when).any():
        k = int(np.argmin(when))
        raise deflection_error(links[k], float(when[k]), geometric_stiffening,
                               STEP_BEYOND + ")" if between[k] else "")
    worst = int(np.argmax(peaks))
    out = {"peak_tip_deflection_per_length": float(peaks[worst])}
    load = np.zeros(len(links)) if axial_load is None else axial_load
    if not estimate:
        return {**out, **unestimated_metadata(links, peaks, load, geometric_stiffening,
                                              shares)}
    return {**out, **accuracy_metadata(links, peaks, load, geometric_stiffening, inboard)}


# How a tip found beyond its length between output samples is placed in the error
# (`deflection_error`'s ``where``), closed by ")" or by what the run did there.
STEP_BEYOND = " (the end of the integrator's first step beyond it"


def deflection_error(link: Link, when: float, geometric_stiffening: bool, where: str = ""
                     ) -> SimulationError:
    """The error of a first-order run in which the tip of ``link`` deflected beyond its
    length at t = ``when`` (s); ``where``: how that instant was found (after the time)."""
    hint = ("; the paper's model has no geometric stiffening and diverges when a link "
            "spins faster than its first frequency: set geometric_stiffening = true"
            if not geometric_stiffening else "")
    return SimulationError(
        f"the tip deflection of {link.name} exceeds its length ({link.length:g} m) at "
        f"t = {when:.4g} s{where}: the first-order model is not valid here{hint}; "
        f"model = \"nonlinear\" handles large deflections")


class ProgressBar:
    """A tqdm bar over simulated time that only appears for runs longer than a second."""

    def __init__(self, t_end: float, enabled: bool) -> None:
        self.t_end = t_end
        self.enabled = enabled
        self._bar: Any = None
        self._shown = 0.0

    def __enter__(self) -> Self:
        if self.enabled:
            from tqdm import tqdm

            self._bar = tqdm(total=self.t_end, unit="s sim", delay=1.0, leave=False,
                             bar_format="{l_bar}{bar}| {n:.2f}/{total:.2f} s [{elapsed}<{remaining}]")
        return self

    def update(self, t: float) -> None:
        if self._bar is not None and t > self._shown:
            self._bar.update(t - self._shown)
            self._shown = t

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.close()


def timed(run: Callable[[], PathRun]) -> tuple[PathRun, float]:
    """The path's run and its wall time (s)."""
    started = time.perf_counter()
    out = run()
    return out, time.perf_counter() - started
