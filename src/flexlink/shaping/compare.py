"""Cycloidal, shaped and optimised versions of one manoeuvre, run and measured alike.

`shaped_version` builds the input-shaped move of the same total duration (the base move
shortened by the shaper's length) for the arm's modes in its final configuration;
`residuals` runs any set of scenarios on plants with every frequency scaled by 1 + error and
takes the residual peak of one channel after each move (`residual.residual_peak`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence

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


__all__ = ["TIP_SENSOR", "band_summary", "cycloidal_version", "residual_or_nan", "residuals",
           "run_residual", "shaped_version", "with_moves", "with_tip_sensor"]
