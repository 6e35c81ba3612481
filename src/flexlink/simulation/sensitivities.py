"""Sensitivities of a run's channels to numeric scenario fields (docs/sensitivities.md).

``simulate(scenario, sensitivities=["links[0].EI", …])`` runs the scenario and, with the run,
the derivative of every channel on the output grid with respect to each field (the field-path
grammar of sweeps and fits, `scenario.fields`). Path taken: prescribed joints, first-order
model, ``method = "lawson"`` (the default of prescribed runs). There the derivative is the
exact derivative of what the run computed (`solvers.lawson_sensitivity`): forward
sensitivity equations stepped by the same Lawson steps on the same table layout and block
propagators. Two pieces come from differences, both at a fixed state or fixed times, never of
a run:

* ∂A/∂p, A = M⁻¹[−K, −C, f] the state matrix, by central differences of the assembly of the
  scenario with the field moved by ±δ (`field_step`: δ = `RELATIVE_STEP` × |value|, an
  angle's at least 1e-5 rad) at the table's sampling times; a field whose lower bound the step would cross takes a one-sided
  second-order difference. The assembly is smooth in every numeric field (modes and
  frequencies from roots found to adjacent floating-point numbers), so the difference's
  error (δ² terms, round-off / δ) is ~1e-9 relative or less. A field that moves the links'
  modal stiffness and damping matrices alone (EI, a damping ratio) has ∂A/∂p = −M⁻¹[∂K, ∂D, 0]
  instead (A is affine in them), ∂K, ∂D by the same stencil of those matrices.
* ∂channel/∂p at the computed state: the channel map (`prescribed.prescribed_values`) at the
  moved field and the state moved along its sensitivity, by the same stencil. Channels are
  linear or quadratic in the state, so this is exact in the state up to round-off.
"""

from __future__ import annotations

import difflib
import functools
import math
import re
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import Scenario
from ..results import Results
from ..scenario.fields import (
    FieldPathError,
    ScenarioFile,
    Target,
    find,
    format_path,
    is_number,
    is_time_grid,
)
from ..solvers import Solution
from .common import PathRun, Progress

RELATIVE_STEP = 1e-5  # of a field's magnitude: the step of the differences of the assembly
ABSOLUTE_STEP = 1e-6  # the step of a field whose value is zero, in its unit (`field_step`)
# The natural size of a field in these units, in the unit: an angle's is the radian, the
# scale on which the trigonometric functions the model takes of it vary (`field_step`).
NATURAL_SIZE = {"degree": 180.0 / math.pi, "degree s-1": 180.0 / math.pi}
_SETTINGS = ("rtol", "atol", "step")  # [simulation] keys of the integrator, not the model
# (offsets in steps, weights): central, then forward and backward one-sided, second order
_STENCILS = (((1, -1), (0.5, -0.5)), ((0, 1, 2), (-1.5, 2.0, -0.5)),
             ((0, -1, -2), (1.5, -2.0, 0.5)))
SUPPORTED = ('prescribed joints with the first-order model and method = "lawson" (the '
             "default of prescribed runs), and driven joints or a moving base with the "
             'first-order model, the compiled Radau IIA (method = "radau5", "lawson" or '
             '"magnus"; closed kinematic loops and sampled controllers included); and the '
             "nonlinear model (prescribed or driven joints, moving base) without controllers "
             "or closed kinematic loops")


class SensitivityError(ValueError):
    """A sensitivity that cannot be computed: unknown or non-numeric field, or a path
    (model, integrator) that does not take sensitivities."""


@dataclass(frozen=True)
class _Field:
    """One field: its target in the file, the unit of its values (UDUNITS), and the offsets
    (multiples of ``step``) and weights of its difference stencil; on the nonlinear model
    also the scenarios at ±``wide_step``, ±2 ``wide_step``
    (`nonlinear_sensitivities.WIDE_OFFSETS`), for the field's own part of its channels, or
    none."""

    target: Target
    unit: str
    step: float
    offsets: tuple[int, ...]
    weights: tuple[float, ...]
    scenarios: tuple[Scenario, ...]
    wide_step: float = 0.0
    wide: tuple[Scenario, ...] = ()

    def mapped(self, change: Callable[[Scenario], Scenario]) -> _Field:
        """The field with ``change`` applied to each of its moved scenarios."""
        from dataclasses import replace

        return replace(self, scenarios=tuple(change(s) for s in self.scenarios),
                       wide=tuple(change(s) for s in self.wide))


def scenario_file(scenario: Scenario | ScenarioFile) -> ScenarioFile:
    """The file a Scenario was built from (what field paths address)."""
    if isinstance(scenario, ScenarioFile):
        return scenario
    origin = getattr(scenario, "_origin", None)
    if origin is None:
        raise SensitivityError(
            "sensitivities: this Scenario was not built from a scenario file or dict (or was "
            "changed since with dataclasses.replace); field paths address the file: pass a "
            "Scenario from flexlink.load_scenario, load_paper_experiment or scenario_from_dict")
    raw, base_dir, name, source = origin
    return ScenarioFile(raw, base_dir, name, source)


def check_path(scenario: Scenario) -> None:
    """SensitivityError naming the run's path unless it takes sensitivities."""
    from . import model_path

    path = model_path(scenario)
    method = scenario.settings.method
    if path == "forward":
        from .driven_sensitivities import refused

        what = refused(scenario)
        if what is None:
            return
        raise SensitivityError(f"sensitivities: {what} do not compute sensitivities yet; "
                               f"they are computed on {SUPPORTED}")
    if path in ("nonlinear", "nonlinear_forward"):
        from .nonlinear_sensitivities import refused as nonlinear_refused

        what = nonlinear_refused(scenario)
        if what is None:
            return
        raise SensitivityError(f"sensitivities: {what} do not compute sensitivities yet; "
                               f"they are computed on {SUPPORTED}")
    if path != "prescribed" or method != "lawson":
        what = f"the {path} path" + (f" with method = {method!r}" if path == "prescribed"
                                     else "")
        raise SensitivityError(
            f"sensitivities: {what} does not compute sensitivities yet; they are computed on "
            f"{SUPPORTED}")
    if scenario.actuators:
        raise SensitivityError("sensitivities: scenarios with piezo actuators do not compute "
                               f"sensitivities yet; they are computed on {SUPPORTED}")


def prepare_fields(file: ScenarioFile, scenario: Scenario, fields: Sequence[str]
                   ) -> list[_Field]:
    """Check every field before anything runs, and build the scenarios of its stencil.
    SensitivityError naming the field: malformed or unknown path, non-numeric or integer
    field, a field that changes the output grid or moves the motion's breaks, or one
    whose moved values the scenario refuses on both sides."""
    from ..dynamics.first_order import input_breakpoints

    if isinstance(fields, str):
        fields = [fields]
    if not fields:
        raise SensitivityError("sensitivities: name at least one field, e.g. links[0].EI")
    twice = [text for i, text in enumerate(fields) if text in fields[:i]]
    if twice:
        raise SensitivityError(f"sensitivities: {twice[0]} is named twice")
    from ..scenario.load import reusing_tables

    breaks = input_breakpoints(scenario.chain.joints, scenario.actuators)
    with reusing_tables():  # the stencils' builds share the tables their field leaves alone
        return [_prepared(file, scenario, text, breaks) for text in fields]


def _prepared(file: ScenarioFile, scenario: Scenario, text: str, breaks: np.ndarray
              ) -> _Field:
    """`prepare_fields` of one field."""
    from ..dynamics.first_order import input_breakpoints

    try:
        target = file.locate(text)
    except FieldPathError as error:
        raise SensitivityError(f"sensitivities: {error}") from None
    if target.value is None:
        raise SensitivityError(f"sensitivities: {text} has no value in the scenario"
                               + _numeric_keys(file, target))
    if target.integer:
        raise SensitivityError(f"sensitivities: {text} takes integers; a derivative needs "
                               "a real-valued field")
    if is_time_grid(target.path):
        raise SensitivityError(f"sensitivities: {text} changes the output time grid; "
                               "choose a field of the model")
    if target.path[0] == "simulation" and target.key in _SETTINGS:
        raise SensitivityError(f"sensitivities: {text} is a setting of the integrator, "
                               "not of the model; choose a field of the model")
    value = float(target.value)
    unit = field_unit(target)
    step = field_step(value, unit)
    problem: Exception | None = None
    for stencil in _STENCILS:  # central; at a bound, one-sided (second order)
        try:
            scenarios = tuple(scenario if j == 0 else
                              file.build({target.path: value + j * step})
                              for j in stencil[0])
            break
        except ValueError as error:
            problem = error
    else:
        raise SensitivityError(f"sensitivities: {text} = {value:g} cannot be moved by "
                               f"±{step:.3g}: {problem}") from None
    for moved in scenarios:
        if moved is scenario:
            continue
        check_path(moved)
        if _same_motions(moved, scenario):
            continue  # the same breaks
        if not _same_breaks(breaks, input_breakpoints(moved.chain.joints,
                                                      moved.actuators)):
            raise SensitivityError(
                f"sensitivities: {text} moves a time where a joint's acceleration jumps "
                "(a motion's start or end); the computed run is not differentiable in it "
                "on a fixed discretisation. Fields that keep those times (angles, link, "
                "sensor and damping properties) take sensitivities")
    return _Field(target, unit, step, stencil[0], stencil[1], scenarios,
                  *_wide(file, scenario, target, value, step))


def _wide(file: ScenarioFile, scenario: Scenario, target: Target, value: float,
          step: float) -> tuple[float, tuple[Scenario, ...]]:
    """The wide stencil's step and scenarios (`nonlinear_sensitivities.WIDE_OFFSETS` times
    WIDE_STEP × ``step``) of a field of the nonlinear model; none (0, ()) on another model,
    or where the scenario refuses a move (the field's own stencil then serves)."""
    if scenario.settings.model != "nonlinear":
        return 0.0, ()
    from .nonlinear_sensitivities import WIDE_OFFSETS, WIDE_STEP

    wide = WIDE_STEP * step
    try:
        return wide, tuple(file.build({target.path: value + j * wide})
                           for j, _ in WIDE_OFFSETS)
    except ValueError:
        return 0.0, ()


def field_step(value: float, unit: str) -> float:
    """The difference step of a field of ``value`` in ``unit`` (UDUNITS): RELATIVE_STEP of its
    magnitude, and of at least its natural size where its unit has one (`NATURAL_SIZE`:
    an angle, or angular rate, of zero or a few degrees is stepped by 1e-5 rad, not by a
    fraction of its value, which would leave the round-off of the rates it moves in the
    difference); a zero field of another unit by ABSOLUTE_STEP."""
    natural = NATURAL_SIZE.get(unit)
    if natural is not None:
        return RELATIVE_STEP * max(abs(value), natural)
    return RELATIVE_STEP * abs(value) if value else ABSOLUTE_STEP


def _same_motions(a: Scenario, b: Scenario) -> bool:
    """Whether two scenarios' joints are the same objects and neither has actuators (what
    `input_breakpoints` reads): their builds shared those tables (`reusing_tables`)."""
    ja, jb = a.chain.joints, b.chain.joints
    return (not a.actuators and not b.actuators and len(ja) == len(jb)
            and all(x is y for x, y in zip(ja, jb)))


def _same_breaks(a: np.ndarray, b: np.ndarray) -> bool:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    return a.shape == b.shape and bool(np.all(a == b))


@dataclass(frozen=True)
class SettledRun:
    """A prescribed run, the discretisation its Lawson integrator settled on, its system
    and, per field, the systems of the field's stencil (the nominal one where the offset is
    0), with ``derivative_rows``: ∂A/∂p of every field at given times (nt, K, n, 2n+1),
    and ``derivative_pairing``: Σ_t ⟨∂A/∂p(t), W_t⟩ per field at given times and weights
    W (nt, n, 2n+1), what a reverse pass reads of them (`lawson_adjoint.lawson_gradient`)."""

    run: PathRun
    scenario: Scenario
    discretisation: Any
    nominal: Any
    systems: list[list[Any]]
    derivative_rows: Any
    derivative_pairing: Any = None


def settled_run(scenario: Scenario, fields: list[_Field], t: np.ndarray,
                on_progress: Progress, shapes: bool, keep_steps: bool = False) -> SettledRun:
    """The prescribed run of ``scenario`` (`prescribed.run_prescribed`, adaptive Lawson),
    its discretisation (``keep_steps``: with the run's steps, for a reverse pass) and the
    systems of the fields' stencils."""
    from ..dynamics.prescribed_kernel import CompiledFirstOrderSystem, mass_inverse
    from ..solvers.lawson import integrate_lawson_discretised
    from .prescribed import prescribed_system, run_prescribed

    settled: list[Any] = [None]

    def adaptive(system: Any, times: np.ndarray, rtol: float, atol: float,
                 progress: Any) -> Solution:
        solution, settled[0] = integrate_lawson_discretised(system, times, rtol, atol,
                                                            progress, keep_table=True,
                                                            keep_steps=keep_steps)
        return solution

    # the run's own system is the nominal one: the sensitivities reuse its settled table
    nominal = prescribed_system(scenario, t)
    nominal.keep_rows()  # the table's samples: the sensitivities read them again
    run = run_prescribed(scenario, t, on_progress, shapes, adaptive, system=nominal)
    nominal.keep_rows(False)
    if run.solution.q.shape[1] == 0:
        raise SensitivityError("sensitivities: every link is rigid: there is nothing to "
                               "differentiate through the integrator")
    if settled[0] is None:
        raise SensitivityError(
            "sensitivities: this run's coefficients were too rough to tabulate (a measured "
            "motion) and were integrated by Magnus, which does not compute sensitivities")
    systems = []

    def system_of(sc: Scenario) -> Any:
        s = CompiledFirstOrderSystem(sc.chain, sc.settings.geometric_stiffening,
                                     sc.actuators, sc.settings.gravity)
        if sc.settings.initial == "equilibrium":
            s.start_from(s.equilibrium(float(t[0])))
        return s

    for f in fields:
        systems.append([nominal if j == 0 or _same_model(sc, scenario) else system_of(sc)
                        for j, sc in zip(f.offsets, f.scenarios, strict=True)])

    # the fields that move the links' stiffness and damping matrices alone: their ∂A/∂p
    # is −M⁻¹[∂K, ∂D, 0] (A is affine in them), no assembly per stencil point
    changes = [_stiffness_change(nominal, f, moved) for f, moved in zip(fields, systems,
                                                                        strict=True)]

    def field_rows(times: np.ndarray) -> Iterator[tuple[int, np.ndarray]]:
        """(k, ∂A/∂p_k at times (nt, n, 2n+1)) of each field the equations read."""
        rows0 = nominal.kept_rows(times)  # the nominal rows, where a stencil or M⁻¹ reads
        inverse = None
        for k, (f, moved) in enumerate(zip(fields, systems, strict=True)):
            if all(s is nominal for s in moved):  # a field the equations do not read
                continue
            if changes[k] is not None:
                if inverse is None:
                    rows0 = nominal.state_rows(times) if rows0 is None else rows0
                    inverse = mass_inverse(nominal, times, rows0)
                rows = np.zeros((times.size, nominal.n, 2 * nominal.n + 1))
                np.matmul(inverse, -changes[k], out=rows[:, :, :-1])
                yield k, rows
                continue
            rows = None
            for w, s in zip(f.weights, moved, strict=True):
                if s is nominal:
                    rows0 = nominal.state_rows(times) if rows0 is None else rows0
                term = (w / f.step) * (rows0 if s is nominal else s.state_rows(times))
                rows = term if rows is None else rows + term
            yield k, rows  # type: ignore[misc]

    def derivative_rows(times: np.ndarray) -> np.ndarray:
        n = nominal.n
        out = np.zeros((times.size, len(fields), n, 2 * n + 1))
        for k, rows in field_rows(times):
            out[:, k] = rows
        return out

    def derivative_pairing(times: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Σ_t ⟨∂A/∂p_k(t), weights_t⟩ (K,): each field's stencil of rows combined, then
        paired (a difference of pairings would carry the round-off of the whole sum)."""
        out = np.zeros(len(fields))
        for k, rows in field_rows(times):
            out[k] = np.vdot(rows, weights)
        return out

    return SettledRun(run, scenario, settled[0], nominal, systems, derivative_rows,
                      derivative_pairing)


def _stiffness_change(nominal: Any, f: _Field, moved: list[Any]) -> np.ndarray | None:
    """[∂K, ∂D] (n, 2n) of a field whose stencil's systems differ from the nominal one in
    their links' modal stiffness and damping matrices alone (a link's EI or damping ratio:
    `prescribed_kernel.stiffness_alone`), by the field's stencil of those matrices; None
    for any other field."""
    from ..dynamics.prescribed_kernel import stiffness_alone

    if all(s is nominal for s in moved) or not all(
            s is nominal or stiffness_alone(nominal, s) for s in moved):
        return None
    n = nominal.n
    out = np.zeros((n, 2 * n))
    for w, s in zip(f.weights, moved, strict=True):
        for o, data in zip(nominal.offsets, s.modal, strict=True):
            block = slice(o, o + data.n)
            out[block, block] += (w / f.step) * data.stiffness_matrix
            out[block, n + o: n + o + data.n] += (w / f.step) * data.damping_matrix
    return out


def _same_model(moved: Scenario, scenario: Scenario) -> bool:
    """Whether a moved scenario's equations are the scenario's (a field of the sensors):
    the same chain, actuators and settings of the equations, so the same system."""
    a, b = moved.settings, scenario.settings
    try:
        return bool(moved.chain == scenario.chain and moved.actuators == scenario.actuators
                    and a.geometric_stiffening == b.geometric_stiffening
                    and a.gravity == b.gravity and a.initial == b.initial)
    except ValueError:  # values holding arrays (a measured motion): compared as different
        return False


def run_with_sensitivities(scenario: Scenario, fields: list[_Field], t: np.ndarray,
                           on_progress: Progress, shapes: bool
                           ) -> tuple[PathRun, dict[str, np.ndarray]]:
    """The prescribed run of ``scenario`` (`prescribed.run_prescribed`, adaptive Lawson)
    and, per channel, its derivatives (nt, K) in the fields."""
    settled = settled_run(scenario, fields, t, on_progress, shapes)
    return settled.run, forward_derivatives(settled, fields, t)


def forward_derivatives(settled: SettledRun, fields: list[_Field], t: np.ndarray,
                        names: Sequence[str] | None = None) -> dict[str, np.ndarray]:
    """Per channel (``names``: those only), its derivatives (nt, K) in the fields along the
    settled run, from the fields' tangents."""
    from ..solvers.lawson_sensitivity import lawson_sensitivities
    from .prescribed import prescribed_values

    run, nominal, systems = settled.run, settled.nominal, settled.systems
    # A field the equations do not read (its stencil's systems all the run's: a sensor's
    # gain) moves no state, only the sensors' readings: no tangent, and the sensors alone.
    sensors_only = [all(s is nominal for s in moved) for moved in systems]
    active = [k for k, only in enumerate(sensors_only) if not only]
    K, nt, n = len(fields), t.size, nominal.n
    # per field its tangents ∂q, ∂q̇, ∂q̈ (nt, n): the active fields' rows of the tangent
    # loop's arrays as they are (no (K, nt, n) copies), zero for the others
    zero = np.zeros((nt, n))
    tangents = [(zero, zero, zero)] * K
    if active:
        _, aq, aqd, aqdd = lawson_sensitivities(
            nominal, lambda times: settled.derivative_rows(times)[:, active], t,
            settled.discretisation, settled_system=True)
        for i, k in enumerate(active):
            tangents[k] = (aq[i], aqd[i], aqdd[i])
    if nominal.z_start is not None:
        for k, moved in enumerate(systems):
            f = fields[k]
            dz0 = sum(w * s.z_start for w, s in zip(f.weights, moved, strict=True))
            q0 = tangents[k][0]
            tangents[k] = (q0 + dz0 / f.step, *tangents[k][1:])
    from .channel_subset import State

    run_solution = run.solution
    # each channel's derivatives filled a field at a time: no per-field columns to stack
    channels = {name: np.empty((nt, K)) for name in (run.values if names is None else names)}
    for k, f in enumerate(fields):
        total: dict[str, np.ndarray] = {}
        for j, w, sc, system in zip(f.offsets, f.weights, f.scenarios, systems[k],
                                    strict=True):
            h = j * f.step
            # the channel map reads the state alone (its finiteness checked with the tangents)
            dq, dqd, dqdd = tangents[k]
            moved_solution = State(t, run_solution.q + h * dq, run_solution.q_dot + h * dqd,
                                   run_solution.q_ddot + h * dqdd)
            if names is None and not sensors_only[k]:
                values, _, _ = prescribed_values(sc, system, moved_solution,  # type: ignore[arg-type]
                                                 False, checked=False)
            else:
                from .channel_subset import channel_values

                wanted = [s.name for s in sc.sensors] if names is None else names
                values, _ = channel_values(sc, system, moved_solution,  # type: ignore[arg-type]
                                           wanted)
            for name, v in values.items():
                total[name] = total.get(name, 0.0) + w * np.asarray(v, dtype=float)
        for name, out in channels.items():
            out[:, k] = total[name] / f.step if name in total else 0.0
    return channels


def path_with_sensitivities(scenario: Scenario) -> Any:
    """The run-with-sensitivities function of the scenario's path."""
    from . import model_path

    path = model_path(scenario)
    if path == "forward":
        from . import driven_sensitivities as module
        chosen = module.run_with_forward_sensitivities
    elif path in ("nonlinear", "nonlinear_forward"):
        from . import nonlinear_sensitivities as module  # type: ignore[no-redef]
        chosen = module.run_with_nonlinear_sensitivities
    else:
        return run_with_sensitivities

    def run(*args: Any) -> Any:
        try:
            return chosen(*args)
        except module.Refused as error:
            raise SensitivityError(str(error)) from None
    return run


def _numeric_keys(file: ScenarioFile, target: Target) -> str:
    """The closest numeric key of the table a valueless path ends in (a misspelt key),
    or that table's numeric keys: the tail of its message."""
    table = find(file.defaults, target.path[:-1])
    if not isinstance(table, Mapping) or not isinstance(target.path[-1], str):
        return ""
    keys = [k for k, v in table.items() if is_number(v)]
    close = difflib.get_close_matches(target.path[-1], keys, n=1, cutoff=0.6)
    if close:
        return f" (did you mean {format_path((*target.path[:-1], close[0]))}?)"
    return f"; its numeric keys: {', '.join(keys)}" if keys else ""


def run_on_path(scenario: Scenario, fields: list[_Field], t: np.ndarray, on_progress: Any,
                shapes: bool) -> Any:
    """`run_with_sensitivities` on the scenario's path (prescribed Lawson or forward)."""
    return path_with_sensitivities(scenario)(scenario, fields, t, on_progress, shapes)


def labelled(results: Results, fields: list[_Field], derivatives: dict[str, np.ndarray]) -> Any:
    """The sensitivities of ``results`` as a DataArray (time × channel × field)."""
    import xarray as xr

    names = [name for name in results.names if name in derivatives]
    texts = [f.target.text for f in fields]
    data = np.stack([derivatives[name] for name in names], axis=1)
    units = np.array([[quotient_unit(results.channels[name].unit, f.unit) for f in fields]
                      for name in names], dtype=object)
    return xr.DataArray(
        data, dims=("time", "channel", "field"),
        coords={"time": results.time, "channel": names, "field": texts,
                "unit": (("channel", "field"), units),
                "field_unit": ("field", [f.unit for f in fields]),
                "field_value": ("field", [float(f.target.value) for f in fields])},
        name="sensitivity",
        attrs={"long_name": "∂channel/∂field of the computed run",
               "method": "forward sensitivities on the run's Lawson discretisation"})


# ---- units -------------------------------------------------------------------------------

_SUPERSCRIPTS = str.maketrans("²³⁻¹", "23-1")
_SYMBOLS = {"deg": "degree"}
# the kinds of [[joints]] table whose keys sit under joints[k] (a servo's D gain there, not
# a controller's LTI matrix D)
_TABLE_OF = {name: "joints" for name in ("torque", "velocity_pid", "position", "elastic",
                                         "prismatic")}


def field_unit(target: Target) -> str:
    """The UDUNITS unit of a field's values, from the schema ("1" if dimensionless, "" where
    the schema gives none it can spell)."""
    key = target.key
    names = [step for step in target.path if isinstance(step, str)]
    if key in ("amplitude", "values") and len(names) >= 2:  # a history's profile: its unit
        key = names[-2]  # is the history's (joints[0].torque, base.loads[0].moment)
    return _unit(key, str(target.path[0]), bool(target.slider))


@functools.lru_cache(maxsize=256)
def _unit(key: str, head: str, slider: bool) -> str:
    """`field_unit` of key ``key`` under top-level table ``head`` (a slider's or not)."""
    from ..scenario import schema

    # a cart's and a slider's keys (their servo gains per m) only under their own tables
    own = {"base": [schema.CART], "joints": [schema.PRISMATIC]}.get(head, [])
    if slider:  # a slider's drive keys are a cart's, its profiles travel (m)
        own = [schema.PRISMATIC, schema.CART]
    sections = [*schema.SECTIONS.values(), *own] + list(schema.PROFILES.values()) + \
        list(schema.CART_PROFILES.values()) + list(schema.HISTORIES.values())
    found = [s[key].unit for s in sections if key in s.keys]
    if slider:  # its travel profiles and force history: a cart's
        mine = [*own, *schema.CART_PROFILES.values(), *schema.HISTORIES.values()]
        preferred = [s[key].unit for s in mine if key in s.keys]
    else:
        preferred = [s[key].unit for s in sections if key in s.keys
                     and _TABLE_OF.get(s.name, s.name.split(".")[0]) == head]
    units = set(preferred) or set(found)
    if len(units) != 1:
        return ""
    return udunits(units.pop())


def udunits(text: str) -> str:
    """A schema unit (N·m², kg/m, m/s², 1/s, deg, deg/s per V) in UDUNITS spelling (N m2,
    kg m-1, m s-2, s-1, degree, degree s-1 V-1); "" where it is not a plain product of
    powers."""
    text = text.split(",")[0].split(" (")[0].strip()
    if not text:
        return "1"
    if " per " in text:  # "deg/s per V": the first unit divided by the second
        top, per = (udunits(part) for part in text.split(" per ", 1))
        powers, divisor = _powers(top), _powers(per)
        if not top or not per or powers is None or divisor is None:
            return ""
        for base, power in divisor.items():
            powers[base] = powers.get(base, 0) - power
        return _spell(powers)
    if re.search(r"[^A-Za-zΩ°·/²³()]", text):
        return ""
    numerator, _, denominator = text.partition("/")
    powers: dict[str, int] = {}
    for part, sign in ((numerator, 1), (denominator.strip("()"), -1)):
        for token in filter(None, part.split("·")):
            m = re.fullmatch(r"([A-Za-zΩ°]+)([²³]?)", token)
            if m is None:
                return ""
            base = _SYMBOLS.get(m.group(1), m.group(1))
            if base == "1":
                continue
            power = {"": 1, "²": 2, "³": 3}[m.group(2)]
            powers[base] = powers.get(base, 0) + sign * power
    return _spell(powers)


def _spell(powers: dict[str, int]) -> str:
    parts = [b if p == 1 else f"{b}{p}" for b, p in powers.items() if p]
    return " ".join(parts) or "1"


def _powers(unit: str) -> dict[str, int] | None:
    powers: dict[str, int] = {}
    if unit in ("", "1"):
        return powers
    for token in unit.split():
        m = re.fullmatch(r"([A-Za-z]+)(-?\d*)", token)
        if m is None:
            return None
        powers[m.group(1)] = powers.get(m.group(1), 0) + int(m.group(2) or 1)
    return powers


def quotient_unit(channel: str, field: str) -> str:
    """channel unit / field unit in UDUNITS spelling ("" if either is unknown)."""
    a, b = _powers(channel), _powers(field)
    if a is None or b is None or field == "":
        return ""
    for base, p in b.items():
        a[base] = a.get(base, 0) - p
    return _spell(a)


def simulate_with_sensitivities(scenario: Scenario | ScenarioFile, fields: Sequence[str],
                                progress: bool = False, shapes: bool = True,
                                drive: Callable[[Scenario], Scenario] | None = None
                                ) -> Results:
    """`simulate` with the sensitivities of every channel to ``fields`` on the results
    (`Results.sensitivities`, `Results.sensitivity`). Every check runs before the run. They
    are labelled (an xarray DataArray) when first read: computing them needs no xarray.
    ``drive``: applied to the scenario and to every moved one before they run (a fit's
    measured joint motions, `experiment`)."""
    results, prepared, derivatives = sensitivity_run(scenario, fields, progress, shapes,
                                                     run_on_path, drive)
    results.label_sensitivities(lambda: labelled(results, prepared, derivatives))
    return results


def simulate_with_derivatives(scenario: Scenario | ScenarioFile, fields: Sequence[str],
                              shapes: bool = True,
                              drive: Callable[[Scenario], Scenario] | None = None
                              ) -> tuple[Results, dict[str, np.ndarray]]:
    """`simulate_with_sensitivities` without labels: the results and the plain
    {channel: (time, field) array}, fields in the order given (the fit's Jacobians)."""
    results, _, derivatives = sensitivity_run(scenario, fields, False, shapes,
                                              run_on_path, drive)
    return results, derivatives


def sensitivity_run(scenario: Scenario | ScenarioFile, fields: Sequence[str], progress: bool,
                    shapes: bool, compute: Any,
                    drive: Callable[[Scenario], Scenario] | None = None
                    ) -> tuple[Results, list[_Field], Any]:
    """Check the scenario and ``fields``, then ``compute(scenario, prepared fields, t,
    on_progress, shapes) → (PathRun, extra)`` (timed, single-threaded, with the links the
    run makes rigid rigid in every moved scenario too, ``drive`` applied to the scenario
    and every moved one first): the Results, the prepared fields and the extra."""
    from ..scenario.load import reusing_tables
    from .common import ProgressBar, assemble_results, check_run_memory, output_times, timed
    from .rigid import quasi_rigid_links, rigid_metadata, with_rigid_links

    file = scenario_file(scenario)
    with reusing_tables():  # the stencils' builds share the tables the scenario's resolved
        if isinstance(scenario, ScenarioFile):
            scenario = file.build()
        check_path(scenario)
        prepared = prepare_fields(file, scenario, fields)
    if drive is not None:
        scenario = drive(scenario)
        prepared = [f.mapped(drive) for f in prepared]
        check_path(scenario)
    check_run_memory(scenario)
    settings = scenario.settings
    t = output_times(settings.t_end, settings.dt_out)
    stiff = quasi_rigid_links(scenario, t)
    if stiff:  # the links the run makes rigid are rigid in every moved scenario too
        prepared = [f.mapped(lambda s: with_rigid_links(s, stiff)) for f in prepared]
        base = with_rigid_links(scenario, stiff)
    else:
        base = scenario
    from ..solvers.threads import single_threaded

    with single_threaded(), ProgressBar(settings.t_end, enabled=progress) as bar:
        (run, extra), wall_time = timed(  # type: ignore[arg-type]
            lambda: compute(base, prepared, t, bar.update, shapes))
    if stiff:
        from dataclasses import replace

        run = replace(run, metadata={**run.metadata, **rigid_metadata(scenario, stiff)})
    return assemble_results(scenario, run, wall_time), prepared, extra
