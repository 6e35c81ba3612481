"""Links too stiff to matter, run as rigid links (prescribed joints only).

The integrators' step follows the highest modal frequency (solvers/magnus.py:initial_step), so
a link a million times stiffer than the rest costs a million times more steps — for vibration
far above anything the output grid shows and a deflection far below the run's tolerance. Such
a link is run rigid (no modes, its mass, tip mass and inertia kept), which changes the results
by less than ``rtol`` of its length; the run's ``rigid_links`` attribute names it. Forward
runs are not changed: their joint accelerations, which set the deflection, are not known
before the run. There a link whose first mode is above the output grid's Nyquist frequency,
or whose highest mode alone sets the step, is named in a warning with the fix, and the
nonlinear model, whose step control does not converge on a link UNRESOLVED_FACTOR times
beyond the Nyquist frequency, refuses it (`stiff_forward_links`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from itertools import pairwise

import numpy as np

from ..dynamics.first_order import chain_modal_data
from ..dynamics.histories import input_breakpoints
from ..dynamics.kinematics import frame_motion, joint_history
from ..errors import SimulationError
from ..model import Link, Scenario
from ..modes import modal_data
from ..modes.pairing import deflection_vectors, pair

# The first frequency must be this many times the output grid's Nyquist frequency: its
# vibration is then invisible in the output (it would only alias).
UNRESOLVED_FACTOR = 10.0
# Static tip deflection of a uniform cantilever under a uniform acceleration a is
# 1.55 a/ω1² (q L⁴/8EI with ω1² = 12.36 EI/mL⁴); 2 covers tip masses and inner loads.
DEFLECTION_FACTOR = 2.0


def rigid_body(link: Link) -> Link:
    """The link without modes (rigid): same mass, tip mass and tip inertia."""
    return dataclasses.replace(link, modes=0, initial_modal_rates=())


def with_modes(link: Link, n: int) -> Link:
    """The link with n modes; its initial modal rates (if any) cut to n or padded with
    zeros."""
    rates = link.initial_modal_rates
    if rates:
        rates = tuple(rates[:n]) + (0.0,) * max(n - len(rates), 0)
    return dataclasses.replace(link, modes=n, initial_modal_rates=rates)


def peak_accelerations(scenario: Scenario, t: np.ndarray) -> np.ndarray:
    """Per link, a bound of the largest rigid-body acceleration of any of its points (m/s²),
    gravity's −g included, over the prescribed motion at times t (s): |origin| + L·√(ω⁴ + ω̇²)."""
    links = scenario.chain.links
    rigid = [modal_data(rigid_body(link)) for link in links]
    fr = frame_motion(joint_history(scenario.chain.joints, t), rigid, [0] * len(links), 0,
                      scenario.settings.gravity)
    lengths = np.array([link.length for link in links])
    spin = np.sqrt(fr.omega**4 + fr.alpha**2) * lengths
    return (np.linalg.norm(fr.origin_accel, axis=-1) + spin).max(axis=0)


# Samples of each interval between the motions' breakpoints at which the peak accelerations
# are sought: the output grid alone can miss a whole move (dt_out longer than the move).
SAMPLES_PER_INTERVAL = 65


def motion_times(scenario: Scenario, t: np.ndarray) -> np.ndarray:
    """The output times ``t`` (s) with the instants that resolve every prescribed motion: each
    interval between its breakpoints (a move's start and end) sampled SAMPLES_PER_INTERVAL
    times, and a measured motion's own samples, within the run."""
    t_end = float(t[-1])
    edges = input_breakpoints(scenario.chain.joints)
    inside = edges[(edges > t[0]) & (edges < t_end)]
    edges = np.unique(np.concatenate([[float(t[0]), t_end], inside]))
    parts = [t] + [np.linspace(a, b, SAMPLES_PER_INTERVAL) for a, b in pairwise(edges)]
    for joint in scenario.chain.joints:
        samples = getattr(joint, "time_s", None)
        if samples is not None:
            parts.append(samples[(samples >= t[0]) & (samples <= t_end)])
    return np.unique(np.concatenate(parts))


def quasi_rigid_links(scenario: Scenario, t: np.ndarray) -> list[int]:
    """Indices of the flexible links whose first frequency is above UNRESOLVED_FACTOR × the
    output grid's Nyquist frequency and whose estimated quasi-static deflection is below
    ``rtol`` × their length; none for forward runs. Remembered per scenario for the last t
    (a sweep's worker asks before it integrates a chunk's cases, then the case's run)."""
    if scenario.is_forward:
        return []
    kept = scenario.__dict__.get("_quasi_rigid")
    if kept is not None and kept[0].shape == t.shape and np.array_equal(kept[0], t):
        return list(kept[1])
    out = _quasi_rigid_links(scenario, t)
    object.__setattr__(scenario, "_quasi_rigid", (np.array(t, dtype=float), tuple(out)))
    return out


def _quasi_rigid_links(scenario: Scenario, t: np.ndarray) -> list[int]:
    settings = scenario.settings
    nyquist = 0.5 / settings.dt_out  # Hz
    modal = chain_modal_data(scenario.chain)
    candidates = [k for k, d in enumerate(modal)
                  if d.n and d.natural_frequencies_hz[0] > UNRESOLVED_FACTOR * nyquist]
    if not candidates:
        return []
    acceleration = peak_accelerations(scenario, motion_times(scenario, t))
    out = []
    for k in candidates:
        omega1 = 2 * np.pi * modal[k].natural_frequencies_hz[0]
        deflection = DEFLECTION_FACTOR * acceleration[k] / omega1**2
        if deflection <= settings.rtol * scenario.chain.links[k].length:
            out.append(k)
    return out


# A link whose highest mode is this many times every other link's sets a forward run's step
# alone: with it rigid the run takes about that many times fewer steps.
STEP_SETTING_FACTOR = 10.0
# Relative change of a frequency the output shows (below its Nyquist frequency) beyond which
# a stiff link's bending matters: it is advised fewer modes, not rigid = true.
BAND_CHANGE = 0.01


def stiff_forward_links(scenario: Scenario) -> dict[str, str]:
    """A forward run's flexible links that cost it most for what the output can show: a
    first frequency above the output grid's Nyquist frequency, or a highest mode
    STEP_SETTING_FACTOR times every other link's (it alone sets the step). Returns
    ``stiff_links_warning`` naming them with the frequency that sets the step and the fix
    (none: {}): rigid = true where that moves none of the frequencies the output shows by
    BAND_CHANGE, else the fewest modes that keep them within BAND_CHANGE (`_fix`).
    ValueError, before the run, for the nonlinear model when a first frequency is
    UNRESOLVED_FACTOR times the Nyquist frequency."""
    if not scenario.is_forward:
        return {}
    nyquist = 0.5 / scenario.settings.dt_out  # Hz
    nonlinear = scenario.settings.model == "nonlinear"
    modal = chain_modal_data(scenario.chain, scenario.base)
    frequencies = {k: data.natural_frequencies_hz
                   for k, (link, data) in enumerate(zip(scenario.chain.links, modal, strict=True))
                   if link.modes}
    found = []
    for k, f in frequencies.items():
        name = scenario.chain.links[k].name
        others = [g[-1] for j, g in frequencies.items() if j != k]
        ratio = f[-1] / max(others) if others else 1.0
        if f[0] <= nyquist and ratio < STEP_SETTING_FACTOR:
            continue
        text = (f"links[{k}] ({name}): its highest mode, {f[-1]:.3g} Hz, sets the integration "
                "step" + (f" ({ratio:.0f}× the other links' highest)" if ratio > 1 else ""))
        if f[0] > nyquist:
            text += (f", yet its first mode, {f[0]:.3g} Hz, is above the output grid's Nyquist "
                     f"frequency ({nyquist:.3g} Hz), so its vibration cannot show in the output")
        if nonlinear and f[0] > UNRESOLVED_FACTOR * nyquist:
            raise ValueError(f"{text}; the nonlinear model's step control does not converge "
                             f"on it: {_fix(scenario, k, nyquist, f[0], refused=True)}")
        found.append(text + ": " + _fix(scenario, k, nyquist, f[0]))
    if not found:
        return {}
    return {"stiff_links_warning": "; ".join(found)}


# Failures of the t = 0 modes that leave a stiff link without the check of its band: the
# mechanism does not assemble there, or its mass matrix is singular.
NO_START_MODES = (SimulationError, np.linalg.LinAlgError)


def _fix(scenario: Scenario, k: int, nyquist: float, first_hz: float,
         refused: bool = False) -> str:
    """The advice for a stiff link k: rigid = true when that moves no frequency below
    ``nyquist`` (Hz) by BAND_CHANGE; else (the link's bending under its joints' loads
    matters: a four-bar's crank) the fewest modes keeping them within BAND_CHANGE, or, for
    the nonlinear model's refusal (``refused``: its first mode, ``first_hz``, is beyond
    UNRESOLVED_FACTOR × ``nyquist``, which fewer modes do not change), an output grid fine
    enough to resolve it."""
    link = scenario.chain.links[k]
    # dt_out at which the first mode is UNRESOLVED_FACTOR × the Nyquist frequency 0.5/dt_out
    finer = (f"a dt_out of at most {0.5 * UNRESOLVED_FACTOR / first_hz:.2g} s (the output grid "
             f"then resolves its first mode, {first_hz:.3g} Hz, within "
             f"{UNRESOLVED_FACTOR:g}× its Nyquist frequency)")

    def changed(to: Link) -> Scenario:
        return with_links(scenario, {k: to})

    try:
        change = frequency_change(scenario, nyquist)
        shift = change(changed(rigid_body(link)))
    except NO_START_MODES:
        return (f"set rigid = true on links[{k}] if its bending does not matter, or "
                + (finer if refused else "give it fewer modes"))
    if shift < BAND_CHANGE:
        return (f"set rigid = true on links[{k}] (it then costs no more than a rigid link; "
                f"the frequencies below {nyquist:.3g} Hz move by {100 * shift:.2g}%)")
    why = ("not rigid = true: with it rigid " + (
        f"a mode below {nyquist:.3g} Hz has no counterpart" if math.isinf(shift)
        else f"the frequencies below {nyquist:.3g} Hz move by {100 * shift:.2g}%"))
    if refused:
        return f"give it {finer}, {why}"
    for n in range(1, link.modes):
        kept = change(changed(with_modes(link, n)))
        if kept < BAND_CHANGE:
            return (f"give links[{k}] modes = {n} (those frequencies then move by "
                    f"{100 * kept:.2g}%), {why}")
    return f"keep its modes, {why}"


def frequency_change(scenario: Scenario, below_hz: float) -> Callable[[Scenario], float]:
    """A function of ``changed`` (the same chain with fewer modes or links made rigid): the
    largest relative change of ``scenario``'s frequencies below ``below_hz`` (Hz) in it, each
    mode paired with the changed one of its shape (`modes.pairing`); inf when one has no
    counterpart. The first-order equations at t = 0 (`start_modes`); ``scenario``'s own modes
    are found once."""
    widths = tuple(link.modes for link in scenario.chain.links)
    f, shapes = start_modes(scenario, widths)
    band = np.flatnonzero(f < below_hz)

    def change(changed: Scenario) -> float:
        g, other = start_modes(changed, widths)
        if band.size > g.size:
            return math.inf
        paired = pair(shapes[band], other)
        return float(np.max(np.abs(g[paired] / f[band] - 1.0), initial=0.0))

    return change


def start_modes(scenario: Scenario, widths: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """The oscillatory modes of a forward scenario's first-order equations at its t = 0
    state: frequencies (Hz, ascending) and shape vectors (`modes.pairing.deflection_vectors`,
    ``widths`` per link). Closed loops: the Jacobian of the constrained rates in independent
    coordinates (`dynamics.loops.reduced_jacobian`); open chains: M ẍ + C ẋ + K x of the
    free and elastic coordinates (applied loads' slopes, such as a servo's, left out: the
    same for the scenarios compared)."""
    from ..solvers.forward import split_state
    from .forward import forward_system

    system = forward_system(scenario)
    nu, n = len(system.free), system.n
    if scenario.closures:
        from ..dynamics.loops import LoopSystem, reduced_jacobian

        J, keep = reduced_jacobian(LoopSystem(system, scenario.closures), 0.0)
        where = {int(y): row for row, y in enumerate(keep)}
        elastic = [where[2 * nu + i] for i in range(n)]
    else:
        t = np.zeros(1)
        parts = split_state(system, system.initial_state()[None])
        pdd_free, _, _ = system.accelerations(t, *parts)
        p, pd, pdd = system.rigid_state(t, parts[0], parts[1], pdd_free)
        keep = system.free + list(range(system.n_rigid, system.n_x))
        M, C, K = (a[0][np.ix_(keep, keep)] for a in system.matrices(p, pd, pdd)[:3])
        size = len(keep)
        J = np.block([[np.zeros((size, size)), np.eye(size)],
                      [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
        elastic = list(range(nu, nu + n))
    lam, vectors = np.linalg.eig(J)
    scale = max(np.abs(lam).max(initial=0.0), 1.0)
    kept = np.flatnonzero((lam.imag > 1e-9 * scale) & (np.abs(lam) > 1e-6 * scale))
    kept = kept[np.argsort(np.abs(lam[kept]))]
    q = vectors[np.ix_(elastic, kept)]
    bounds = np.cumsum([0] + [link.modes for link in scenario.chain.links])
    blocks = [q[a:b] for a, b in pairwise(bounds)]
    return (np.abs(lam[kept]) / (2 * np.pi),
            deflection_vectors(system.modal, blocks, widths))


def with_links(scenario: Scenario, links: dict[int, Link]) -> Scenario:
    """The scenario with the links at the keys of ``links`` replaced."""
    chain = tuple(links.get(k, link) for k, link in enumerate(scenario.chain.links))
    return dataclasses.replace(scenario, chain=dataclasses.replace(scenario.chain, links=chain))


def with_rigid_links(scenario: Scenario, indices: list[int]) -> Scenario:
    """The scenario with the links at ``indices`` made rigid."""
    return with_links(scenario, {k: rigid_body(scenario.chain.links[k]) for k in indices})


def rigid_metadata(scenario: Scenario, indices: list[int]) -> dict[str, str]:
    """The run's attributes on the links it ran rigid (none: no attribute)."""
    if not indices:
        return {}
    names = [scenario.chain.links[k].name for k in indices]
    return {"rigid_links": ", ".join(names),
            "rigid_links_note": (
                f"{', '.join(names)} ran as rigid: first frequency above "
                f"{UNRESOLVED_FACTOR:g}× the output grid's Nyquist frequency and quasi-static "
                "deflection below rtol of the length (set rigid = true to say so; a finer "
                "dt_out or a smaller rtol keeps the modes)")}
