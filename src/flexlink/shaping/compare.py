"""Cycloidal, shaped and optimised versions of one manoeuvre, run and measured alike.

`shaped_version` builds the input-shaped move of the same total duration (the base move
shortened by the shaper's length) for the arm's modes in its final configuration;
`residuals` runs any set of scenarios on plants with every frequency scaled by 1 + error and
takes the residual peak of one channel after each move (`residual.residual_peak`);
`residual_runs` makes many such runs at once on forked processes (the command's report).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..errors import SimulationError
from ..model import PointSensor, Scenario
from ..motion import Cycloidal, Shaped
from ..motion.shapers import ImpulseSequence, design
from ..simulation import simulate
from .optimize import Move
from .plants import arm_modes, scale_frequencies
from .residual import DEFAULT_WINDOW_S, residual_peak

TIP_SENSOR = "shaping_tip_deflection"  # the deflection sensor added at the last link's tip


def with_moves(scenario: Scenario, joints: Mapping[int, object]) -> Scenario:
    """``scenario`` with the motions of some joints replaced."""
    motions = list(scenario.chain.joints)
    for k, motion in joints.items():
        motions[k] = motion
    return dataclasses.replace(scenario, chain=dataclasses.replace(scenario.chain,
                                                                   joints=tuple(motions)))


def cycloidal_version(scenario: Scenario, moves: Sequence[Move]) -> Scenario:
    """Every move as a cycloid of its duration."""
    return with_moves(scenario, {m.joint: Cycloidal(m.from_deg, m.to_deg, m.start, m.duration)
                                 for m in moves})


def shaped_version(scenario: Scenario, moves: Sequence[Move], kind: str = "zvd",
                   modes: int = 2) -> tuple[Scenario, ImpulseSequence]:
    """Every move as a cycloid shaped by ``kind`` for the lowest ``modes`` modes of the arm
    at its final angles, the cycloid shortened so that the shaped move ends when the others
    do. ValueError if the shaper alone is longer than the move."""
    final = [float(np.degrees(j.evaluate(np.array([1e9]))[0][0])) for j in scenario.chain.joints]
    freqs, zetas = arm_modes(scenario, final, modes)
    shaper = design(kind, list(freqs), list(zetas))
    joints = {}
    for m in moves:
        base = m.duration - shaper.duration
        if base <= 0.0:
            raise ValueError(f"the {kind} shaper lasts {shaper.duration:.3g} s, longer than "
                             f"joint {m.joint + 1}'s move ({m.duration:g} s)")
        joints[m.joint] = Shaped(Cycloidal(m.from_deg, m.to_deg, m.start, base), shaper)
    return with_moves(scenario, joints), shaper


def with_tip_sensor(scenario: Scenario) -> Scenario:
    """``scenario`` with a deflection sensor at the last link's tip (named TIP_SENSOR)."""
    k = len(scenario.chain.links) - 1
    sensor = PointSensor(TIP_SENSOR, "deflection", k, scenario.chain.links[k].length)
    return dataclasses.replace(scenario, sensors=(*scenario.sensors, sensor))


def run_residual(scenario: Scenario, move_end: float, model: str = "first_order",
                 window: float = DEFAULT_WINDOW_S, dt_out: float = 0.002):
    """(Results, residual peak of the last link's tip deflection in m) of ``scenario`` run
    to move_end + window (s) in ``model``."""
    settings = dataclasses.replace(scenario.settings, t_end=move_end + window, dt_out=dt_out,
                                   model=model, rtol=1e-6 if model == "first_order" else 1e-4)
    run = with_tip_sensor(dataclasses.replace(scenario, settings=settings))
    results = simulate(run, shapes=False)
    return results, residual_peak(results, TIP_SENSOR, move_end, window)


def residuals(scenarios: Mapping[str, Scenario], move_end: float, errors: Sequence[float],
              model: str = "first_order", window: float = DEFAULT_WINDOW_S
              ) -> dict[str, np.ndarray]:
    """Residual peak (m) of each scenario on the plants of relative frequency error
    ``errors`` (0.1: every frequency 10 % higher than the design's); NaN where the run fails
    (the model diverges on that plant)."""
    out = {}
    for label, scenario in scenarios.items():
        out[label] = np.array([residual_or_nan(scale_frequencies(scenario, 1.0 + e), move_end,
                                               model, window) for e in errors])
    return out


def residual_or_nan(scenario: Scenario, move_end: float, model: str = "first_order",
                    window: float = DEFAULT_WINDOW_S) -> float:
    """`run_residual`'s peak (m), or NaN where the run fails (the model diverges)."""
    try:
        return run_residual(scenario, move_end, model, window)[1]
    except SimulationError:
        return math.nan


@dataclass(frozen=True)
class Residual:
    """One run's residual: its peak (m; NaN where the run failed: ``error`` says why) and,
    where asked, the last link's tip deflection (m) against time (s)."""

    peak: float
    time: np.ndarray | None = None
    tip: np.ndarray | None = None
    error: str | None = None


Check = tuple[Scenario, str, bool]  # (scenario, model, keep the tip trace)


def residual_runs(checks: Sequence[Check], move_end: float, workers: int = 1,
                  window: float = DEFAULT_WINDOW_S) -> list[Residual]:
    """`run_residual` of every (scenario, model, keep the trace) in ``checks``, in order, on
    ``workers`` processes forked from this one (here where it cannot fork: one worker, one
    check, other threads running, or not Linux); a failed run (SimulationError) is a
    `Residual` with a NaN peak and the error's message."""
    pool = _fork_pool(workers) if len(checks) > 1 else None
    if pool is None:
        return [check_residual(c, move_end, window) for c in checks]
    from concurrent.futures.process import BrokenProcessPool

    from ..batch.executors import stop_pool

    _CHECKS[:] = checks  # the workers fork at the first task and read them by index
    count = len(checks)
    try:
        return list(pool.map(_residual_of, range(count), [move_end] * count,
                             [window] * count))
    except BrokenProcessPool:  # a worker died (killed, out of memory): the runs here
        pool.shutdown()
        return [check_residual(c, move_end, window) for c in checks]
    except BaseException:  # Ctrl-C: the queued runs are not waited for
        stop_pool(pool)
        raise
    finally:
        pool.shutdown()  # at once after stop_pool
        _CHECKS.clear()


_CHECKS: list[Check] = []  # `residual_runs`' checks while its pool runs


def _fork_pool(workers: int) -> ProcessPoolExecutor | None:
    """A pool of ``workers`` processes forked from this one (they inherit `_CHECKS` and the
    loaded compiled code), or None where forking is unavailable or unsafe."""
    import multiprocessing
    import sys
    import threading

    if (workers < 2 or not sys.platform.startswith("linux")
            or "fork" not in multiprocessing.get_all_start_methods()
            or threading.active_count() > 1):
        return None
    from ..batch.executors import init_pool_worker

    return ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork"),
                               initializer=init_pool_worker)


def _residual_of(index: int, move_end: float, window: float) -> Residual:
    return check_residual(_CHECKS[index], move_end, window)


def check_residual(check: Check, move_end: float, window: float = DEFAULT_WINDOW_S
                   ) -> Residual:
    """`run_residual` of one check (scenario, model, keep the trace) as a `Residual`."""
    scenario, model, keep = check
    try:
        results, peak = run_residual(scenario, move_end, model, window)
    except SimulationError as exc:
        return Residual(math.nan, error=str(exc))
    if not keep:
        return Residual(peak)
    return Residual(peak, np.asarray(results.time), np.asarray(results[TIP_SENSOR]))


def band_summary(errors_pct: Sequence[float], cycloidal: np.ndarray, optimised: np.ndarray
                 ) -> dict[str, object]:
    """The robustness of a move over a band of frequency errors: residual peaks (m) of the
    cycloidal and optimised moves, their ratio per error, and the worst ratio (where the
    optimised move gains least; a NaN residual is a diverged run)."""
    ratio = np.asarray(cycloidal) / np.asarray(optimised)
    finite = np.isfinite(ratio)
    worst = int(np.flatnonzero(finite)[np.argmin(ratio[finite])]) if finite.any() else None
    return {"errors_pct": [float(e) for e in errors_pct],
            "cycloidal_m": [float(v) for v in cycloidal],
            "optimised_m": [float(v) for v in optimised],
            "ratio": [float(v) for v in ratio],
            "worst_ratio": None if worst is None else float(ratio[worst]),
            "worst_at_pct": None if worst is None else float(errors_pct[worst])}


__all__ = ["TIP_SENSOR", "Residual", "band_summary", "check_residual", "cycloidal_version",
           "residual_or_nan", "residual_runs", "residuals", "run_residual", "shaped_version",
           "with_moves", "with_tip_sensor"]
