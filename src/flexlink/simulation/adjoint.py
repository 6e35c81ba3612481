"""The gradient of a scalar objective over a run's channels by one reverse pass of the run's
Lawson steps (`solvers.lawson_adjoint`), for `Objective` (docs/sensitivities.md); a forward
run's by the reverse pass of its Radau IIA steps (`simulation.forward_adjoint`); the
nonlinear paths' from the fields' tangents.

J = metric(channels) depends on the fields p through the run's state and directly through the
channel map (a sensor's gain, a link's shapes): dJ/dp = Σ_t ∂J/∂x(t) ∂x(t)/∂p + ∂J/∂p|x, with
x = (q, q̇, q̈) at the output times. The first term is the reverse pass with the seeds
∂J/∂x(t) = Σ_c ∂J/∂c(t) ∂c(t)/∂x(t), its cost independent of the number of fields; the
channels' derivatives in the state are their rows over the state where they are such rows
(sensors on the modes), else central differences along each state coordinate at every
output time at once (each channel at one time depends on the state at that time only,
linearly or quadratically, so the differences are exact to round-off), and ∂J/∂p|x central
differences of the channel map over each field's stencil at the run's state, as the tangents'
channel pass takes them. Both read only the metric's channels, which for sensors on the
modes (strain, deflection, piezo) cost no frames; a metric on channels that need the frames
(tips, torques, accelerometers) has the fields' tangents (`sensitivities.forward_derivatives`)
instead, cheaper there.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from ..model import Scenario
from ..results import Results
from ..solvers import Solution
from .channel_subset import State, channel_values
from .common import PathRun, Progress
from .sensitivities import SensitivityError, SettledRun, _Field, settled_run

Metric = Callable[[Results], tuple[float, Mapping[str, np.ndarray]]]


def adjoint_run(scenario: Scenario, fields: list[_Field], t: np.ndarray,
                on_progress: Progress, shapes: bool) -> tuple[PathRun, Any]:
    """The run and what its gradient needs (`sensitivity_run`'s compute): a prescribed
    run's `SettledRun`, a forward run's `driven_sensitivities.ForwardSettled`, else (the
    nonlinear paths) every channel's derivatives from the fields' tangents."""
    from . import model_path

    path = model_path(scenario)
    if path == "forward":
        from .driven_sensitivities import Refused, forward_settled

        try:
            settled = forward_settled(scenario, fields, t, on_progress, shapes)
        except Refused as error:
            raise SensitivityError(str(error)) from None
        return settled.run, settled
    if path != "prescribed":
        from .sensitivities import run_on_path

        return run_on_path(scenario, fields, t, on_progress, shapes)
    settled = settled_run(scenario, fields, t, on_progress, shapes, keep_steps=True)
    return settled.run, settled


def objective_gradient(settled: Any, fields: list[_Field], t: np.ndarray,
                       slopes: Mapping[str, np.ndarray]) -> tuple[np.ndarray, str]:
    """dJ/dp (K,) of J with ∂J/∂channel = ``slopes`` (nt each) along the settled run
    (`adjoint_run`'s extra), and how it was computed ("adjoint" or "tangents")."""
    from ..solvers.threads import single_threaded
    from .driven_sensitivities import ForwardSettled

    with single_threaded():  # small arrays: BLAS threads would only spin
        if isinstance(settled, ForwardSettled):
            return _forward_gradient(settled, fields, t, slopes)
        if isinstance(settled, dict):  # every channel's derivatives (the tangents)
            return _contracted(settled, fields, slopes), "tangents"
        return _objective_gradient(settled, fields, t, slopes)


def _forward_gradient(settled: Any, fields: list[_Field], t: np.ndarray,
                      slopes: Mapping[str, np.ndarray]) -> tuple[np.ndarray, str]:
    """A forward run's gradient: the reverse pass of its Radau IIA steps where it applies
    (`forward_adjoint.forward_gradient`), else the fields' tangents."""
    from .driven_sensitivities import forward_tangents
    from .forward_adjoint import forward_gradient

    gradient = forward_gradient(settled, fields, t, slopes)
    if gradient is not None:
        return gradient, "adjoint"
    return _contracted(forward_tangents(settled, fields, t), fields, slopes), "tangents"


def _contracted(derivatives: Mapping[str, np.ndarray], fields: list[_Field],
                slopes: Mapping[str, np.ndarray]) -> np.ndarray:
    """Σ_c ∂J/∂c · ∂c/∂p (K,) from every channel's derivatives (nt, K)."""
    gradient = np.zeros(len(fields))
    for name, weight in slopes.items():
        gradient += np.asarray(weight, dtype=float) @ derivatives[name]
    return gradient


def _objective_gradient(settled: SettledRun, fields: list[_Field], t: np.ndarray,
                        slopes: Mapping[str, np.ndarray]) -> tuple[np.ndarray, str]:
    from ..solvers.lawson_adjoint import lawson_gradient

    names = list(slopes)
    solution = settled.run.solution
    nominal_scenario = settled.scenario
    readings, frames = channel_values(nominal_scenario, settled.nominal, solution, names)
    if frames:
        return _by_tangents(settled, fields, t, slopes), "tangents"
    weights = {name: np.asarray(slopes[name], dtype=float) for name in names}
    arrays = [solution.q, solution.q_dot, solution.q_ddot]
    seeds = _seeds_by_rows(nominal_scenario, settled.nominal, t, arrays, readings, weights)

    def functional(scenario: Scenario, system: Any, sol: Solution) -> np.ndarray:
        """Σ_c ∂J/∂c · c, per output time."""
        values, _ = channel_values(scenario, system, sol, names)
        return sum(weights[name] * values[name] for name in names)  # type: ignore[return-value]

    # else ∂J/∂x(t) by central differences along each state coordinate at all times at once
    n = solution.q.shape[1]
    links = _link_columns(settled.nominal, n)
    differenced = range(3) if seeds is None else range(0)
    if seeds is None:
        seeds = [np.zeros(a.shape) for a in arrays]
    for part in differenced:
        if part and _unread(functional, nominal_scenario, settled.nominal, t, arrays, part,
                            arrays[part]):
            continue  # sensors that do not read the rates (accelerations): their seed is 0
        shifted = list(arrays)
        moving = shifted[part] = arrays[part].copy()  # one column moved at a time
        read = links if len(links) == 1 else [
            cols for cols in links if not _unread(functional, nominal_scenario,
                                                  settled.nominal, t, shifted, part,
                                                  arrays[part], cols)]
        # a link's coordinates that no sensor reads have seeds 0
        for j in (j for cols in read for j in range(cols.start, cols.stop)):
            column = arrays[part][:, j]
            step = float(np.abs(column).max()) or 1.0
            moved = []
            for sign in (1.0, -1.0):
                moving[:, j] = column + sign * step
                moved.append(functional(nominal_scenario, settled.nominal,
                                        State(t, *shifted)))  # type: ignore[arg-type]
            moving[:, j] = column
            seeds[part][:, j] = (moved[0] - moved[1]) / (2.0 * step)
    gradient, _ = lawson_gradient(settled.nominal, settled.derivative_rows, t,
                                  settled.discretisation, *seeds, settled_system=True,
                                  pairing=settled.derivative_pairing)
    for k, (f, moved_systems) in enumerate(zip(fields, settled.systems, strict=True)):
        direct = 0.0
        # readings the field does not move (a joint's motion): their differences are 0
        moves = not all(_same_readings(sc, system, nominal_scenario, settled.nominal, names)
                        for sc, system in zip(f.scenarios, moved_systems, strict=True))
        for w, sc, system in zip(f.weights, f.scenarios, moved_systems, strict=True):
            if moves:
                direct += w * float(np.sum(functional(sc, system, solution)))
            if system.z_start is not None:  # q = w + z_start(p): the start moves too
                gradient[k] += w * float(np.sum(seeds[0] @ system.z_start)) / f.step
        gradient[k] += direct / f.step
    return gradient, "adjoint"


def _seeds_by_rows(scenario: Scenario, system: Any, t: np.ndarray, arrays: list[np.ndarray],
                   readings: Mapping[str, np.ndarray], weights: Mapping[str, np.ndarray]
                   ) -> list[np.ndarray] | None:
    """∂J/∂(q, q̇, q̈) (nt, n each) of J = Σ_t Σ_c weights_c(t) c(t) where each channel is
    a fixed row over the state, c(t) = Σ_parts r_c · x(t) (the sensors on the modes: a
    reading of a link's shapes at a point): the rows read at unit states (one channel
    evaluation per part), checked against the run's ``readings``; None where they do not
    give them (a reading that is not such a row)."""
    n = arrays[0].shape[1]
    if t.size < n:
        return None
    unit, zero = np.eye(n), np.zeros((n, n))
    rows = [channel_values(scenario, system, State(t[:n], *(  # type: ignore[arg-type]
        unit if p == part else zero for p in range(3))), list(weights))[0]
        for part in range(3)]
    for name, values in readings.items():
        predicted = sum(a @ r[name] for a, r in zip(arrays, rows, strict=True))
        scale = float(np.abs(values).max())
        if not np.allclose(predicted, values, rtol=0.0, atol=1e-12 * scale + 1e-300):
            return None
    return [sum(w[:, None] * r[name][None, :] for name, w in weights.items())  # type: ignore[misc]
            for r in rows]


def _unread(functional: Callable[..., np.ndarray], scenario: Scenario, system: Any,
            t: np.ndarray, arrays: list[np.ndarray], part: int, values: np.ndarray,
            columns: slice | None = None) -> bool:
    """Whether the functional leaves ``arrays[part]`` (the state's q, q̇ or q̈, ``values``)
    unread, or only its ``columns``: finite with those all NaN, which any arithmetic on them
    would carry (the readings are linear or quadratic in the state). Their central
    differences would then be zero to the bit. The whole part is read as a NaN view
    (nothing written); ``columns`` are set NaN in ``arrays[part]`` (a copy of ``values``)
    and given back their values."""
    probe = list(arrays)
    if columns is None:
        probe[part] = np.broadcast_to(np.nan, values.shape)
    else:
        arrays[part][:, columns] = np.nan
    try:
        with np.errstate(invalid="ignore"):
            return bool(np.all(np.isfinite(functional(scenario, system, State(t, *probe)))))
    finally:
        if columns is not None:
            arrays[part][:, columns] = values[:, columns]


def _link_columns(system: Any, n: int) -> list[slice]:
    """The state's columns by link (a sensor reads its own link's), or all as one where
    the links' do not cover them."""
    columns = [b.slice for b in getattr(system, "bodies", ())]
    covered = sorted(j for cols in columns for j in range(cols.start, cols.stop))
    return columns if covered == list(range(n)) else [slice(0, n)]


def _same_readings(scenario: Scenario, system: Any, nominal_scenario: Scenario,
                   nominal: Any, names: list[str]) -> bool:
    """Whether the readings of the sensors ``names`` on the modes (all the functional
    reads) are the nominal ones: the same sensors, links but for their EI and damping
    ratios, and modal data that are the same objects or share all but their stiffness,
    damping and frequencies (a reading takes a link's mode shapes, its place in the state
    and a strain gauge's depth: `channels.modal.modal_reading`)."""
    from ..dynamics.prescribed_kernel import _same_but_stiffness, _unstiffened_link

    if system is not nominal and (len(system.modal) != len(nominal.modal) or not all(
            a is b or _same_but_stiffness(a, b) for a, b in zip(system.modal, nominal.modal))):
        return False
    try:
        return bool([s for s in scenario.sensors if s.name in names]
                    == [s for s in nominal_scenario.sensors if s.name in names]
                    and all(a == b or _unstiffened_link(a) == _unstiffened_link(b)
                            for a, b in zip(scenario.chain.links,
                                            nominal_scenario.chain.links, strict=True)))
    except (TypeError, ValueError):  # values holding arrays, other links: as different
        return False


def _by_tangents(settled: SettledRun, fields: list[_Field], t: np.ndarray,
                 slopes: Mapping[str, np.ndarray]) -> np.ndarray:
    """dJ/dp from the fields' tangents, reading the metric's channels only."""
    from .sensitivities import forward_derivatives

    derivatives = forward_derivatives(settled, fields, t, list(slopes))
    gradient = np.zeros(len(fields))
    for name, weight in slopes.items():
        gradient += np.asarray(weight, dtype=float) @ derivatives[name]
    return gradient

