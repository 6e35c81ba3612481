"""Sensitivities of a forward run (driven joints, moving base; first-order model, compiled
Radau IIA) to numeric scenario fields: the derivative of what the run computed, on its
own accepted steps (`solvers.radau_sensitivity`).

Pieces from differences, each at a fixed state or time, never of a run (fields moved by
±δ as in `sensitivities.prepare_fields`):

* ∂f/∂p at every stage: the compiled rates of the forward system assembled at the moved
  field, with its own input table (a drive's torque or a servo's reference moves the
  inputs), at the run's stage states;
* ∂y0/∂p: the moved scenarios' initial states (an equilibrium start, a base's initial
  velocity);
* the projection onto the known momentum (free or pinned base, cart), after each step and
  at each output: the moved scenario's projection of the state moved along its
  sensitivity;
* ∂channel/∂p: the forward path's channels (`forward.forward_run`) of the moved scenario
  at the states moved along their sensitivities;
* sampled controllers: the voltages held between samples, differentiated sample by
  sample (`held_sensitivities.py`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import Scenario
from .common import PathRun, Progress


class Refused(ValueError):
    """A field the forward run's sensitivities cannot take (the caller reports it as a
    `sensitivities.SensitivityError`)."""


@dataclass
class _Model:
    """One scenario's forward system as the compiled kernels see it."""

    scenario: Scenario
    system: Any
    data: Any
    work: Any
    projection: Any
    y0: np.ndarray
    table: tuple
    integrals: tuple | None
    loops: Any = None  # closed loops: their `dynamics.loops.LoopSystem`


def _equal(a: Any, b: Any) -> bool:
    """a == b for scenario parts, False where a comparison is ambiguous (arrays inside)."""
    try:
        return bool(a == b)
    except ValueError:
        return False


def _moved_model(scenario: Scenario, nominal: _Model, t: np.ndarray, nodes: np.ndarray,
                 dependent: np.ndarray | None) -> _Model:
    """The model of a moved ``scenario`` (`_model`): the nominal one with the moved
    scenario where only what the equations do not read moved (a sensor), the nominal input
    table where the inputs did not move (drives, base loads, actuators, controllers)."""
    from dataclasses import replace

    other = nominal.scenario
    base, own = other.base, scenario.base
    inputs_same = (_equal(_input_sources(scenario.chain.joints),
                          _input_sources(other.chain.joints))
                   and _equal(scenario.actuators, other.actuators)
                   and _equal(scenario.controllers, other.controllers)
                   and _equal(scenario.settings, other.settings)
                   and _equal(None if own is None else (own.kind, own.loads, own.cart),
                              None if base is None else (base.kind, base.loads, base.cart)))
    if inputs_same and _equal(scenario.chain, other.chain) and _equal(own, base) \
            and _equal(scenario.closures, other.closures):
        return replace(nominal, scenario=scenario)
    return _model(scenario, t, nodes, dependent,
                  nominal.table if inputs_same and nominal.loops is None else None, nominal)


def _input_sources(joints: Any) -> tuple:
    """What the input rows and their breakpoints read of each joint
    (`forward_kernel.inputs`, `histories.input_breakpoints`): a torque drive's torque, a
    servo's reference, else the joint's (its motor's) whole prescribed motion; a servo's
    gains, a motor's inertia or a joint's start are not among them."""
    from ..model import PositionServo, TorqueDrive, VelocityServo
    from ..model.joints import drive_side

    out = []
    for joint in map(drive_side, joints):
        if isinstance(joint, TorqueDrive):
            out.append((TorqueDrive, joint.torque))
        elif isinstance(joint, VelocityServo | PositionServo):
            out.append((type(joint), joint.reference))
        else:
            out.append(joint)
    return tuple(out)


def _model(scenario: Scenario, t: np.ndarray, nodes: np.ndarray | None,
           dependent: np.ndarray | None = None, table: tuple | None = None,
           like: _Model | None = None) -> _Model:
    """The model of ``scenario``; ValueError if its input segments differ from ``nodes`` or
    its closures' dependent joints from ``dependent`` (those of the nominal model);
    ``table``: its input table where known to be another model's (the same inputs);
    ``like``: a model whose scratch workspace it shares where its records have the same
    shapes and types (the kernels hold nothing in it between calls)."""
    from ..dynamics._forward_numba import workspace
    from ..dynamics.forward_kernel import breakpoints, inputs, pack
    from ..dynamics.momentum_projection import projection, start_values
    from ..solvers.input_table import integrals, tabulate
    from ..solvers.radau import segment_nodes
    from .forward import forward_system

    system = forward_system(scenario)
    u0 = inputs(system, t[:1])[0]
    loops = None
    if scenario.closures:  # the loops' rates (the tree's on states closed by Newton)
        from ..dynamics.loops import LoopSystem

        loops = LoopSystem(system, scenario.closures)
        data, y0 = loops.data, loops.y0
        work = loops.workspace(y0.size)
        known = projection(system, pack(system), float(t[0]), u0.size)
        known = known._replace(active=known.active[:0])  # the Radau loop projects nothing
    else:
        data = pack(system)
        work = (like.work if like is not None and like.loops is None
                and len(system.servos) == len(like.system.servos)
                and _same_layout(data, like.data) else workspace(data, len(system.servos)))
        y0 = system.initial_state()
        known = projection(system, data, float(t[0]), u0.size)
        if known.active.size:
            start_values(known, data, work, u0, y0, float(t[-1]))
    samples = None
    if scenario.controllers:  # the run's steps also end on their sample instants
        from types import SimpleNamespace

        from ..solvers.gauss_sampled import sample_grid

        samples = SimpleNamespace(grid=sample_grid(scenario.controllers, float(t[-1])))
    if table is None:
        own = segment_nodes(t, breakpoints(system), samples)
        if nodes is not None and not (own.shape == nodes.shape and np.all(own == nodes)):
            raise ValueError("moves a time where an input jumps")
    if loops is not None and dependent is not None and not np.array_equal(loops.dep,
                                                                            dependent):
        raise ValueError("changes which joints the closures make dependent")
    if table is None:
        table = tabulate(lambda times: inputs(system, times), own)
    return _Model(scenario, system, data, work, known, y0, table,
                  integrals(table) if known.active.size else None, loops)


def _same_layout(a: Any, b: Any) -> bool:
    """Whether two ForwardData records have arrays of the same shapes and types and scalars
    of the same types (so the same compiled code and workspace serve both)."""
    for x, y in zip(a, b, strict=True):
        if isinstance(x, np.ndarray):
            if not (isinstance(y, np.ndarray) and x.shape == y.shape and x.dtype == y.dtype
                    and x.flags.c_contiguous == y.flags.c_contiguous):
                return False
        elif type(x) is not type(y):
            return False
    return True


def _rates(model: _Model) -> Any:
    from ..solvers._radau_numba import rates_at

    def rates(u: np.ndarray, Y: np.ndarray) -> np.ndarray:
        out = np.empty_like(Y)
        rates_at(model.data, model.work, np.ascontiguousarray(u), np.ascontiguousarray(Y), out)
        return out
    return rates


def _same_rates(a: _Model, b: _Model) -> bool:
    """Whether two models' rates are the same function: equal kernel data and input tables
    (a field read only by the channels, such as a sensor's place)."""
    if a.loops is not None or b.loops is not None:
        return a is b
    from .record_moves import same

    return ((a.data is b.data or all(same(x, y) for x, y in zip(a.data, b.data, strict=True)))
            and (a.table is b.table
                 or all(same(x, y) for x, y in zip(a.table, b.table, strict=True))))


def _linearization(nominal: _Model, moved: list[list[_Model]], fields: list,
                   reads: list[bool]) -> tuple:
    """(jacobians, forcing) of `radau_tangent` from the compiled equations
    (`dynamics._forward_jacobian_numba`): ∂f/∂y at the stages, exact along the elastic
    coordinates, and per field ∂f/∂p = −A⁻¹ ∂E/∂p from the moved models' equations at the
    nominal accelerations (forcing takes the stage states jacobians was last given)."""
    from ..dynamics._forward_jacobian_numba import forward_jacobians, jacobian_scratch
    from ..solvers.radau_sensitivity import JACOBIAN_STEP
    from .record_moves import applied_forces, moved_arrays, moved_equations

    d = nominal.data
    nu, n, m = d.free.shape[0], d.n_x - d.n_rigid, nominal.y0.size
    q, ns, K = nu + n, m - 2 * nu - 2 * n, len(fields)
    last: dict = {}
    scratch = jacobian_scratch(d, nominal.work, m)
    parts = [moved_arrays(nominal, group, more=True) for group in moved]

    def jacobians(u: np.ndarray, Y: np.ndarray) -> np.ndarray:
        rows = Y.shape[0]
        J, A, acc = np.empty((rows, m, m)), np.empty((rows, q, q)), np.empty((rows, q))
        forward_jacobians(d, nominal.work, np.ascontiguousarray(u), np.ascontiguousarray(Y),
                          JACOBIAN_STEP, J, A, acc, scratch)
        last.update(Y=Y, A=A, acc=acc)
        return J

    def forcing(times: np.ndarray, segment: np.ndarray, Y: np.ndarray) -> np.ndarray:
        bases = _Bases(segment, times)
        if last.get("Y") is not Y:
            jacobians(bases.rows(nominal.table), Y)
        rows = Y.shape[0]
        dE, dS = np.zeros((rows, q, K)), np.zeros((rows, ns, K))
        E, S = np.empty((rows, q)), np.empty((rows, ns))
        states = np.ascontiguousarray(Y)
        applied0 = (applied_forces(nominal, bases.rows(nominal.table), states)
                    if any(names is not None for names in parts) else None)
        for k, f in enumerate(fields):
            if not reads[k]:
                continue
            for w, md in zip(f.weights, moved[k], strict=True):
                moved_equations(md, nominal, parts[k], applied0, bases.rows(md.table), states,
                                last["acc"], E, S)
                dE[:, :, k] += (w / f.step) * E
                dS[:, :, k] += (w / f.step) * S
        da = -np.linalg.solve(last["A"], dE)
        out = np.zeros((rows, m, K))
        out[:, nu:2 * nu] = da[:, :nu]
        out[:, 2 * nu + n:2 * nu + 2 * n] = da[:, nu:]
        out[:, 2 * nu + 2 * n:] = dS
        return out
    return jacobians, forcing


class _Bases:
    """Input rows and the inputs' integrals of many models' input tables at the same times
    (`radau_sensitivity.table_rows`, `_radau_numba.input_integral`): the piece lookup and
    the Chebyshev polynomials made once per distinct set of pieces (the moved models'
    tables mostly have the nominal one's)."""

    def __init__(self, segment: np.ndarray, times: np.ndarray) -> None:
        self.segment, self.times = segment, times
        self.made: list[tuple[tuple, tuple, dict]] = []  # (table, (piece, x), {degree: T})
        # (table, its rows), not written to (numba compiles read-only arrays apart)
        self.read: list[tuple[tuple, np.ndarray]] = []

    def _basis(self, table: tuple, degree: int) -> tuple[np.ndarray, np.ndarray]:
        from ..solvers.radau_sensitivity import table_piece
        from .record_moves import same

        for other, located, polynomials in self.made:
            if other is table or all(same(x, y) for x, y in
                                     zip((table[0], table[1], table[3]),
                                         (other[0], other[1], other[3]), strict=True)):
                break
        else:
            located, polynomials = table_piece(table, self.segment, self.times), {}
            self.made.append((table, located, polynomials))
        if degree not in polynomials:
            polynomials[degree] = np.polynomial.chebyshev.chebvander(located[1], degree)
        return located[0], polynomials[degree]

    def rows(self, table: tuple) -> np.ndarray:
        """The input rows (n, columns) of ``table`` (made once per table object: not to be
        written to)."""
        from ..solvers.radau_sensitivity import table_rows

        for other, rows in self.read:
            if other is table:
                return rows
        rows = table_rows(table, self.segment, self.times,
                          self._basis(table, table[2].shape[1] - 1))
        self.read.append((table, rows))
        return rows

    def integrals(self, model: _Model) -> np.ndarray:
        """The inputs' integrals from the start (n, columns) of ``model``
        (`_radau_numba.input_integral`)."""
        anti, offset = model.integrals  # type: ignore[misc]
        piece, T = self._basis(model.table, anti.shape[1] - 1)
        return offset[piece] + np.einsum("nk,nkc->nc", T, anti[piece])


def _projected(model: _Model, Y: np.ndarray, times: np.ndarray, bases: _Bases,
               repeat: int = 1) -> np.ndarray:
    """The states Y (n · repeat, m) projected onto the model's known momentum at times (n,)
    (each repeated ``repeat`` times in a row) inside the input segments of ``bases``
    (`_momentum_numba.project`)."""
    from ..dynamics._forward_jacobian_numba import project_rows

    out = np.array(Y, dtype=float)
    u, U = bases.rows(model.table), bases.integrals(model)
    if repeat > 1:
        u, U, times = (np.repeat(v, repeat, axis=0) for v in (u, U, times))
    project_rows(model.data, model.work, model.projection, np.ascontiguousarray(u),
                 np.ascontiguousarray(U), np.ascontiguousarray(times), out)
    return out


@dataclass
class ForwardSettled:
    """A forward run with its accepted steps (`radau_sensitivity.StepSequence`), the nominal
    model and, per field, the models of its stencil (the nominal one where the offset is
    0): what its tangents (`forward_tangents`) and an objective's reverse pass
    (`simulation.forward_adjoint`) start from."""

    run: PathRun
    scenario: Scenario
    nominal: _Model
    moved: list[list[_Model]]
    steps: Any
    reads: list[bool]  # per field: whether the rates read it
    held: Any  # sampled controllers' held voltages (`HeldVoltages`), or None
    dy0: np.ndarray  # the initial state's derivative (m, K)


def forward_settled(scenario: Scenario, fields: list, t: np.ndarray, on_progress: Progress,
                    shapes: bool) -> ForwardSettled:
    """The forward run of ``scenario`` (`forward.run_forward`, compiled Radau IIA) with its
    steps and the fields' moved models; Refused for a field the computed run is not
    differentiable in."""
    from ..solvers.radau_sensitivity import step_sequence
    from .forward import run_forward

    records: list = []
    run = run_forward(scenario, t, on_progress, shapes, steps=records)
    nominal = _model(scenario, t, None)
    nodes = np.array([nominal.table[0][nominal.table[3][k]]
                      for k in range(nominal.table[3].size - 1)] + [t[-1]])
    dependent = None if nominal.loops is None else nominal.loops.dep
    moved: list[list[_Model]] = []
    for f in fields:
        try:
            moved.append([nominal if j == 0 else _moved_model(sc, nominal, t, nodes, dependent)
                          for j, sc in zip(f.offsets, f.scenarios, strict=True)])
        except ValueError as error:
            raise Refused(f"sensitivities: {f.target.text} {error}; the computed "
                                   "run is not differentiable in it on a fixed step "
                                   "sequence") from None
    if nominal.y0.size == 0:
        raise Refused("sensitivities: this run has no state to differentiate")
    steps = step_sequence(records)
    held = None
    if scenario.controllers:  # the voltages they hold between samples
        from .held_sensitivities import HeldVoltages

        try:
            held = HeldVoltages(nominal, moved, fields, steps, t)
        except ValueError as error:
            raise Refused(f"sensitivities: a field {error}; the computed run is not "
                          "differentiable in it on a fixed step sequence") from None
    # a field the rates do not read: its forcing is zero (no evaluations)
    reads = [not all(_same_rates(md, nominal) for md in group) for group in moved]
    dy0 = np.zeros((nominal.y0.size, len(fields)))
    for k, f in enumerate(fields):
        dy0[:, k] = sum(w * md.y0 for w, md in zip(f.weights, moved[k], strict=True)) / f.step
    return ForwardSettled(run, scenario, nominal, moved, steps, reads, held, dy0)


def run_with_forward_sensitivities(scenario: Scenario, fields: list, t: np.ndarray,
                                   on_progress: Progress, shapes: bool
                                   ) -> tuple[PathRun, dict[str, np.ndarray]]:
    """The forward run of ``scenario`` (`forward.run_forward`, compiled Radau IIA) and,
    per channel, its derivatives (nt, K) in the fields (`sensitivities._Field`)."""
    settled = forward_settled(scenario, fields, t, on_progress, shapes)
    return settled.run, forward_tangents(settled, fields, t)


def _projection_tangent(nominal: _Model, moved: list[list[_Model]], fields: list,
                        segment: np.ndarray, times: np.ndarray, Y: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray]:
    """The derivative of the projection of states Y (n, m) moving along dy (m, K) at
    times (n,), as J (n, m, m) and c (n, m, K): J[i] dy + c[i]. J: the nominal
    projection's Jacobian (below); c: per field, the projections of the
    moved models at Y combined by its stencil. Equal to the stencil applied to the moved
    projections at Y moved along dy to second order in the step (both stencils: their
    weights w_j at offsets j have Σ w_j = Σ w_j j² = 0, Σ w_j j = 1)."""
    from ..solvers.radau_sensitivity import JACOBIAN_STEP
    from .record_moves import same_projection

    n, m = Y.shape
    K = len(fields)
    nu, ne = len(nominal.system.free), nominal.system.n
    position = np.r_[0:nu, 2 * nu:2 * nu + ne]
    rate = np.r_[nu:2 * nu, 2 * nu + ne:2 * nu + 2 * ne]
    integral = np.arange(2 * nu + 2 * ne, m)
    c = np.zeros((n, m, K))
    bases = _Bases(segment, times)
    for k, f in enumerate(fields):
        if same_projection(nominal, moved[k]):  # c = 0: the stencil of one projection
            continue
        for w, md in zip(f.weights, moved[k], strict=True):
            c[:, :, k] += (w / f.step) * _projected(md, Y, times, bases)
    # the projection reads the configuration and the rates, not the servo integrals
    # (their columns: the identity); it is affine in the rates (the momentum is linear
    # in them at a fixed configuration, and so are its corrections): one unit step
    # each, exact; central differences along the configuration
    a, v = len(position), len(rate)
    eps = JACOBIAN_STEP * np.maximum(1.0, np.abs(Y[:, position]))
    shifted = np.repeat(Y[:, None, :], 2 * a + v + 1, axis=1)
    ia, iv = np.arange(a), np.arange(v)
    shifted[:, ia, position] += eps
    shifted[:, a + ia, position] -= eps
    shifted[:, 2 * a + iv, rate] += 1.0
    span = shifted[:, ia, position] - shifted[:, a + ia, position]
    unit = shifted[:, 2 * a + iv, rate] - Y[:, rate]
    P = _projected(nominal, shifted.reshape(-1, m), times, bases, 2 * a + v + 1
                   ).reshape(n, 2 * a + v + 1, m)
    J = np.zeros((n, m, m))
    J[:, :, position] = np.swapaxes((P[:, :a] - P[:, a:2 * a]) / span[:, :, None], 1, 2)
    J[:, :, rate] = np.swapaxes((P[:, 2 * a:2 * a + v] - P[:, -1:]) / unit[:, :, None],
                                1, 2)
    J[:, integral, integral] = 1.0
    return J, c


def state_tangents(settled: ForwardSettled, fields: list, t: np.ndarray) -> np.ndarray:
    """The derivatives (nt, m, K) of the states the run's outputs hold (projected onto the
    known momentum if the run projects) in the fields, from the fields' tangents."""
    from ..solvers.radau_sensitivity import (
        NODES,
        dense,
        output_steps,
        radau_tangent,
        table_rows,
    )

    nominal, moved, steps = settled.nominal, settled.moved, settled.steps
    held, reads, dy0 = settled.held, settled.reads, settled.dy0
    K = len(fields)
    m = nominal.y0.size
    rates_of = [[_rates(md) for md in group] for group in moved]

    def inputs_at(md: _Model, segment: np.ndarray, times: np.ndarray) -> np.ndarray:
        rows = table_rows(md.table, segment, times)
        if held is not None:
            rows[:, held.columns] = held.voltages_at(times)
        return rows

    def forcing(times: np.ndarray, segment: np.ndarray, Y: np.ndarray) -> np.ndarray:
        out = np.zeros((Y.shape[0], m, K))
        for k, f in enumerate(fields):
            if not reads[k]:
                continue
            for w, md, rates in zip(f.weights, moved[k], rates_of[k], strict=True):
                out[:, :, k] += (w / f.step) * rates(inputs_at(md, segment, times), Y)
        if held is None:
            return out
        # ∂f/∂V of the held voltages: the rates are affine in them (piezo moments)
        u = inputs_at(nominal, segment, times)
        columns = range(u.shape[1])[held.columns]
        dV = np.empty((Y.shape[0], m, len(columns)))
        for c, col in enumerate(columns):
            up, down = u.copy(), u.copy()
            up[:, col] += 1.0
            down[:, col] -= 1.0
            dV[:, :, c] = 0.5 * (rates_of_nominal(up, Y) - rates_of_nominal(down, Y))
        return np.concatenate([out, dV], axis=2)

    rates_of_nominal = _rates(nominal)
    projected = nominal.projection.active.size > 0

    def projection_tangent(segment: np.ndarray, times: np.ndarray, Y: np.ndarray
                           ) -> tuple[np.ndarray, np.ndarray]:
        return _projection_tangent(nominal, moved, fields, segment, times, Y)

    if projected:
        step_J, step_c = projection_tangent(steps.segment, steps.t + steps.h,
                                            steps.y0 + steps.z[:, 2])

    def project_step(s: int, y1: np.ndarray, dy1: np.ndarray) -> np.ndarray:
        return step_J[s] @ dy1 + step_c[s]

    stage_u = inputs_at(nominal, np.repeat(steps.segment, 3),
                        (steps.t[:, None] + steps.h[:, None] * NODES).ravel()
                        ).reshape(steps.h.size, 3, -1)
    # the compiled linearization where the model is one ForwardData without held inputs;
    # closed loops: fourth-order stage Jacobians (their rates are nonlinear in a light
    # link's elastic coordinates on a scale near the second-order step)
    jacobians = None
    if nominal.loops is None and held is None:
        jacobians, forcing = _linearization(nominal, moved, fields, reads)
    starts, dz, ends = radau_tangent(steps, _rates(nominal), stage_u, forcing, dy0,
                                     project_step if projected else None, jacobians,
                                     2 if nominal.loops is None else 4, held)
    if held is not None:
        held.finish(ends[-1])
    which, s = output_steps(steps, t)
    dstates = np.empty((t.size, m, K))
    dstates[0] = dy0
    dstates[1:] = dense(starts[which], dz[which], ends[which], s)
    if projected:  # the outputs are projected too
        raw = dense(steps.y0[which], steps.z[which], steps.y1[which], s)
        out_J, out_c = projection_tangent(steps.segment[which], t[1:], raw)
        dstates[1:] = np.einsum("nij,njk->nik", out_J, dstates[1:]) + out_c
    return dstates


def forward_tangents(settled: ForwardSettled, fields: list, t: np.ndarray
                     ) -> dict[str, np.ndarray]:
    """Per channel, the derivatives (nt, K) in the fields along a settled forward run, from
    the fields' tangents."""
    from ..solvers.radau_sensitivity import dense, output_steps

    run, nominal, moved, steps = settled.run, settled.nominal, settled.moved, settled.steps
    held, reads = settled.held, settled.reads
    dstates = state_tangents(settled, fields, t)
    which, s = output_steps(steps, t)
    # the states the channels are computed from: the run's outputs (projected onto the
    # known momentum), or for closed loops the integrated ones (the channels close them)
    states_out = _states(run, nominal)
    if nominal.loops is not None:
        states_out = np.vstack([nominal.y0, dense(steps.y0[which], steps.z[which],
                                                  steps.y1[which], s)])
    channels: dict[str, list[np.ndarray]] = {name: [] for name in run.values}
    unmoved: list = []  # the nominal model's outputs pass at states_out, once
    solved = (None if nominal.loops is not None or held is not None
              else _accelerations(nominal, t, states_out))
    for k, f in enumerate(fields):
        total: dict[str, np.ndarray] = {}
        # a field only the channels read (a sensor's place): the outputs pass is the
        # nominal one at the run's own states; only the channels differ
        same = (nominal.loops is None and held is None and not reads[k]
                and not np.any(dstates[:, :, k]))
        if same and not unmoved:
            unmoved.append(_outputs_pass(nominal, t, states_out, run))
        for j, w, md in zip(f.offsets, f.weights, moved[k], strict=True):
            y = states_out + j * f.step * dstates[:, :, k]
            loop = None if held is None else held.shifted(k, j * f.step)
            passed = unmoved[0] if same else None
            if passed is None and solved is not None:
                passed = _outputs_pass(md, t, y, run, _moved_accelerations(md, t, y, *solved))
            for name, v in _channels(md, t, y, run, passed, loop).items():
                total[name] = total.get(name, 0.0) + w * np.asarray(v, dtype=float)
        for name, column in channels.items():
            column.append(total[name] / f.step)
    return {name: np.stack(v, axis=-1) for name, v in channels.items()}


def _outputs_pass(model: _Model, t: np.ndarray, states: np.ndarray, run: PathRun,
                  accelerations: np.ndarray | None = None, loop: Any = None) -> tuple:
    """The Solution and the compiled outputs of ``model`` at the states (nt, m), with the
    given ``accelerations`` (p̈_free, z̈) (nt, ·) or those the rates solve for; ``loop``: the
    sampled controllers' records (`held_sensitivities.HeldVoltages.shifted`)."""
    from ..solvers.forward import forward_solution

    return forward_solution(model.data, model.work, model.system, t, states,
                            dict(run.solution.stats), loop, run.solution.accuracy,
                            model.projection, accelerations)


def _accelerations(model: _Model, t: np.ndarray, states: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The inverse of the equations' matrix A⁻¹ (nt, q, q) and the accelerations a (nt, q)
    that the rates of ``model`` solve for at the states (nt, m), times t
    (`_forward_jacobian_numba`)."""
    from ..dynamics._forward_jacobian_numba import forward_accelerations
    from ..dynamics.forward_kernel import inputs

    q = model.data.free.shape[0] + model.data.n_x - model.data.n_rigid
    A, acc = np.empty((t.size, q, q)), np.empty((t.size, q))
    forward_accelerations(model.data, model.work, inputs(model.system, t),
                          np.ascontiguousarray(states), A, acc)
    return np.linalg.inv(A), acc


def _moved_accelerations(model: _Model, t: np.ndarray, states: np.ndarray,
                         inverse: np.ndarray, acc: np.ndarray) -> np.ndarray:
    """The accelerations of a moved ``model`` at states (nt, m) near those where the nominal
    model's are acc with matrix A = inverse⁻¹ (`_accelerations`): one Newton step from them,
    a − A⁻¹ E(a). Its error, second order in the move, is even in it: a central difference
    of the channels keeps its order."""
    from ..dynamics._forward_jacobian_numba import forward_equations
    from ..dynamics.forward_kernel import inputs

    E = np.empty_like(acc)
    S = np.empty((t.size, states.shape[1] - 2 * acc.shape[1]))
    forward_equations(model.data, model.work, inputs(model.system, t),
                      np.ascontiguousarray(states), acc, E, S)
    return acc - np.einsum("nij,nj->ni", inverse, E)


def _channels(model: _Model, t: np.ndarray, states: np.ndarray, run: PathRun,
              passed: tuple | None = None, loop: Any = None) -> dict[str, np.ndarray]:
    """The forward path's channels of ``model`` at the integrator's states (nt, m);
    ``passed``: its outputs pass there (`_outputs_pass`), if already made; ``loop``: the
    sampled controllers' records (`held_sensitivities.HeldVoltages.shifted`)."""
    from .forward import forward_run

    stats = dict(run.solution.stats)
    if model.loops is None:
        solution, outputs = passed or _outputs_pass(model, t, states, run, loop=loop)
        return forward_run(model.scenario, model.system, t, solution, outputs, loop, {}, {},
                           False).values
    from ..solvers.loops import loop_run
    from .loops import closed_loop_outputs, closure_metadata, closure_values

    looped = loop_run(model.loops, t, states, stats, model.scenario.settings.rtol)
    outputs = closed_loop_outputs(model.system, looped.solution, looped.joint_forces)
    return forward_run(model.scenario, model.system, t, looped.solution, outputs, None,
                       closure_values(model.scenario, model.loops, looped.multipliers),
                       closure_metadata(model.loops, looped.residual), False).values


def _states(run: PathRun, model: _Model) -> np.ndarray:
    """The run's states y = [p_free, ṗ_free, z, ż, integrals] at the outputs."""
    sol = run.solution
    nu = len(model.system.free)
    return np.hstack([sol.q[:, :nu], sol.q_dot[:, :nu], sol.q[:, nu:], sol.q_dot[:, nu:],
                      sol.extra if sol.extra is not None else np.zeros((sol.t.size, 0))])


def refused(scenario: Scenario) -> str | None:
    """What keeps the forward run of ``scenario`` from taking sensitivities ("controllers[0]
    ('ppf') with quantization …", …), or None: they are computed on the compiled Radau IIA
    run, closed kinematic loops and sampled controllers included
    (`held_sensitivities.refused` names the controllers that cannot take them)."""
    from ..solvers.forward import FAST_METHOD

    if scenario.controllers:
        from .held_sensitivities import refused as controllers_refused

        what = controllers_refused(scenario)
        if what is not None:
            return what
    if scenario.settings.method not in (FAST_METHOD, "lawson", "magnus"):
        return f"a forward run with method = {scenario.settings.method!r}"
    return None
