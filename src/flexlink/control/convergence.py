"""How far a scenario's natural frequencies are from converged in its assumed modes.

The assumed modes are a Ritz basis: each frequency converges from above as modes are added, and
the highest kept frequency is the least converged. The estimate linearises the first-order
plant (`linearize`, at t = 0 unless told otherwise) with m₁ = n, m₂ = n + k and m₃ = n + 2k
modes per link, k = min(n, 8) (`levels`), and matches the frequencies by rank. With
d₁ = f(m₁) − f(m₂), d₂ = f(m₂) − f(m₃) and an error ∝ m^−p, d₂/d₁ gives p (held ≥ 1, the
slowest a Ritz frequency of these bases converges) and the error left with n modes is
d₁/(1 − (m₁/m₂)^p): Richardson's extrapolation (docs/modes.md, "Mode convergence").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..model import Scenario
from .linearization import linearize
from .operating_point import At

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
    """The plant's frequencies (Hz) with each link's modes and with more (`levels`)."""

    bases: tuple[str, ...]  # each link's basis ("rigid": no modes)
    links: tuple[str, ...]
    modes: tuple[int, ...]
    frequency_hz: np.ndarray  # (N,) every oscillatory mode kept, ascending
    refined_hz: np.ndarray  # (2, N): the N lowest with the 2nd and 3rd of `levels`
    where: str = "t = 0"  # the operating point, in words

    @property
    def error(self) -> np.ndarray:
        """The estimated relative error (f − f_converged)/f_converged of each kept frequency
        (≥ 0: a Ritz frequency is an upper bound)."""
        f, (g, h) = self.frequency_hz, self.refined_hz
        d1, d2 = f - g, g - h
        m = levels(max(self.modes, default=0))
        excess = np.zeros_like(f)
        for i in np.flatnonzero(d1 > 0):
            p = _order(d2[i] / d1[i], m)
            excess[i] = d1[i] / (1.0 - (m[0] / m[1]) ** p)
        # the converged value taken no lower than half the finest one (a bound, never reached)
        return excess / np.maximum(f - excess, 0.5 * h)

    @property
    def highest_error(self) -> float:
        """The estimated relative error of the highest kept frequency (0 without modes)."""
        return float(self.error[-1]) if self.error.size else 0.0

    @property
    def converged_below_hz(self) -> float:
        """The highest frequency up to which every kept frequency is estimated within
        THRESHOLD (0 Hz: not even the first)."""
        bad = np.flatnonzero(self.error >= THRESHOLD)
        count = bad[0] if bad.size else self.error.size
        return float(self.frequency_hz[count - 1]) if count else 0.0

    def basis_text(self) -> str:
        """``link1 clamped_free ×4, link2 tip_loaded ×4``."""
        return ", ".join(f"{name} {basis}" + (f" ×{n}" if n else "")
                         for name, basis, n in zip(self.links, self.bases, self.modes))

    def warning(self) -> str | None:
        """A sentence when some kept frequency's estimated error is THRESHOLD or more."""
        error = self.error
        if not error.size or error.max() < THRESHOLD:
            return None
        worst = int(np.argmax(error))
        n = len(error)
        which = ("the highest" if worst == n - 1 else f"frequency {worst + 1}") + \
            f" of the {n} frequencies at {self.where}"
        below = self.converged_below_hz
        band = (f"those up to {below:.4g} Hz are within {100 * THRESHOLD:g}%" if below
                else f"none is within {100 * THRESHOLD:g}%")
        return (f"mode basis ({self.basis_text()}): {which}, {self.frequency_hz[worst]:.4g} Hz, "
                f"is an estimated {100 * error[worst]:.3g}% above its converged value "
                f"(from {_counts(self.modes)} modes per link); {band}. Raise `modes` "
                "(or choose `mode_shapes`) for the higher frequencies (docs/modes.md)")

    def metadata(self) -> dict[str, Any]:
        """Run attributes (results.nc, report.html, the summary)."""
        out: dict[str, Any] = {
            "mode_bases": self.basis_text(),
            "mode_convergence_at": self.where,
            "mode_convergence_modes": _counts(self.modes),
            "mode_convergence_highest_hz": float(self.frequency_hz[-1])
            if self.frequency_hz.size else 0.0,
            "mode_convergence_highest_error": self.highest_error,
            "mode_convergence_converged_below_hz": self.converged_below_hz,
        }
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
            f"value (from {meta['mode_convergence_modes']} modes per link)")


def _counts(modes: tuple[int, ...]) -> str:
    """``4, 8, 12`` (or ``3/4, 6/8, 9/12`` for links with different counts)."""
    flexible = sorted({n for n in modes if n}) or [0]
    return ", ".join("/".join(str(levels(n)[i]) for n in flexible) for i in range(3))


def mode_convergence(scenario: Scenario, at: At = 0.0) -> ModeConvergence:
    """The estimate for ``scenario`` about ``at`` (as for `linearize`; default: the joints'
    state at t = 0, or a rest configuration of the t = 0 angles where that state cannot be
    linearised, e.g. a servo saturated there). The first-order equations, open loop
    (controllers left out)."""
    from ..model.basis import chosen_mode_shapes
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
    found = []
    for i in range(3):
        scaled = tuple(link if link.rigid else replace(link, modes=levels(link.modes)[i])
                       for link in links)
        with single_threaded():  # small eigenproblems: BLAS threads only contend
            found.append(_frequencies(replace(base, chain=replace(chain, links=scaled)), at))
    count = min(f.size for f, _ in found)
    return ModeConvergence(bases, tuple(link.name for link in links),
                           tuple(link.modes for link in links), found[0][0][:count],
                           np.stack([f[:count] for f, _ in found[1:]]), found[0][1])


def estimate_for_command(scenario: Scenario, at: At = 0.0) -> ModeConvergence | None:
    """The estimate beside a `flexlink linearize` or `flexlink modes` result: about ``at``,
    at t = 0 for a later time of a forward run (which would be simulated again with more
    modes); None where the scenario cannot be linearised there."""
    if isinstance(at, int | float) and at > 0 and scenario.is_forward:
        at = 0.0
    try:
        return mode_convergence(scenario, at)
    except Exception:  # noqa: BLE001 — an estimate beside the result, never its failure
        return None


def _frequencies(scenario: Scenario, at: At) -> tuple[np.ndarray, str]:
    """The plant's frequencies (Hz) about ``at`` and the operating point in words."""
    if isinstance(at, int | float) and at == 0.0:
        try:
            return linearize(scenario, at=0.0, outputs=[]).modes()[0], "t = 0"
        except ValueError:
            from ..model.joints import initial_angle

            at = [math.degrees(initial_angle(j)) for j in scenario.chain.joints]
            where = "the t = 0 angles at rest"
    elif isinstance(at, int | float):
        where = f"t = {at:g} s"
    plant = linearize(scenario, at=at, outputs=[])
    if not isinstance(at, int | float):
        where = _rest_text(at, plant.operating_point)
    return plant.modes()[0], where


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
