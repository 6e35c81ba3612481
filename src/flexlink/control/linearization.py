"""The linearised plant of a scenario about a rest configuration or a time of its run.

The first-order equations are already the perturbation equations about the rigid motion
(docs/derivation.md): in x = [δp_free; z] (free rigid coordinates — base, driven joints —
then the elastic coordinates; prescribed joints have δβ = 0)

    M ẍ + C ẋ + K x = ∂Q/∂x x + ∂Q/∂ẋ ẋ + ∂Q/∂s s + B_u u,   ṡ = (servo integral law),

with M, C, K of `ForwardSystem.matrices` (or `FirstOrderSystem`'s when every joint is
prescribed on a fixed hub), Q the applied loads (servo laws, base loads), s the integrals of
the velocity servos' errors. The state is [x; ẋ; s]. The loads are linearised by central
differences of `ForwardSystem.applied` and `dynamics.servos.servo_torque` (piecewise linear:
exact unless on a saturation, which is refused); the outputs by differencing the channel
functions of channels/ on unit perturbations (affine in z, ż, z̈: exact; central differences
in the rigid coordinates). Accelerometers read z̈: their rows are C = Y_a A, D = Y_a B.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from os import PathLike
from typing import Any

import numpy as np

from ..channels.catalogue import cart_name, coordinate_name, joint_name
from ..channels.first_order import sensor_values, tip_values
from ..channels.forward import SolvedMotion, elastic_joint_values
from ..dynamics.actuators import actuator_matrix
from ..dynamics.elastic_joints import driven_motors
from ..dynamics.first_order import FirstOrderSystem
from ..dynamics.forward import ForwardSystem
from ..dynamics.kinematics import JointHistory, frame_motion
from ..dynamics.servos import servo_torque
from ..dynamics.torques import joint_torques
from ..model import Scenario, TorqueDrive, VelocityServo, is_driven
from ..model.joints import drive_side
from ..solvers import Solution
from .linear import LinearPlant
from .operating_point import (
    At,
    Configuration,
    NotLinearizable,
    Shifted,
    held_scenario,
    parse_at,
)
from .plant_parts import (  # noqa: F401 — modes.py and tests import these from here
    STEP,
    _check_run_size,
    _check_servos,
    _describe,
    _elastic_names,
    _input_unit,
    _plant,
    _rate_name,
    forward_system,
)

KINK = 1e-4  # one-sided slopes differing by more than this (relative): a saturation


@dataclass(frozen=True)
class _Equations:
    """M ẍ + C ẋ + K x = Qx x + Qv ẋ + Qs s + Bu u and ṡ = Rx x + Rv ẋ + Rs s + Ru u."""

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    Qx: np.ndarray
    Qv: np.ndarray
    Qs: np.ndarray
    Bu: np.ndarray
    Rx: np.ndarray
    Rv: np.ndarray
    Rs: np.ndarray
    Ru: np.ndarray


def linearize(scenario: Scenario | str | PathLike[str], at: At = 0.0,
              inputs: list[str] | None = None,
              outputs: list[str] | None = None) -> LinearPlant:
    """The continuous plant (A, B, C, D) of ``scenario`` about ``at``: a time in s of its run
    (the joints', base's and servos' state then; frozen-time unless it is at rest), joint
    angles in degrees (a sequence, one per joint) or a mapping ``{"joint2": 45, "base_x": 0.1,
    "base_attitude": 30}`` (a rest configuration; docs/control.md).

    Inputs: ``jointK_torque`` (N·m, torque drives), ``jointK_reference`` (rad) and, for a
    velocity servo with D ≠ 0, ``jointK_reference_rate`` (rad/s; a reference r(t) enters as
    both), ``base_force_x``, ``base_force_y`` (N, inertial axes at the base's reference
    point), ``base_moment`` (N·m), ``<actuator>_voltage`` (V). Outputs (deviations, SI): every
    sensor, the base pose and rates, the driven joints' angles and rates, every joint's motor
    torque, the link tips' X, Y.
    ``inputs``/``outputs``: keep only these, in this order. The first-order equations are
    used; a ``model = "nonlinear"`` scenario with prescribed joints is linearised at a rest
    configuration about its static deflection under the actuators' t = 0 voltages
    (control/nonlinear.py). ``scenario``: a `Scenario`, or the path of a scenario file."""
    from ..scenario.load import as_scenario

    scenario = as_scenario(scenario, "linearize")
    point = parse_at(scenario, at)
    original = scenario
    if isinstance(point, Configuration):
        scenario = held_scenario(scenario, point)
        t0 = 0.0
    else:
        t0 = point
    if scenario.closures:  # independent coordinates of the closed loops
        from .loop_plant import loop_plant

        plant = loop_plant(scenario, t0, point)
    elif scenario.settings.model == "nonlinear" and not scenario.is_forward:
        if not isinstance(point, Configuration):
            raise NotLinearizable("at: a model = 'nonlinear' scenario is linearised about a "
                                  "rest configuration (joint angles), its static deflection "
                                  "under the actuators' t = 0 voltages; a time of its run is "
                                  "not an equilibrium")
        from .nonlinear import nonlinear_plant

        plant = nonlinear_plant(original, scenario, point)
    elif scenario.is_forward:
        plant = forward_plant(scenario, t0, point)
    else:
        plant = _prescribed_plant(scenario, t0, point)
    if inputs is not None or outputs is not None:
        plant = plant.select(inputs, outputs)
    return plant


# -- every joint prescribed, fixed hub: FirstOrderSystem -----------------------------------------
def _prescribed_plant(scenario: Scenario, t0: float, point: float | Configuration) -> LinearPlant:
    system = FirstOrderSystem(scenario.chain, scenario.settings.geometric_stiffening,
                              gravity=scenario.settings.gravity)
    t = np.array([t0])
    if isinstance(point, Configuration):
        zeros = np.zeros((1, len(point.angles)))
        hist = JointHistory(np.array([point.angles]), zeros, zeros)
        frames = frame_motion(hist, system.modal, system.offsets, system.n, system.gravity)
    else:
        frames = system.frames(t)
        hist = system.joint_history(t)
    M, C, K, f = (a[0] for a in system.matrices(t, frames=frames))
    n = system.n
    bp = actuator_matrix(scenario.actuators, system.modal)
    eq = _Equations(M, C, K, np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, 0)), bp,
                    np.zeros((0, n)), np.zeros((0, n)), np.zeros((0, 0)),
                    np.zeros((0, bp.shape[1])))
    A, B = _state_matrices(eq)
    coords = _elastic_names(scenario)

    def readings(rows: _Rows) -> dict[str, np.ndarray]:
        m = rows.z.shape[0]
        fr = frames.at_rows(np.zeros(m, dtype=int))
        sol = Solution(np.full(m, t0), rows.z, rows.zd, rows.zdd, "linearize")
        out = sensor_values(system, fr, sol, scenario.sensors)
        torque = joint_torques(system, np.full(m, t0), rows.z, rows.zd, rows.zdd)
        for k in range(torque.shape[1]):  # what the motor holding a prescribed joint feels
            out[joint_name(k, "torque")] = torque[:, k]
        return {**out, **tip_values(system, fr, rows.z)}

    Cm, D, out_names = _outputs(readings, 0, n, A, B, 0)
    at_rest = bool(np.all(hist.rate == 0) and np.all(hist.acceleration == 0))
    # At rest the equations are affine in z with constant coefficients: the plant is that of
    # the deviations from the static deflection K⁻¹f (gravity, the t0 voltages), an
    # equilibrium; f = 0 makes it the undeformed configuration.
    equilibrium = at_rest
    op = _describe(scenario, point, equilibrium)
    if at_rest and np.abs(f).max(initial=0.0) > 0.0:
        z_static = np.linalg.solve(K, f)
        op["static_tip_deflection_m"] = [float(b.data.tip_value @ z_static[b.slice])
                                         for b in system.bodies]
    return _plant(scenario, A, B, Cm, D, coords, [], _input_names(scenario, []),
                  out_names, op, equilibrium)


# -- a moving base or driven joints: ForwardSystem ----------------------------------------------
def forward_plant(scenario: Scenario, t0: float, point: float | Configuration,
                  state: tuple[np.ndarray, ...] | None = None) -> LinearPlant:
    """The plant of a forward scenario at time t0 (``point``: t0 or the configuration the
    scenario is held in); ``state``: (p_free, ṗ_free, z, ż, integrals) at t0 if known (else
    the run is integrated up to t0)."""
    system = forward_system(scenario)
    nf, n, ns = len(system.free), system.n, len(system.servos)
    if state is None:
        state = run_state(scenario, system, t0)
    p_free, pd_free, z0, zd0, integral = state
    t = np.array([t0])
    pdd_free, zdd0, _ = system.accelerations(t, p_free[None], pd_free[None], z0[None],
                                             zd0[None], integral[None])
    p, pd, pdd = system.rigid_state(t, p_free[None], pd_free[None], pdd_free)
    M, C, K, _ = (a[0] for a in system.matrices(p, pd, pdd))
    keep = system.free + list(range(system.n_rigid, system.n_x))
    M, C, K = (a[np.ix_(keep, keep)] for a in (M, C, K))
    _check_servos(scenario, system, t0, p[0], pd[0], integral)
    Qx, Qv, Qs, Rx, Rv, Rs = _load_derivatives(system, t0, p[0], pd[0], integral, keep)
    Bu, Ru, in_names = _input_columns(scenario, system, t0, p[0], pd[0], integral, keep)
    eq = _Equations(M, C, K, Qx, Qv, Qs, Bu, Rx, Rv, Rs, Ru)
    A, B = _state_matrices(eq)
    moving = bool(np.abs(pd_free).max(initial=0.0) > 0 or np.abs(zd0).max(initial=0.0) > 0
                  or np.abs(z0).max(initial=0.0) > 0)
    if moving:  # frozen time: the Jacobian of the equations the run integrates, at its state
        A, B = _jacobian(system, t0, state, Bu, Ru, keep)
    own = [i for i in system.free if i < system.n_base]  # the base's free coordinates
    base_names = ([cart_name("position")] if system.base.cart is not None
                  else [f"base_{c}" for c in system.base.coordinates])
    joints = system.chain.joints
    rigid = base_names[:len(own)] + [coordinate_name(joints[k], k, "angle")
                                     for k in system.driven] + [
        joint_name(k, "motor_angle") for k in driven_motors(system.chain.joints)]

    def readings(rows: _Rows) -> dict[str, np.ndarray]:
        m = rows.z.shape[0]
        tt = np.full(m, t0)
        P, PD, PDD = system.rigid_state(tt, p_free + rows.p, pd_free + rows.pd,
                                        pdd_free[0] + rows.pdd)
        view = SolvedMotion(system, system.frames(P, PD, PDD))
        z, zd, zdd = z0 + rows.z, zd0 + rows.zd, zdd0[0] + rows.zdd
        out = sensor_values(view, view.frames, Solution(tt, z, zd, zdd, "linearize"),
                            scenario.sensors)
        out.update(elastic_joint_values(system, P, PD))
        for i, name in enumerate(rigid):  # catalogue order: base, joint angles, joint rates
            if name.startswith("base_"):
                out[name], out[f"{name}_rate"] = P[:, system.free[i]], PD[:, system.free[i]]
            if name == cart_name("position"):
                out[name], out[cart_name("velocity")] = P[:, system.free[i]], PD[:, system.free[i]]
        for i, name in enumerate(rigid):
            if name.startswith("joint"):
                out[name] = P[:, system.free[i]]
        for i, name in enumerate(rigid):
            if name.startswith("joint"):
                out[_rate_name(name)] = PD[:, system.free[i]]
        torque = system.joint_torques(P, PD, PDD, z, zd, zdd)
        for k in range(torque.shape[1]):
            out[coordinate_name(joints[k], k, "torque")] = torque[:, k]
        return {**out, **tip_values(view, view.frames, z)}

    Cm, D, out_names = _outputs(readings, nf, n, A, B, ns)
    # Servos without an integrator (position servos, I = 0) carry a constant integral state:
    # decoupled (zero rows and columns), so it is left out of the plant.
    kept = [i for i in range(A.shape[0]) if i < 2 * (nf + n)
            or system.servo_of(system.servos[i - 2 * (nf + n)])[0].integrator]
    A, B, Cm = A[np.ix_(kept, kept)], B[kept], Cm[:, kept]
    scale = max(np.abs(M).max(), 1.0)
    still = np.abs(np.concatenate([pdd_free[0], zdd0[0]])).max(initial=0.0) <= 1e-9 * scale
    rates = np.concatenate([pd_free, zd0])
    equilibrium = not np.abs(rates).max(initial=0.0) > 0 and bool(still)
    op = _describe(scenario, point, equilibrium)
    op.update({f"{name}": float(v) for name, v in zip(rigid, p_free)})
    return _plant(scenario, A, B, Cm, D, _elastic_names(scenario), rigid, in_names, out_names,
                  op, equilibrium, ns_names=[
                      "cart_error_integral" if k == len(scenario.chain.links)
                      else joint_name(k, "error_integral")
                      for k in system.servos if system.servo_of(k)[0].integrator])


def run_state(scenario: Scenario, system: ForwardSystem, t0: float) -> tuple[np.ndarray, ...]:
    """p_free, ṗ_free, z, ż, servo integrals at t0 of the scenario's run (t0 = 0: the
    initial state, no run)."""
    return run_states(scenario, system, np.array([t0]))[0]


def run_states(scenario: Scenario, system: ForwardSystem, times: np.ndarray
               ) -> list[tuple[np.ndarray, ...]]:
    """``run_state`` at each of the increasing times (s), from one run."""
    from ..solvers.forward import FAST_METHOD, integrate_forward, split_state

    times = np.asarray(times, dtype=float)
    initial = tuple(a[0] for a in split_state(system, system.initial_state()[None]))
    if times.max(initial=0.0) == 0.0:
        return [initial for _ in times]
    settings = scenario.settings
    dt = settings.dt_out
    _check_run_size(scenario, float(times.max()))
    grid = np.unique(np.concatenate([np.linspace(0.0, times.max(),
                                                 max(2, math.ceil(times.max() / dt) + 1)),
                                     times]))
    sol = integrate_forward(system, grid, settings.rtol, settings.atol, FAST_METHOD)
    nf = len(system.free)
    extra = sol.extra if sol.extra is not None else np.zeros((grid.size, 0))
    out = []
    for t in times:
        i = int(np.searchsorted(grid, t))
        out.append((sol.q[i, :nf], sol.q_dot[i, :nf], sol.q[i, nf:], sol.q_dot[i, nf:],
                    extra[i]))
    return out


def _central(fun: Any, width: int) -> tuple[np.ndarray, np.ndarray]:
    """Central differences of fun(deltas) (deltas (m, width) → values (m, k)) with respect to
    each of ``width`` variables, and whether the one-sided slopes agree (no kink)."""
    d = np.zeros((1 + 2 * width, width))
    for j in range(width):
        d[1 + j, j] = STEP
        d[1 + width + j, j] = -STEP
    v = fun(d)
    plus, minus, mid = v[1:1 + width], v[1 + width:], v[0]
    slope = ((plus - minus) / (2 * STEP)).T  # (k, width)
    fwd, bwd = (plus - mid) / STEP, (mid - minus) / STEP
    scale = np.abs(fwd).max(initial=0.0) + np.abs(bwd).max(initial=0.0) + 1e-12
    return slope, np.abs(fwd - bwd).max(initial=0.0) <= KINK * scale


def _load_derivatives(system: ForwardSystem, t0: float, p: np.ndarray, pd: np.ndarray,
                      integral: np.ndarray, keep: list[int]) -> tuple[np.ndarray, ...]:
    """∂Q/∂x, ∂Q/∂ẋ, ∂Q/∂s on the kept rows and the integral-rate derivatives."""
    nk, ns, nf = len(keep), len(integral), len(system.free)

    def applied(p_rows: np.ndarray, pd_rows: np.ndarray, s_rows: np.ndarray) -> np.ndarray:
        m = p_rows.shape[0]
        Q, rates = system.applied(np.full(m, t0), p_rows, pd_rows, s_rows)
        return np.concatenate([Q[:, keep], rates], 1)

    out = []
    for which, width in (("p", nf), ("pd", nf), ("s", ns)):
        def fun(d: np.ndarray, which: str = which) -> np.ndarray:
            m = d.shape[0]
            P, PD, S = np.tile(p, (m, 1)), np.tile(pd, (m, 1)), np.tile(integral, (m, 1))
            target = {"p": P, "pd": PD, "s": S}[which]
            cols = system.free if which != "s" else list(range(ns))
            target[:, cols] += d
            return applied(P, PD, S)

        slope, smooth = _central(fun, width) if width else (np.zeros((nk + ns, 0)), True)
        if not smooth:
            raise NotLinearizable("the applied loads have a kink (a saturation) at the "
                                  "operating point: choose another time or a rest "
                                  "configuration")
        full = np.zeros((nk + ns, nk if which != "s" else ns))
        full[:, :width] = slope
        out.append(full)
    Qx, Qv, Qs = (a[:nk] for a in out)
    Rx, Rv, Rs = (a[nk:] for a in out)
    return Qx, Qv, Qs, Rx, Rv, Rs


def _input_columns(scenario: Scenario, system: ForwardSystem, t0: float, p: np.ndarray,
                   pd: np.ndarray, integral: np.ndarray, keep: list[int]
                   ) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Generalized-force columns (kept rows) and integral-rate columns of every input."""
    nk, ns = len(keep), len(system.servos)
    cols: list[np.ndarray] = []
    rate_cols: list[np.ndarray] = []
    names: list[str] = []
    t = np.array([t0])

    def unit(index: int) -> np.ndarray:
        col = np.zeros(nk)
        col[keep.index(index)] = 1.0
        return col

    for k in system.driven:
        joint, i = drive_side(scenario.chain.joints[k]), system.drive_index(k)
        if not is_driven(joint):  # an elastic joint's prescribed motor
            continue
        if isinstance(joint, TorqueDrive):
            names.append(coordinate_name(scenario.chain.joints[k], k, "torque"))
            cols.append(unit(i))
            rate_cols.append(np.zeros(ns))
            continue
        s = system.servos.index(k)
        shifts = [("reference", (1.0, 0.0))]
        if isinstance(joint, VelocityServo) and joint.D != 0.0:
            shifts.append(("reference_rate", (0.0, 1.0)))
        for name, (da, dr) in shifts:
            vals = []
            for sign in (1.0, -1.0):
                shifted = replace(joint, reference=Shifted(joint.reference, sign * STEP * da,
                                                           sign * STEP * dr))
                vals.append(servo_torque(shifted, t, p[i:i + 1], pd[i:i + 1],
                                         integral[s:s + 1]))  # type: ignore[arg-type]
            dtau = float(vals[0][0][0] - vals[1][0][0]) / (2 * STEP)
            drate = float(vals[0][1][0] - vals[1][1][0]) / (2 * STEP)
            names.append(joint_name(k, name))
            cols.append(dtau * unit(i))
            rc = np.zeros(ns)
            rc[s] = drate
            rate_cols.append(rc)
    base, nb = system.base, system.n_base
    loads = {"free": [("base_force_x", 0), ("base_force_y", 1), ("base_moment", nb - 1)],
             "pinned": [("base_moment", nb - 1)], "fixed": [],
             "cart": [] if base.cart is None or base.cart.prescribed
             else [(cart_name("force"), 0)]}[base.kind]
    for name, index in loads:
        names.append(name)
        cols.append(unit(index))
        rate_cols.append(np.zeros(ns))
    bp = actuator_matrix(scenario.actuators, system.modal)
    for j, act in enumerate(scenario.actuators):
        col = np.zeros(nk)
        col[len(system.free):] = bp[:, j]
        names.append(f"{act.name}_voltage")
        cols.append(col)
        rate_cols.append(np.zeros(ns))
    Bu = np.column_stack(cols) if cols else np.zeros((nk, 0))
    Ru = np.column_stack(rate_cols) if rate_cols else np.zeros((ns, 0))
    return Bu, Ru, names


class _Loaded(ForwardSystem):
    """The forward system with an extra generalized force (n_x,) added to its applied loads
    and an extra servo-integral rate: inputs seen through the equations the run integrates."""

    extra = np.zeros(0)
    extra_rates = np.zeros(0)

    def applied(self, t: np.ndarray, p: np.ndarray, pd: np.ndarray, integral: np.ndarray,
                voltages: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        Q, rates = super().applied(t, p, pd, integral, voltages)
        return Q + self.extra, rates + self.extra_rates


def _jacobian(system: ForwardSystem, t0: float, state: tuple[np.ndarray, ...], Bu: np.ndarray,
              Ru: np.ndarray, keep: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """A, B of the state [δp_free; z; δṗ_free; ż; s] by central differences of
    `ForwardSystem.accelerations` at a moving state (rigid and elastic coordinates of the run):
    there the rigid rows are nonlinear and the mass matrix depends on z."""
    loaded = _Loaded(system.chain, system.base, system.geometric_stiffening, system.actuators,
                     gravity=system.gravity)
    nf, n, ns = len(system.free), system.n, len(system.servos)
    y0 = np.concatenate(state)  # [p, ṗ, z, ż, s]
    t = np.array([t0])

    def rhs(y: np.ndarray, extra: np.ndarray, extra_rates: np.ndarray) -> np.ndarray:
        _, pd, z, zd, s = np.split(y, np.cumsum([nf, nf, n, n]))
        p = y[:nf]
        loaded.extra, loaded.extra_rates = extra, extra_rates
        pdd, zdd, rates = loaded.accelerations(t, p[None], pd[None], z[None], zd[None], s[None])
        return np.concatenate([pd, pdd[0], zd, zdd[0], rates[0]])

    none, no_rate = np.zeros(system.n_x), np.zeros(ns)
    size = y0.size
    J = np.zeros((size, size))
    for j in range(size):
        e = np.zeros(size)
        e[j] = STEP
        J[:, j] = (rhs(y0 + e, none, no_rate) - rhs(y0 - e, none, no_rate)) / (2 * STEP)
    Jb = np.zeros((size, Bu.shape[1]))
    for j in range(Bu.shape[1]):
        force = np.zeros(system.n_x)
        force[keep] = Bu[:, j] * STEP
        rate = Ru[:, j] * STEP
        Jb[:, j] = (rhs(y0, force, rate) - rhs(y0, -force, -rate)) / (2 * STEP)
    order = (list(range(nf)) + list(range(2 * nf, 2 * nf + n)) + list(range(nf, 2 * nf))
             + list(range(2 * nf + n, 2 * nf + 2 * n)) + list(range(2 * nf + 2 * n, size)))
    return J[np.ix_(order, order)], Jb[order]


# -- common -------------------------------------------------------------------------------------
def _state_matrices(eq: _Equations) -> tuple[np.ndarray, np.ndarray]:
    """A, B of the state [x; ẋ; s]."""
    nx, ns, m = eq.M.shape[0], eq.Rs.shape[0], eq.Bu.shape[1]
    Minv = np.linalg.inv(eq.M)
    A = np.zeros((2 * nx + ns, 2 * nx + ns))
    A[:nx, nx:2 * nx] = np.eye(nx)
    A[nx:2 * nx, :nx] = -Minv @ (eq.K - eq.Qx)
    A[nx:2 * nx, nx:2 * nx] = -Minv @ (eq.C - eq.Qv)
    A[nx:2 * nx, 2 * nx:] = Minv @ eq.Qs
    A[2 * nx:, :nx] = eq.Rx
    A[2 * nx:, nx:2 * nx] = eq.Rv
    A[2 * nx:, 2 * nx:] = eq.Rs
    B = np.zeros((2 * nx + ns, m))
    B[nx:2 * nx] = Minv @ eq.Bu
    B[2 * nx:] = eq.Ru
    return A, B


@dataclass(frozen=True)
class _Rows:
    """Perturbations of (free rigid coordinates, their rates and accelerations, z, ż, z̈)."""

    p: np.ndarray
    pd: np.ndarray
    pdd: np.ndarray
    z: np.ndarray
    zd: np.ndarray
    zdd: np.ndarray


def _outputs(readings: Any, nf: int, n: int, A: np.ndarray, B: np.ndarray, ns: int
             ) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Output rows C, D by differencing ``readings`` (a dict of channel values per row):
    exact unit steps in z, ż, z̈ (the readings are affine in them), central differences in
    the rigid coordinates; y = Y_x x + Y_v ẋ + Y_a ẍ with ẍ from the state equations."""
    nx = nf + n
    rows = 1 + 3 * n + 6 * nf
    d = {k: np.zeros((rows, w)) for k, w in
         (("p", nf), ("pd", nf), ("pdd", nf), ("z", n), ("zd", n), ("zdd", n))}
    r = 1
    for key in ("z", "zd", "zdd"):
        d[key][r:r + n] = np.eye(n)
        r += n
    for key in ("p", "pd", "pdd"):
        d[key][r:r + nf] = STEP * np.eye(nf)
        d[key][r + nf:r + 2 * nf] = -STEP * np.eye(nf)
        r += 2 * nf
    values = readings(_Rows(**d))
    names = list(values)
    Y = np.column_stack([np.asarray(values[k], dtype=float) for k in names])  # (rows, p)
    Y = Y - Y[0]
    Yx, Yv, Ya = (np.zeros((len(names), nx)) for _ in range(3))
    r = 1
    for target in (Yx, Yv, Ya):
        target[:, nf:] = Y[r:r + n].T
        r += n
    for target in (Yx, Yv, Ya):
        target[:, :nf] = (Y[r:r + nf] - Y[r + nf:r + 2 * nf]).T / (2 * STEP)
        r += 2 * nf
    C = np.zeros((len(names), 2 * nx + ns))
    C[:, :nx] = Yx
    C[:, nx:2 * nx] = Yv
    C += Ya @ A[nx:2 * nx]
    D = Ya @ B[nx:2 * nx]
    return C, D, names


def _input_names(scenario: Scenario, names: list[str]) -> list[str]:
    return names + [f"{a.name}_voltage" for a in scenario.actuators]


