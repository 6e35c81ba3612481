"""How far a scenario's natural frequencies are from converged in its assumed modes.

The assumed modes are a Ritz basis: each frequency converges from above as modes are added, and
the highest kept frequency is usually the least converged. The estimate linearises the
first-order plant (`linearize`, at t = 0 unless told otherwise) with m₁ = n, m₂ = n + k and
m₃ = n + 2k modes per link, k = min(n, 8) (`levels`), and pairs each kept mode with the mode of
each finer basis that has its shape: the largest MAC (modal assurance criterion) of the links'
deflections, mass-weighted (each link's ∫ΦᵀΦ dm with its tip body), one-to-one (`pair`). Pairing by rank would compare
a link's top mode with another link's new modes that fall below it. With d₁ = f(m₁) − f(m₂),
d₂ = f(m₂) − f(m₃) and an error ∝ m^−p, d₂/d₁ gives p (held ≥ 1, the slowest a Ritz
frequency of these bases converges) and the error left with n modes is d₁/(1 − (m₁/m₂)^p):
Richardson's extrapolation (docs/modes.md, "Mode convergence"). A mode whose frequency rises
by THRESHOLD or more with more modes (a link on an elastic joint without hub inertia keeps
one, set by the mode count) has no converged counterpart: it is named, not estimated, and
warns only where the output can show it (below the output grid's Nyquist frequency). The
finest basis's modes paired with no kept one are modes the kept basis lacks: the band the
estimate vouches for ends below the lowest of them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from os import PathLike
from typing import Any

import numpy as np

from ..errors import RunTooLarge, SimulationError
from ..model import Scenario
from ..modes.pairing import deflection_vectors, pair
from .linear import LinearPlant
from .linearization import linearize
from .operating_point import At, NotLinearizable

# Estimated relative error of a kept frequency above which a run warns.
THRESHOLD = 0.01


def levels(n: int) -> tuple[int, int, int]:
    """The mode counts compared for a link with n modes: n, n + k, n + 2k, k = min(n, 8)."""
    k = min(n, 8)
    return n, n + k, n + 2 * k


def _order(ratio: float, m: tuple[int, int, int]) -> float:
    """p with (m₂^−p − m₃^−p)/(m₁^−p − m₂^−p) = ``ratio``, at least 1 (inf for ratio ≤ 0)."""
    def rho(p: float) -> float:
        return (m[1] ** -p - m[2] ** -p) / (m[0] ** -p - m[1] ** -p)

    if not ratio > 0:
        return math.inf
    if ratio >= rho(1.0):
        return 1.0
    low, high = 1.0, 200.0  # rho decreases with p
    if ratio <= rho(high):
        return high
    for _ in range(60):
        mid = 0.5 * (low + high)
        low, high = (mid, high) if rho(mid) > ratio else (low, mid)
    return 0.5 * (low + high)


@dataclass(frozen=True)
class ModeConvergence:
    """The plant's frequencies (Hz) with each link's modes, and those of the same modes (paired
    by shape) with more (`levels`)."""

    bases: tuple[str, ...]  # each link's basis ("rigid": no modes)
    links: tuple[str, ...]
    modes: tuple[int, ...]
    frequency_hz: np.ndarray  # (N,) every oscillatory mode kept, ascending
    refined_hz: np.ndarray  # (2, N): each kept mode's frequency with the 2nd and 3rd of `levels`
    where: str = "t = 0"  # the operating point, in words
    # the finest basis's frequencies (Hz) paired with no kept mode: modes the kept basis lacks
    missing_hz: np.ndarray = field(default_factory=lambda: np.zeros(0))
    nyquist_hz: float = math.inf  # the output grid's: the band the channels can show

    @property
    def rising(self) -> np.ndarray:
        """Whether each kept frequency rises by THRESHOLD or more with more modes: a mode of
        the truncated basis with no converged counterpart (bool, (N,))."""
        f, h = self.frequency_hz, self.refined_hz[-1]
        return (h - f >= THRESHOLD * f) & (h >= self.refined_hz[0])

    @property
    def error(self) -> np.ndarray:
        """The estimated relative error (f − f_converged)/f_converged of each kept frequency
        (≥ 0: a Ritz frequency is an upper bound; a frequency that moves up by less than
        THRESHOLD: its change; one that rises by more: 0, see `rising`)."""
        f, (g, h) = self.frequency_hz, self.refined_hz
        d1, d2 = f - g, g - h
        m = levels(max(self.modes, default=0))
        excess = np.zeros_like(f)
        for i in np.flatnonzero(d1 > 0):
            p = _order(d2[i] / d1[i], m)
            excess[i] = d1[i] / (1.0 - (m[0] / m[1]) ** p)
        # the converged value taken no lower than half the finest one (a bound, never reached)
        out = excess / np.maximum(f - excess, 0.5 * h)
        up = (d1 <= 0) & ~self.rising  # not monotone: the change itself, without extrapolating
        out[up] = np.abs(h[up] - f[up]) / h[up]
        return out

    @property
    def _physical(self) -> np.ndarray:
        return np.flatnonzero(~self.rising)

    @property
    def highest_hz(self) -> float:
        """The highest kept frequency that is not `rising` (0 Hz: none)."""
        kept = self._physical
        return float(self.frequency_hz[kept[-1]]) if kept.size else 0.0

    @property
    def highest_error(self) -> float:
        """The estimated relative error of `highest_hz` (0 without modes)."""
        kept = self._physical
        return float(self.error[kept[-1]]) if kept.size else 0.0

    @property
    def missing_below_hz(self) -> float:
        """The lowest frequency of a mode the kept basis lacks (inf: none found)."""
        return float(self.missing_hz.min()) if self.missing_hz.size else math.inf

    @property
    def converged_below_hz(self) -> float:
        """The highest kept frequency up to which every kept frequency is estimated within
        THRESHOLD and no mode is missing (0 Hz: not even the first)."""
        f = self.frequency_hz
        bad = np.flatnonzero((self.error >= THRESHOLD) | self.rising
                             | (f >= self.missing_below_hz))
        count = bad[0] if bad.size else self.error.size
        return float(f[count - 1]) if count else 0.0

    def basis_text(self) -> str:
        """``link1 clamped_free ×4, link2 tip_loaded ×4``."""
        return ", ".join(f"{name} {basis}" + (f" ×{n}" if n else "")
                         for name, basis, n in zip(self.links, self.bases, self.modes))

    def rising_text(self) -> str:
        """``163 Hz (610, 1343 Hz with 8, 12 modes per link)`` for each `rising` mode ("")."""
        return "; ".join(f"{self.frequency_hz[i]:.4g} Hz ({self._refined_text(i)})"
                         for i in np.flatnonzero(self.rising))

    def _refined_text(self, i: int) -> str:
        """``610, 1343 Hz with 8, 12 modes per link``: kept mode i with the finer bases."""
        counts = _counts(self.modes).split(", ")
        return (f"{self.refined_hz[0, i]:.4g}, {self.refined_hz[1, i]:.4g} Hz with "
                f"{counts[1]}, {counts[2]} modes per link")

    def warning(self) -> str | None:
        """A sentence when some kept frequency's estimated error is THRESHOLD or more, or a
        `rising` mode the output can show (below `nyquist_hz`) stands above a mode the basis
        lacks (the kept spectrum is not the structure's there)."""
        error = self.error
        n = len(error)
        f = self.frequency_hz
        misplaced = np.flatnonzero(self.rising & (f > self.missing_below_hz)
                                   & (f < self.nyquist_hz))
        if not n or (error.max() < THRESHOLD and not misplaced.size):
            return None
        below = self.converged_below_hz
        band = (f"those up to {below:.4g} Hz are within {100 * THRESHOLD:g}%" if below
                else f"none is within {100 * THRESHOLD:g}%")
        found = []
        if error.max() >= THRESHOLD:
            worst = int(np.argmax(error))
            which = "the highest" if worst == n - 1 else f"frequency {worst + 1}"
            found.append(f"{which} of the {n} frequencies at {self.where}, "
                         f"{self.frequency_hz[worst]:.4g} Hz, is an estimated "
                         f"{100 * error[worst]:.3g}% above its converged value "
                         f"(from {_counts(self.modes)} modes per link)")
        if misplaced.size:
            i = int(misplaced[0])
            found.append(f"frequency {i + 1} at {self.where}, {self.frequency_hz[i]:.4g} Hz, "
                         f"has no converged counterpart: it rises with more modes "
                         f"({self._refined_text(i)}) and stands above a mode at "
                         f"{self.missing_below_hz:.4g} Hz that this basis lacks")
        return (f"mode basis ({self.basis_text()}): {'; '.join(found)}; {band}. Raise `modes` "
                "(or choose `mode_shapes`) for the higher frequencies (docs/modes.md)")

    def metadata(self) -> dict[str, Any]:
        """Run attributes (results.nc, report.html, the summary)."""
        out: dict[str, Any] = {
            "mode_bases": self.basis_text(),
            "mode_convergence_at": self.where,
            "mode_convergence_modes": _counts(self.modes),
            "mode_convergence_highest_hz": self.highest_hz,
            "mode_convergence_highest_error": self.highest_error,
            "mode_convergence_converged_below_hz": self.converged_below_hz,
        }
        if self.missing_hz.size:
            out["mode_convergence_missing_below_hz"] = self.missing_below_hz
        if self.rising.any():
            out["mode_convergence_rising"] = self.rising_text()
        warning = self.warning()
        if warning:
            out["mode_convergence_warning"] = warning
        return out


def modes_line(meta: Mapping[str, Any]) -> str:
    """One summary line from `ModeConvergence.metadata`: each link's basis and the estimated
    error of the highest frequency."""
    return (f"modes: {meta['mode_bases']}; the highest frequency at "
            f"{meta['mode_convergence_at']} ({meta['mode_convergence_highest_hz']:.4g} Hz) is an "
            f"estimated {100 * meta['mode_convergence_highest_error']:.2g}% above its converged "
            f"value (from {meta['mode_convergence_modes']} modes per link)"
            + (f"; above it, rising with more modes (no converged counterpart): "
               f"{meta['mode_convergence_rising']}" if meta.get("mode_convergence_rising")
               else ""))


def _counts(modes: tuple[int, ...]) -> str:
    """``4, 8, 12`` (or ``3/4, 6/8, 9/12`` for links with different counts)."""
    flexible = sorted({n for n in modes if n}) or [0]
    return ", ".join("/".join(str(levels(n)[i]) for n in flexible) for i in range(3))


def mode_convergence(scenario: Scenario | str | PathLike[str], at: At = 0.0) -> ModeConvergence:
    """The estimate for ``scenario`` about ``at`` (as for `linearize`; default: the joints'
    state at t = 0, or a rest configuration of the t = 0 angles where that state cannot be
    linearised, e.g. a servo saturated there). The first-order equations, open loop
    (controllers left out). ``scenario``: a `Scenario`, or the path of a scenario file."""
    from ..scenario.load import as_scenario

    scenario = as_scenario(scenario, "mode_convergence")
    from ..model.basis import chosen_mode_shapes
    from ..simulation.rigid import with_modes
    from ..solvers.threads import single_threaded

    settings = replace(scenario.settings, model="first_order")
    # no sensors: the plant's output rows are not needed
    base = replace(scenario, settings=settings, controllers=(), sensors=())
    chain = base.chain
    kinds = chosen_mode_shapes(chain, base.base)
    bases = tuple("rigid" if link.rigid else kind for link, kind in zip(chain.links, kinds))
    # "auto" is resolved once here so that every count uses the same basis
    links = tuple(link if link.rigid else replace(link, mode_shapes=kind)
                  for link, kind in zip(chain.links, kinds))
    widths = tuple(levels(link.modes)[2] for link in links)
    found = []
    for i in range(3):
        scaled = tuple(link if link.rigid else with_modes(link, levels(link.modes)[i])
                       for link in links)
        with single_threaded():  # small eigenproblems: BLAS threads only contend
            found.append(_modes(replace(base, chain=replace(chain, links=scaled)), at, widths))
    (f, shapes, where), finer = found[0], found[1:]
    count = min(g.size for g, _, _ in found)  # a finer basis with fewer modes: the lowest
    paired = [pair(shapes[:count], s) for _, s, _ in finer]
    refined = np.stack([g[p] for (g, _, _), p in zip(finer, paired)])
    last = finer[-1][0]
    missing = np.setdiff1d(np.arange(last.size), paired[-1])
    return ModeConvergence(bases, tuple(link.name for link in links),
                           tuple(link.modes for link in links), f[:count], refined, where,
                           np.sort(last[missing]), 0.5 / scenario.settings.dt_out)


def _modes(scenario: Scenario, at: At, widths: tuple[int, ...]
           ) -> tuple[np.ndarray, np.ndarray, str]:
    """The plant's frequencies (Hz) about ``at``, each mode's shape vector (`_shape_vectors`)
    and the operating point in words."""
    plant, where = _plant(scenario, at)
    f, _, vectors = plant.modes()
    return f, _shape_vectors(scenario, plant.state_names, vectors, widths), where


def _shape_vectors(scenario: Scenario, names: tuple[str, ...], vectors: np.ndarray,
                   widths: tuple[int, ...]) -> np.ndarray:
    """(N, Σ widths) shape vectors (`modes.pairing.deflection_vectors`) of the plant's
    eigenvectors ``vectors`` (columns), their elastic rows found by name."""
    from ..dynamics.first_order import chain_modal_data

    index = {name: i for i, name in enumerate(names)}
    q = [vectors[[index[f"{link.name}_q{i + 1}"] for i in range(link.modes)]]
         for link in scenario.chain.links]
    return deflection_vectors(chain_modal_data(scenario.chain, scenario.base), q, widths)


# Why a scenario has no estimate without anything having failed: it has no linearisation
# about the operating point (a servo saturated or a load's kink there), no rest configuration
# to fall back on, or the run up to it would not fit in memory.
NO_ESTIMATE = (NotLinearizable, SimulationError)


def estimate_for_command(scenario: Scenario, at: At = 0.0
                         ) -> tuple[ModeConvergence | None, str | None]:
    """The estimate beside a run's, a `flexlink linearize` or a `flexlink modes` result:
    about ``at``, at t = 0 for a later time of a forward run (which would be simulated again
    with more modes). None where there is nothing to estimate (every link rigid) or the
    scenario cannot be linearised there (NO_ESTIMATE); for any other failure None and a
    warning naming it (the result beside it does not depend on the estimate)."""
    if isinstance(at, int | float) and at > 0 and scenario.is_forward:
        at = 0.0
    if not any(link.modes for link in scenario.chain.links):
        return None, None
    try:
        return mode_convergence(scenario, at), None
    except NO_ESTIMATE:
        return None, None
    except Exception as exc:  # noqa: BLE001 — reported: the result does not depend on it
        return None, (f"the mode-convergence estimate failed ({type(exc).__name__}: {exc}); "
                      "the results do not depend on it, but the accuracy of the modes is "
                      "not estimated")


def _plant(scenario: Scenario, at: At) -> tuple[LinearPlant, str]:
    """The plant about ``at`` and the operating point in words."""
    if isinstance(at, int | float) and at == 0.0:
        try:
            return linearize(scenario, at=0.0, outputs=[]), "t = 0"
        except (NotLinearizable, RunTooLarge):
            from ..model.joints import initial_angle

            at = [math.degrees(initial_angle(j)) for j in scenario.chain.joints]
            where = "the t = 0 angles at rest"
    elif isinstance(at, int | float):
        where = f"t = {at:g} s"
    plant = linearize(scenario, at=at, outputs=[])
    if not isinstance(at, int | float):
        where = _rest_text(at, plant.operating_point)
    return plant, where


def _rest_text(at: At, operating_point: Mapping[str, Any]) -> str:
    """``rest at joint1 = 30°, base_x = 0.1 m``: the configuration ``at`` (a mapping or one
    angle per joint) in words; for a closed loop (``operating_point`` of its plant) the
    angles the loop closed at (and a slider's travel), given or not, since a dependent
    joint's value in ``at`` is only a guess."""
    pairs = dict(at.items()) if isinstance(at, Mapping) else \
        {f"joint{i + 1}": float(a) for i, a in enumerate(at)}  # type: ignore[union-attr]
    dependent = str(operating_point.get("dependent_joints", "")).split()

    def value(key: str, given: float) -> str:
        if key in dependent and f"{key}_angle" in operating_point:
            return f"{math.degrees(operating_point[f'{key}_angle']):.4g}°"
        if key in dependent and f"{key}_position" in operating_point:
            return f"{operating_point[f'{key}_position']:.4g} m"
        return f"{given:g}" + ("°" if key.startswith("joint") or key == "base_attitude"
                               else " m")

    given = [f"{k} = {value(k, v)}" for k, v in pairs.items() if k not in dependent]
    closed = [f"{k} = {value(k, pairs.get(k, math.nan))}" for k in dependent]
    loop = f"the loop closed at {', '.join(closed)}" if closed else ""
    if not given:
        return f"rest, {loop}"
    return f"rest at {', '.join(given)}" + (f"; {loop}" if loop else "")
