"""The linearised plant of a mechanism with closed loops (`[[closures]]`, first-order model)
about a rest configuration or a time of its run, in independent coordinates.

Coordinate partitioning (docs/derivation.md §13) makes the closed mechanism an ODE in its
independent components: the free joint angles the closures do not determine, the elastic
coordinates, their rates and the servo integrals; the dependent joint angles and rates are
functions of them (the compiled `project`). The plant is that ODE's Jacobian

    ẋ = A x + B u,   y = C x + D u,   x = [δp_ind; z; δṗ_ind; ż; s],

by central differences of the compiled closed-loop rates (`dynamics._loops_numba.rates_in`:
the constrained equations on the projected state) over the independent components (A) and
over the input row's columns of the drives and actuators (B); C and D by central differences
of the run's channel functions on projected states (the dependent joints' angles and rates,
the joints' motor torques without the constraint forces, the closures' forces, sensors and
tips, and a moving base's pose and rates: `base_x`, `base_x_rate` …, `cart_position`,
`cart_velocity`, as the open chain's plant names them). At rest without loads this is the linearisation about an equilibrium; elsewhere it is
frozen-time (docs/control.md).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..channels.catalogue import cart_name, coordinate_name, joint_name
from ..channels.first_order import sensor_values, tip_values
from ..channels.forward import SolvedMotion, elastic_joint_values
from ..dynamics import forward_kernel
from ..dynamics.forward import ForwardSystem
from ..dynamics.forward_kernel import inputs as input_rows
from ..dynamics.forward_kernel import voltage_columns
from ..dynamics.loops import LoopSystem, difference_steps, reduced_jacobian
from ..model import Scenario, TorqueDrive, VelocityServo, is_driven
from ..model.joints import drive_side
from ..solvers import Solution
from .linear import LinearPlant
from .operating_point import Configuration
from .plant_parts import STEP, _check_servos, _describe, _elastic_names, _plant, forward_system

# The projection closes each perturbed state to 1e-12 of the loop's size: a difference step
# well above that keeps the closure's round-off out of the slopes.
OUTPUT_STEP = 1e-6


def loop_plant(scenario: Scenario, t0: float, point: float | Configuration,
               state: np.ndarray | None = None) -> LinearPlant:
    """The plant of a closed-loop ``scenario`` at time t0 (``point``: t0, or the
    configuration it is held in); ``state``: the closed state y = [p_free, ṗ_free, z, ż,
    integrals] at t0 if known (else the run is integrated up to t0)."""
    system = forward_system(scenario)
    loops = LoopSystem(system, scenario.closures)
    y = loop_states(scenario, loops, np.array([t0]))[0] if state is None else state
    nu, n = len(system.free), system.n
    J, keep = reduced_jacobian(loops, t0, y)
    independent = [j for j in range(nu) if j not in set(loops.dep.tolist())]
    ni = len(independent)
    # kept: [p_ind, ṗ_ind, z, ż, s]; the plant's order: [p_ind, z, ṗ_ind, ż, s (integrators)]
    integrators = [i for i, k in enumerate(system.servos) if scenario.chain.joints[k].integrator]
    order = (list(range(ni)) + list(range(2 * ni, 2 * ni + n)) + list(range(ni, 2 * ni))
             + list(range(2 * ni + n, 2 * ni + 2 * n)) + [2 * ni + 2 * n + i for i in integrators])
    A = J[np.ix_(order, order)]
    full = keep[order]  # each plant state's index into y
    u0 = input_rows(system, np.array([float(t0)]))[0]
    p, pd, _ = _rigid(system, t0, y[None])
    _check_servos(scenario, system, t0, p[0], pd[0], y[2 * (nu + n):])
    columns, in_names = _input_columns(scenario, system)
    B = _input_jacobian(loops, u0, y, columns, full)

    def readings(ys: np.ndarray, us: np.ndarray) -> dict[str, np.ndarray]:
        return _readings(scenario, loops, t0, ys, us)

    C, D, out_names = _output_jacobians(readings, y, u0, full, columns,
                                        difference_steps(system, y, OUTPUT_STEP)[full])
    rigid = [_coordinate_name(system, system.free[j]) for j in independent]
    dy = np.empty_like(y)
    from ..solvers._radau_numba import rates_function

    rates_function(loops.data, loops.workspace(y.size))(u0, y, dy)
    moving = np.abs(np.concatenate([y[nu:2 * nu], y[2 * nu + n:2 * nu + 2 * n]])
                    ).max(initial=0.0) > 0
    scale = max(1.0, np.abs(A).max())
    still = np.abs(np.concatenate([dy[nu:2 * nu], dy[2 * nu + n:2 * nu + 2 * n]])
                   ).max(initial=0.0) <= 1e-9 * scale
    equilibrium = not moving and bool(still)
    op = _describe(scenario, point, equilibrium)
    joints = scenario.chain.joints
    closed = {k: float(p[0, system.joint_index(k)]) for k in range(len(joints))}
    op.update({coordinate_name(joints[k], k, "angle"): v for k, v in closed.items()})
    if isinstance(point, Configuration):  # the loop's angles, not the guesses given in ``at``
        op.update({f"joint{k + 1}_deg": math.degrees(v) for k, v in closed.items()
                   if coordinate_name(joints[k], k, "angle").endswith("_angle")})
    op["dependent_joints"] = " ".join(joint_name(system.free[j] - system.n_base, "angle")
                                      .removesuffix("_angle") for j in loops.dep)
    return _plant(scenario, A, B, C, D, _elastic_names(scenario), rigid, in_names, out_names,
                  op, equilibrium, ns_names=[joint_name(system.servos[i], "error_integral")
                                             for i in integrators])


def loop_states(scenario: Scenario, loops: LoopSystem, times: np.ndarray) -> list[np.ndarray]:
    """The closed state y = [p_free, ṗ_free, z, ż, integrals] at each of the increasing
    times (s) of the scenario's run, from one run (t = 0 alone: the closed initial state)."""
    from ..solvers.loops import integrate_loops
    from .plant_parts import _check_run_size

    times = np.asarray(times, dtype=float)
    if times.max(initial=0.0) == 0.0:
        return [loops.y0.copy() for _ in times]
    settings = scenario.settings
    _check_run_size(scenario, float(times.max()))
    grid = np.unique(np.concatenate([np.linspace(
        0.0, times.max(), max(2, math.ceil(times.max() / settings.dt_out) + 1)), times]))
    sol = integrate_loops(loops, grid, settings.rtol, settings.atol).solution
    nu = len(loops.system.free)
    extra = sol.extra if sol.extra is not None else np.zeros((grid.size, 0))
    out = []
    for t in times:
        i = int(np.searchsorted(grid, t))
        out.append(np.concatenate([sol.q[i, :nu], sol.q_dot[i, :nu], sol.q[i, nu:],
                                   sol.q_dot[i, nu:], extra[i]]))
    return out


def _coordinate_name(system: ForwardSystem, i: int) -> str:
    """The channel name of rigid coordinate i: the base's (``base_x``, ``cart_position``
    …), a joint's angle (a slider's position), an elastic joint's motor angle (after the
    joints' in p)."""
    k = i - system.n_base
    N = len(system.chain.links)
    if k < 0:
        base = system.base
        return (cart_name("position") if base.cart is not None
                else f"base_{base.coordinates[i]}")
    if k < N:
        return coordinate_name(system.chain.joints[k], k, "angle")
    return joint_name(system.elastic[k - N], "motor_angle")


def _rigid(system: ForwardSystem, t0: float, ys: np.ndarray, pdd_free: np.ndarray | None = None
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """p, ṗ, p̈ (m, n_rigid) of the rows ys (their free coordinates) at time t0."""
    nu = len(system.free)
    m = ys.shape[0]
    pdd = np.zeros((m, nu)) if pdd_free is None else pdd_free
    return system.rigid_state(np.full(m, t0), ys[:, :nu], ys[:, nu:2 * nu], pdd)


def _input_columns(scenario: Scenario, system: ForwardSystem
                   ) -> tuple[list[int], list[str]]:
    """Each input's column of the input row u (forward_kernel.inputs) and its name: the
    torque of a torque drive (free joints too: a torque on a dependent joint acts through
    the loop), a servo's reference (and a velocity servo's reference rate with D ≠ 0), each
    actuator's voltage."""
    N = len(system.chain.links)
    cols, names = [], []
    for k in system.driven:
        joint = drive_side(scenario.chain.joints[k])
        if not is_driven(joint):
            continue
        if isinstance(joint, TorqueDrive):
            cols.append(3 * N + k)
            names.append(joint_name(k, "torque"))
            continue
        cols.append(k)
        names.append(joint_name(k, "reference"))
        if isinstance(joint, VelocityServo) and joint.D != 0.0:
            cols.append(N + k)
            names.append(joint_name(k, "reference_rate"))
    volts = voltage_columns(system)
    for j, act in enumerate(scenario.actuators):
        cols.append(volts.start + j)
        names.append(f"{act.name}_voltage")
    return cols, names


def _input_jacobian(loops: LoopSystem, u0: np.ndarray, y: np.ndarray, columns: list[int],
                    full: np.ndarray) -> np.ndarray:
    """∂ẋ/∂u over the inputs' columns of the input row, on the plant's states ``full``."""
    from ..solvers._radau_numba import rates_function

    rates = rates_function(loops.data, loops.workspace(y.size))
    B = np.empty((full.size, len(columns)))
    up, down = np.empty_like(y), np.empty_like(y)
    for c, col in enumerate(columns):
        for sign, out in ((1.0, up), (-1.0, down)):
            u = u0.copy()
            u[col] += sign * STEP
            rates(u, y, out)
        B[:, c] = (up[full] - down[full]) / (2 * STEP)
    return B


def _readings(scenario: Scenario, loops: LoopSystem, t0: float, ys: np.ndarray,
              us: np.ndarray) -> dict[str, np.ndarray]:
    """Channel values (by name) of the states ys (m, ·) under the input rows us, each
    projected onto the loops as a run's outputs are (simulation/loops.py)."""
    from ..dynamics._loops_numba import closed_states
    from ..simulation.loops import closure_values

    system = loops.system
    nu, n = len(system.free), system.n
    m = ys.shape[0]
    states = np.ascontiguousarray(ys, dtype=float).copy()
    lam = np.empty((m, loops.n_c))
    joint_forces = np.empty((m, len(system.chain.links)))
    residual = np.empty(m)
    work = loops.workspace(states.shape[1])
    dy = np.empty_like(states)
    closed_states(loops.data, work, us, states, dy, lam, joint_forces, residual)
    p, pd, pdd = _rigid(system, t0, states, dy[:, nu:2 * nu])
    z, zd = states[:, 2 * nu:2 * nu + n], states[:, 2 * nu + n:2 * nu + 2 * n]
    zdd = dy[:, 2 * nu + n:2 * nu + 2 * n]
    tt = np.full(m, t0)
    view = SolvedMotion(system, system.frames(p, pd, pdd))
    out = sensor_values(view, view.frames, Solution(tt, z, zd, zdd, "linearize"),
                        scenario.sensors)
    torque = forward_kernel.joint_torques(system, p, pd, pdd, z, zd, zdd) - joint_forces
    for i in system.free:  # the moving base's pose and rates, named as the open chain's
        if i < system.n_base:
            name = _coordinate_name(system, i)
            rate = cart_name("velocity") if name == cart_name("position") else f"{name}_rate"
            out[name], out[rate] = p[:, i], pd[:, i]
    joints = scenario.chain.joints
    for k in range(len(joints)):
        if system.joint_index(k) in system.free:
            out[coordinate_name(joints[k], k, "angle")] = p[:, system.joint_index(k)]
            out[coordinate_name(joints[k], k, "rate")] = pd[:, system.joint_index(k)]
    for k in range(torque.shape[1]):
        out[coordinate_name(joints[k], k, "torque")] = torque[:, k]
    out.update(elastic_joint_values(system, p, pd))
    out.update(closure_values(scenario, loops, lam))
    return {**out, **tip_values(view, view.frames, z)}


def _output_jacobians(readings: Any, y: np.ndarray, u0: np.ndarray, full: np.ndarray,
                      columns: list[int], state_steps: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """C, D by central differences of ``readings`` over the plant's states (their entries
    ``full`` of y, steps ``state_steps``: `difference_steps`) and the inputs' columns of u."""
    ns, ni = full.size, len(columns)
    width = ns + ni
    ys = np.tile(y, (1 + 2 * width, 1))
    us = np.tile(u0, (1 + 2 * width, 1))
    steps = np.empty(width)
    for j in range(width):
        if j < ns:
            h = state_steps[j]
            ys[1 + j, full[j]] += h
            ys[1 + width + j, full[j]] -= h
        else:
            h = STEP
            us[1 + j, columns[j - ns]] += h
            us[1 + width + j, columns[j - ns]] -= h
        steps[j] = h
    values = readings(ys, us)
    names = list(values)
    Y = np.column_stack([np.asarray(values[k], dtype=float) for k in names])
    slope = ((Y[1:1 + width] - Y[1 + width:]) / (2 * steps[:, None])).T
    return slope[:, :ns], slope[:, ns:], names
