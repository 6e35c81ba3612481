"""Forward dynamics, first-order model (free or pinned base, driven joints):
ForwardSystem → compiled Radau IIA (solvers/radau.py; or solve_ivp, method = "DOP853",
"Radau", …) → channels. Sampled controllers run with the compiled integrator."""

from __future__ import annotations

import itertools
from types import SimpleNamespace
from typing import TYPE_CHECKING

import numpy as np

from ..channels.catalogue import cart_name, closure_name, voltage_name
from ..channels.first_order import sensor_values, shape_values, tip_deflections, tip_values
from ..channels.forward import SolvedMotion, pose_and_joint_values
from ..channels.shapes import LazyShapes
from ..dynamics.forward import ForwardSystem, drive_force
from ..errors import SimulationError, StoppedRun
from ..model import Base, Scenario
from ..model.basis import held_by_loop
from ..solvers import Solution
from ..solvers.forward import FAST_METHOD, integrate_forward
from ..solvers.gauss_sampled import SampledLoop, sample_grid
from .accuracy import (
    LOOP_SPAN_POINTS,
    axial_load_parameter,
    hangs_on_elastic,
    loop_held_measure,
    loop_limits,
    loop_validity_warning,
)
from .cart import LAST, SAMPLE, STEP, check_travel
from .closed_loop import control_values, sensor_rows
from .common import STEP_BEYOND, PathRun, Progress, check_tip_deflection, deflection_error
from .prismatic import check_travel as check_slider_travel
from .slider_drift import slider_drift_metadata

if TYPE_CHECKING:
    from ..dynamics.loops import LoopSystem


def forward_system(scenario: Scenario) -> ForwardSystem:
    """The forward system of ``scenario`` (first-order model)."""
    settings = scenario.settings
    return ForwardSystem(scenario.chain, scenario.base or Base(), settings.geometric_stiffening,
                         scenario.actuators, gravity=settings.gravity, initial=settings.initial)


def run_forward(scenario: Scenario, t: np.ndarray, on_progress: Progress,
                  with_shapes: bool = True, steps: list | None = None) -> PathRun:
    """The forward run; ``steps``: a list that receives the compiled integrator's accepted
    steps (`solvers.radau.integrate_radau`)."""
    settings = scenario.settings
    system = forward_system(scenario)
    method = settings.method if settings.method not in ("lawson", "magnus") else FAST_METHOD
    loop = sampled_loop(scenario, system, t) if scenario.controllers else None
    closures: dict = {}
    closure_values: dict = {}
    if scenario.closures:  # loops closed by constraints (simulation/loops.py)
        from .loops import closed_loop_outputs, closed_loop_solution

        try:
            solution, closure_values, joint_forces, closures = closed_loop_solution(
                scenario, system, t, on_progress, loop, steps)
        except StoppedRun as stop:
            explain_stop(scenario, system, t, stop, loop is not None)
            raise
        outputs = closed_loop_outputs(system, solution, joint_forces)
    else:
        try:
            solution, outputs = integrate_forward(system, t, settings.rtol, settings.atol,
                                                  method, on_progress, loop=loop,
                                                  with_outputs=True, steps=steps)
        except StoppedRun as stop:
            explain_stop(scenario, system, t, stop, loop is not None)
            raise
    return forward_run(scenario, system, t, solution, outputs, loop, closure_values, closures,
                       with_shapes)


def explain_stop(scenario: Scenario, system: ForwardSystem, t: np.ndarray, stop: StoppedRun,
                 controlled: bool) -> None:
    """A SimulationError naming what stopped the run where it was a travel left, a tip beyond
    its length or loads far beyond the model's range (``controlled``: sampled controllers
    ran); else nothing, and the stop's own error stands."""
    check_travel_before(scenario, system, t, stop)
    check_deflection_at_stop(scenario, system, t, stop, controlled)
    check_loads_at_stop(scenario, system, stop)


def check_travel_before(scenario: Scenario, system: ForwardSystem, t: np.ndarray,
                        stop: StoppedRun) -> None:
    """A run that stopped (a step ended outside a travel, its state grew without bound, or
    its step collapsed) after a cart or a slider had left its travel: the travel's error,
    which names the cause and the field, in place of the stop's. Read on the output samples
    reached, then on the last state."""
    if stop.states is None or stop.y is None:
        return
    nu = len(system.free)
    then = f"; the run then stopped at t = {stop.t:.6g} s"
    reached = np.all(np.isfinite(stop.states[:, :2 * nu]), axis=1)
    for times, rows, where in ((t[reached], stop.states[reached], SAMPLE),
                               (np.array([stop.t]), stop.y[None, :],
                                STEP if stop.left_travel else LAST)):
        if not np.all(np.isfinite(rows[:, :2 * nu])):
            continue
        p = system.rigid_state(times, rows[:, :nu], rows[:, nu:2 * nu],
                               np.zeros((times.size, nu)))[0]
        tail = then if where == SAMPLE else ""
        check_travel(scenario.base, times, p[:, 0], where, tail)
        check_slider_travel(system.chain.joints, times, p, system.n_base, where, tail)


def check_deflection_at_stop(scenario: Scenario, system: ForwardSystem, t: np.ndarray,
                             stop: StoppedRun, controlled: bool) -> None:
    """A run the compiled integrator stopped at a step that ended with a link's tip beyond
    its length (`solvers.forward.deflection_bounds`): that error in place of the stop's, at
    the first output sample reached beyond it, else at the step's end (``controlled``: under
    sampled controllers, an unstable closed loop)."""
    if not stop.left_travel or stop.y is None or stop.states is None:
        return
    start = 2 * len(system.free) - system.n_rigid  # a body's offset is its column in [δp; z]
    reached = np.all(np.isfinite(stop.states), axis=1)
    step = STEP_BEYOND + ": the run stopped there)"
    for times, rows, where in ((t[reached], stop.states[reached], ""),
                               (np.array([stop.t]), stop.y[None, :], step)):
        for k, body in enumerate(system.bodies):
            link = scenario.chain.links[k]
            z = rows[:, start + body.offset:start + body.offset + body.data.n]
            beyond = np.abs(z @ body.data.tip_value) > link.length
            if beyond.any():
                exc = deflection_error(link, float(times[int(np.argmax(beyond))]),
                                       system.geometric_stiffening, where)
                raise SimulationError(f"closed loop unstable: {exc}" if controlled
                                      else str(exc)) from None


def check_loads_at_stop(scenario: Scenario, system: ForwardSystem, stop: StoppedRun) -> None:
    """A run that stalled or blew up under loads far beyond the first-order model's range:
    an error naming them, in place of the stop's (whose hint is about the integrator; on
    closed loops, a toggle position). The measure is `static_deflection_ratio` from the
    start state with the loads at the stop, the loops closed."""
    if stop.left_travel:
        return
    loops = None
    if scenario.closures:
        from ..dynamics.loops import LoopSystem

        loops = LoopSystem(system, scenario.closures)
    ratio, at_tip = static_deflection_ratio(system, stop.t, loops)
    k = int(np.argmax(np.where(np.isfinite(ratio), ratio, np.inf))) if ratio.size else 0
    if not ratio.size or ratio[k] <= 1.0:
        return
    size = f"{ratio[k]:.3g} times" if np.isfinite(ratio[k]) else "beyond any multiple of"
    where = "'s tip" if at_tip[k] else " across its span"
    loads = ", ".join(applied_loads(scenario, system, stop.t)) or "no load given: the initial state"
    raise SimulationError(
        f"the forward run stopped at t = {stop.t:.6g} s under loads far beyond the first-order "
        f"model's range: the accelerations they cause at the start would bend "
        f"{scenario.chain.links[k].name}{where} "
        f"{size} its length if held steady ({loads}); "
        "check their values and units") from None


def static_deflection_ratio(system: ForwardSystem, t: float, loops: LoopSystem | None = None
                            ) -> tuple[np.ndarray, np.ndarray]:
    """Each link's largest deflection per length (its tip, or LOOP_SPAN_POINTS interior
    points: a link a loop holds at both ends has no tip deflection) that its modal
    accelerations at the start state under the loads at ``t`` (s) would hold steady,
    K⁻¹ M z̈ of its clamped modes: far above 1 where the loads are beyond what the model can
    carry (inf where not finite); and whether the tip's is the largest. With ``loops``: the
    closed start state, the accelerations the closures allow (the loads they carry bend the
    links as the loops hold them)."""
    with np.errstate(all="ignore"):
        try:
            zdd = _start_modal_accelerations(system, t, loops)
        except (np.linalg.LinAlgError, ValueError, FloatingPointError):
            zdd = np.full(system.n, np.nan)
        out = np.zeros(len(system.bodies))
        at_tip = np.ones(len(system.bodies), dtype=bool)
        start = -system.n_rigid  # a body's offset is its column in x = [δp; z]
        for k, body in enumerate(system.bodies):
            d = body.data
            if d.n == 0:
                continue
            a = zdd[start + body.offset:start + body.offset + d.n]
            held = np.linalg.solve(d.stiffness_matrix, d.clamped_mass_matrix @ a) \
                if np.all(np.isfinite(a)) else np.full(d.n, np.inf)
            x = d.length * np.arange(1, LOOP_SPAN_POINTS + 1) / (LOOP_SPAN_POINTS + 1)
            tip = abs(float(held @ d.tip_value))
            span = float(np.abs(d.shapes.evaluate(x) @ held).max())
            at_tip[k] = not span > tip
            value = max(tip, span) / d.length if np.all(np.isfinite(held)) else np.inf
            out[k] = value if np.isfinite(value) else np.inf
    return out, at_tip


def _start_modal_accelerations(system: ForwardSystem, t: float, loops: LoopSystem | None
                               ) -> np.ndarray:
    """z̈ (n,) at the start state under the inputs at ``t`` (s): the tree's, or with
    ``loops`` the closed start state's constrained rates (y = [p, ṗ, z, ż, …])."""
    if loops is None:
        from ..solvers.forward import split_state

        parts = split_state(system, system.initial_state()[None])
        return system.accelerations(np.array([t]), *parts)[1][0]
    from ..dynamics.forward_kernel import inputs
    from ..dynamics.loop_equilibrium import rates_function

    y = loops.y0
    rates = np.empty_like(y)
    rates_function(loops, loops.workspace(y.size))(inputs(system, np.array([t]))[0], y, rates)
    nu, n = len(system.free), system.n
    return rates[2 * nu + n:2 * nu + 2 * n]


def applied_loads(scenario: Scenario, system: ForwardSystem, t: float) -> list[str]:
    """The loads of ``scenario`` at t (s) that are not zero, each as its field and value."""
    from ..model import TorqueDrive
    from ..model.joints import drive_side

    at = np.array([t])
    out = []
    for k, joint in enumerate(scenario.chain.joints):
        drive = drive_side(joint)
        if isinstance(drive, TorqueDrive):
            value = float(drive.torque.value(at)[0])
            field, unit = ("force", "N") if k in system.slides else ("torque", "N·m")
            if value:
                out.append(f"joints[{k}].{field} = {value:.3g} {unit}")
    base = scenario.base
    if base is not None and base.cart is not None and isinstance(base.cart.drive, TorqueDrive):
        value = float(base.cart.drive.torque.value(at)[0])
        if value:
            out.append(f"base.cart.force = {value:.3g} N")
    for j, load in enumerate(base.loads if base is not None and base.kind != "fixed" else ()):
        values = [float(h.value(at)[0]) for h in (load.force_x, load.force_y, load.moment)]
        if any(values):
            out.append(f"base.loads[{j}]: force ({values[0]:.3g}, {values[1]:.3g}) N, moment "
                       f"{values[2]:.3g} N·m")
    g = scenario.settings.gravity
    if any(g):
        out.append(f"simulation.gravity = [{g[0]:.3g}, {g[1]:.3g}] m/s²")
    return out


def forward_run(scenario: Scenario, system: ForwardSystem, t: np.ndarray, solution: Solution,
                outputs: object, loop: SampledLoop | None, closure_values: dict,
                closures: dict, with_shapes: bool) -> PathRun:
    """The forward path's run (channels, shapes, metadata) from its solution and outputs
    (`solvers.forward.forward_solution`)."""
    settings = scenario.settings
    nu = len(system.free)
    p, pd, pdd = system.rigid_state(t, solution.q[:, :nu], solution.q_dot[:, :nu],
                                    solution.q_ddot[:, :nu])
    check_travel(scenario.base, t, p[:, 0])
    check_slider_travel(system.chain.joints, t, p, system.n_base)
    z, zd, zdd = solution.q[:, nu:], solution.q_dot[:, nu:], solution.q_ddot[:, nu:]
    view = SolvedMotion(system, outputs.frames)
    axial = axial_load_parameter(scenario.chain.links, system.modal, scenario.base,
                                 view.frames.theta, view.frames.omega, view.frames.alpha,
                                 view.frames.origin_accel)
    try:
        validity = check_tip_deflection(
            scenario.chain.links, t, tip_deflections(view, z), system.geometric_stiffening,
            axial, estimate=False, shares=inertia_shares(system, p, pd, pdd))
    except SimulationError as exc:
        if loop is None:
            raise
        raise SimulationError(f"closed loop unstable: {exc}") from None  # the tips ran away
    if scenario.closures and system.geometric_stiffening:
        held = loop_held_metadata(scenario, view, z, closure_values, axial)
        if "validity_warning" in held and "validity_warning" in validity:
            held["validity_warning"] = (f"{validity['validity_warning']}; "
                                        f"{held['validity_warning']}")
        validity.update(held)
    drift = slider_drift_metadata(system, t, p, z, zd, zdd)
    if "validity_warning" in drift and "validity_warning" in validity:
        drift["validity_warning"] = f"{validity['validity_warning']}; {drift['validity_warning']}"
    validity.update(drift)
    elastic = Solution(t, z, zd, zdd, solution.method)
    values = sensor_values(view, view.frames, elastic, scenario.sensors)
    values.update(pose_and_joint_values(system, t, p, pd, solution.extra, outputs.torques,
                                        outputs.momenta))
    if system.base.cart is not None:  # a driven cart's force is its drive's law
        values[cart_name("force")] = (
            system.cart_force(t, p, pd, pdd, z, zd, zdd) if system.base.cart.prescribed
            else drive_force(system, t, p, pd, np.zeros((t.size, 0)) if solution.extra is None
                             else solution.extra))
    values.update(tip_values(view, view.frames, z))
    if scenario.closures:
        values.update(closure_values)
    if loop is None:
        volts = system.voltages(t)  # open loop: the commanded voltages, clipped
        values.update({voltage_name(a.name): volts[:, j]
                       for j, a in enumerate(system.actuators)})
    else:
        values.update(loop_values(scenario, loop, t))
    shapes = LazyShapes(lambda: shape_values(view, view.frames, z)) if with_shapes else ()
    return PathRun(solution, values, shapes=shapes, metadata={
        "path": "forward", "geometric_stiffening": settings.geometric_stiffening,
        "elastic_coordinates": system.n, "rigid_coordinates": system.n_rigid,
        **({"controllers": len(scenario.controllers)} if loop else {}), **closures,
        **validity})


def loop_held_metadata(scenario: Scenario, view: SolvedMotion, z: np.ndarray,
                       closure_values: dict[str, np.ndarray], axial: np.ndarray) -> dict:
    """The validity metadata of the links whose far end a closed loop holds
    (`model.basis.held_by_loop`), whose tip deflection is zero: each one's peak span
    deflection per length (at LOOP_SPAN_POINTS interior points), its axial load parameter
    (``axial``, the tree's `axial_load_parameter`, plus the closures' force along its chord
    times ∫φ₁'² over the first mode's stiffness) and the warning of
    `accuracy.loop_validity_warning`."""
    chain = scenario.chain
    held = [k for k, link in enumerate(chain.links) if not link.rigid
            and held_by_loop(chain, k, scenario.closures) and view.modal[k].n]
    if not held:
        return {}
    span = np.zeros(len(held))
    load = np.zeros(len(held))
    inboard = hangs_on_elastic(chain.links, scenario.base)
    on_elastic = np.zeros(len(held), dtype=bool)
    theta = view.frames.theta
    for i, k in enumerate(held):
        d, link = view.modal[k], chain.links[k]
        x = link.length * np.arange(1, LOOP_SPAN_POINTS + 1) / (LOOP_SPAN_POINTS + 1)
        w = z[:, view.bodies[k].slice] @ d.shapes.evaluate(x).T  # (nt, points), m
        span[i] = float(np.abs(w).max()) / link.length if w.size else 0.0
        along = np.zeros(z.shape[0])
        for c in scenario.closures:
            if not ((c.link == k and c.x >= link.length * (1 - 1e-12))
                    or (c.to_link == k and c.x_to >= link.length * (1 - 1e-12))):
                continue
            other = c.to_link if c.link == k else c.link
            on_elastic[i] |= other is not None and not chain.links[other].rigid
            if c.kind == "revolute":
                fx = closure_values[closure_name(c.name, "force_x")]
                fy = closure_values[closure_name(c.name, "force_y")]
            else:  # a slider's force is along its line's normal
                normal = closure_values[closure_name(c.name, "normal_force")]
                fx, fy = -np.sin(c.angle) * normal, np.cos(c.angle) * normal
            along += fx * np.cos(theta[:, k]) + fy * np.sin(theta[:, k])
        on_elastic[i] |= bool(inboard[k])
        load[i] = axial[k] + float(np.abs(along).max(initial=0.0)) \
            * d.foreshortening_tip[0, 0] / d.stiffness_matrix[0, 0]
    measure = loop_held_measure(span, load)
    i = int(np.argmax(measure / loop_limits(on_elastic)))
    out = {"loop_validity_link": chain.links[held[i]].name,
           "loop_span_deflection_per_length": float(span[i]),
           "loop_axial_load_parameter": float(load[i]),
           "loop_validity_measure": float(measure[i]),
           "loop_validity_limit": float(loop_limits(on_elastic)[i])}
    warning = loop_validity_warning(chain.links, held, span, load, on_elastic)
    if warning:
        out["validity_warning"] = warning
    return out


def inertia_shares(system: ForwardSystem, p: np.ndarray, pd: np.ndarray, pdd: np.ndarray
                   ) -> np.ndarray:
    """`ForwardSystem.inertia_shares` at the run's first, middle and last output."""
    rows = np.unique([0, p.shape[0] // 2, p.shape[0] - 1]) if p.shape[0] else np.zeros(0, int)
    return system.inertia_shares(p[rows], pd[rows], pdd[rows])


def sampled_loop(scenario: Scenario, system, t: np.ndarray, model: str = "first-order"
                 ) -> SampledLoop:
    """The scenario's controllers on their sample grid, reading the sensors as rows over
    the elastic coordinates of ``system`` (a forward system: .modal, .n, .voltages)."""
    if system.n == 0:
        raise SimulationError("controllers need an elastic link: every link is rigid")
    cuts = np.concatenate([[0], np.cumsum([d.n for d in system.modal])])
    coords = [slice(int(a), int(b)) for a, b in itertools.pairwise(cuts)]
    grid = sample_grid(scenario.controllers, float(t[-1]))
    return SampledLoop(scenario.controllers, scenario.actuators,
                       sensor_rows(scenario, system.modal, coords, system.n, model),
                       grid, system.voltages(grid))


def loop_values(scenario: Scenario, loop: SampledLoop, t: np.ndarray) -> dict[str, np.ndarray]:
    """The held voltages, commands and controller states at the outputs t (s)."""
    held = np.searchsorted(loop.grid, t + 1e-9 * max(1.0, t[-1]), side="right") - 1
    run = SimpleNamespace(work=loop.work, python_commands=loop.commands)
    return control_values(scenario, run, np.clip(held, 0, loop.grid.size - 1),
                          loop.python_index)
