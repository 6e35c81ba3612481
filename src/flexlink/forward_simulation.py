"""Forward dynamics runs (free or pinned base, driven joints): integrate, then read channels.

The state is [p_free, ṗ_free, z, ż, servo integrals]; scipy's solve_ivp integrates the coupled
equations of `dynamics.forward.ForwardSystem` (nonlinear in the rigid coordinates, first order
in z). Sensors reuse `sensors.evaluate` on the solved rigid motion, which plays the role of a
prescribed one: the expansion is about the actual rigid state, so ρ and θ1 depend on z only.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.integrate import solve_ivp

from ._version import package_version
from .drives import Base, PositionServo, TorqueDrive, VelocityServo, command_volts
from .dynamics.forward import ForwardSystem, momentum
from .dynamics.kinematics import FrameMotion
from .model import Scenario
from .results import Results
from .sensors.evaluate import Trajectory, _tip_position, sensor_channels
from .solvers import SimulationError
from .solvers.threads import single_threaded

DEFAULT_METHOD = "DOP853"  # "lawson", "magnus" (prescribed-joint integrators) do not apply here
MAX_STEP_OUTPUTS = 10  # longest step, in output intervals (simulation.dt_out)
# A run whose right-hand side is called STALL_CALLS times while time advances by less than
# STALL_FRACTION of the span is stopped: solve_ivp would otherwise grind on at steps of
# 1e-12 s towards a blow-up (e.g. the paper's model, without stiffening, on a fast swing).
STALL_CALLS = 5000
STALL_FRACTION = 1e-6


def needs_forward_dynamics(scenario: Scenario) -> bool:
    """True if the base moves, branches start on it, or a joint is driven."""
    from .drives import is_driven

    return scenario.base is not None or any(is_driven(j) for j in scenario.chain.joints)


def initial_state(system: ForwardSystem) -> np.ndarray:
    """[p_free, ṗ_free, z, ż, integrals] at t = 0: base and driven joints as given (servos
    start on their reference), elastic coordinates at rest."""
    b = system.base
    p0, v0 = {"free": ([*b.position, b.attitude], [*b.velocity, b.rate]),
              "pinned": ([b.attitude], [b.rate]), "fixed": ([], [])}[b.kind]
    p, v = list(p0), list(v0)
    for k in system.driven:
        joint = system.chain.joints[k]
        if isinstance(joint, TorqueDrive):
            p.append(joint.initial_angle)
            v.append(joint.initial_rate)
        else:
            angle, rate, _ = joint.reference.evaluate(np.array([0.0]))
            p.append(float(np.ravel(angle)[0]))
            v.append(float(np.ravel(rate)[0]))
    n = system.n
    return np.concatenate([p, v, np.zeros(2 * n + len(system.servos))])


def integrate(system: ForwardSystem, t_out: np.ndarray, rtol: float, atol: float,
              method: str = DEFAULT_METHOD, y0: np.ndarray | None = None) -> np.ndarray:
    """The state at t_out, (nt, 2 nu + 2 n + n_servos).

    The step is limited to MAX_STEP_OUTPUTS output intervals: while nothing moves the error
    estimate is zero and the step would otherwise grow past the start of an input."""
    nu, n = len(system.free), system.n
    y0 = initial_state(system) if y0 is None else y0
    span = float(t_out[-1] - t_out[0])
    watch = {"calls": 0, "t": float(t_out[0])}

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        watch["calls"] += 1
        if watch["calls"] % STALL_CALLS == 0:  # the step has collapsed: the model blew up
            if t - watch["t"] < STALL_FRACTION * span:
                raise SimulationError(_stall_message(system, t))
            watch["t"] = t
        parts = split_state(system, y[None])
        pdd, zdd, rates = system.accelerations(np.array([t]), *parts)
        return np.concatenate([y[nu:2 * nu], pdd[0], y[2 * nu + n:2 * nu + 2 * n], zdd[0],
                               rates[0]])

    with single_threaded():  # tiny matrices: threads only cost
        max_step = MAX_STEP_OUTPUTS * float(np.min(np.diff(t_out))) if t_out.size > 1 else np.inf
        sol = solve_ivp(rhs, (float(t_out[0]), float(t_out[-1])), y0, method=method,
                        t_eval=t_out, rtol=rtol, atol=atol, max_step=max_step)
    if sol.status != 0:
        raise SimulationError(f"time integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
    if not np.all(np.isfinite(sol.y)):
        raise SimulationError("time integration produced non-finite values")
    return sol.y.T


def _stall_message(system: ForwardSystem, t: float) -> str:
    hint = ("; the paper's model (geometric_stiffening = false) is not energy-consistent and "
            "can blow up when a light link swings fast: set geometric_stiffening = true"
            if not system.geometric_stiffening else
            "; the first-order model may be outside its range (large deflections), or a servo "
            "loop is very stiff: try method = \"Radau\"")
    return f"the forward run stalled at t = {t:.6g} s (the time step collapsed){hint}"


def split_state(system: ForwardSystem, y: np.ndarray) -> tuple[np.ndarray, ...]:
    """p_free, ṗ_free, z, ż, integrals from states (nt, ·)."""
    nu, n = len(system.free), system.n
    cuts = np.cumsum([nu, nu, n, n])
    return tuple(np.split(y, cuts, axis=1))


def simulate_forward(scenario: Scenario) -> Results:
    """Run a scenario with a moving base or driven joints."""
    from .simulation import output_times

    settings = scenario.settings
    base = scenario.base if scenario.base is not None else Base()
    system = ForwardSystem(scenario.chain, base, settings.geometric_stiffening)
    t = output_times(settings.t_end, settings.dt_out)
    method = DEFAULT_METHOD if settings.method in ("magnus", "lawson") else settings.method
    started = time.perf_counter()
    y = integrate(system, t, settings.rtol, settings.atol, method)
    p_free, pd_free, z, zd, integral = split_state(system, y)
    pdd_free, zdd, _ = system.accelerations(t, p_free, pd_free, z, zd, integral)
    if not (np.all(np.isfinite(pdd_free)) and np.all(np.isfinite(zdd))):
        raise SimulationError("accelerations are not finite")
    p, pd, pdd = system.rigid_state(t, p_free, pd_free, pdd_free)
    _check_small_deflections(system, t, z)

    results = Results(time=t, metadata={
        "scenario": scenario.name, "flexlink_version": package_version(),
        "model": "forward_first_order", "geometric_stiffening": settings.geometric_stiffening,
        "method": method, "wall_time_s": time.perf_counter() - started,
        "elastic_coordinates": system.n, "rigid_coordinates": system.n_rigid,
    })
    view = SolvedMotion(system, system.frames(p, pd, pdd))
    traj = Trajectory(t, z, zd, zdd)
    for ch in sensor_channels(view, traj, scenario.sensors):  # type: ignore[arg-type]
        results.add(ch.name, ch.values, ch.unit, ch.description)
    _rigid_channels(results, system, t, p, pd, pdd, z, zd, zdd, integral)
    for k, link in enumerate(scenario.chain.links):
        tip = _tip_position(view, view.frames(t), z, k)
        results.add(f"{link.name}_tip_X", tip[:, 0], "m", f"X of the tip of {link.name}")
        results.add(f"{link.name}_tip_Y", tip[:, 1], "m", f"Y of the tip of {link.name}")
    return results


def _rigid_channels(results: Results, system: ForwardSystem, t, p, pd, pdd, z, zd, zdd,
                    integral) -> None:
    names = {"x": ("m", "m/s"), "y": ("m", "m/s"), "attitude": ("rad", "rad/s")}
    for i, name in enumerate(system.base.coordinates):
        unit, rate_unit = names[name]
        results.add(f"base_{name}", p[:, i], unit, f"base {name} (reference point, inertial)")
        results.add(f"base_{name}_rate", pd[:, i], rate_unit, f"rate of base {name}")
    torque = system.joint_torques(p, pd, pdd, z, zd, zdd)
    for k, joint in enumerate(system.chain.joints):
        i = system.joint_index(k)
        kind = {TorqueDrive: "torque-driven", VelocityServo: "velocity servo",
                PositionServo: "position servo"}.get(type(joint), "prescribed")
        results.add(f"joint{k + 1}_angle", p[:, i], "rad", f"angle of joint {k + 1} ({kind})")
        results.add(f"joint{k + 1}_rate", pd[:, i], "rad/s", f"rate of joint {k + 1}")
        results.add(f"joint{k + 1}_torque", torque[:, k], "N*m",
                    f"motor torque of joint {k + 1} (equations of motion, first order)")
        if isinstance(joint, VelocityServo | PositionServo):
            results.add(f"joint{k + 1}_reference", joint.reference.evaluate(t)[0] + 0 * t, "rad",
                        f"reference angle of joint {k + 1}'s servo")
        if isinstance(joint, VelocityServo):
            s = system.servos.index(k)
            volts = command_volts(joint, t, p[:, i], pd[:, i], integral[:, s])
            results.add(f"joint{k + 1}_command", volts, "V", f"servo command of joint {k + 1}")
    if system.base.kind != "fixed":
        lin, ang = momentum(system, p, pd, z, zd)
        results.add("momentum_x", lin[:, 0], "N*s", "linear momentum, X (first order)")
        results.add("momentum_y", lin[:, 1], "N*s", "linear momentum, Y (first order)")
        results.add("angular_momentum", ang, "N*m*s",
                    "angular momentum about the origin (first order)")


class SolvedMotion:
    """The solved rigid motion seen as a prescribed one, for `sensors.evaluate`: frames and
    maps restricted to the elastic coordinates (δp = 0)."""

    def __init__(self, system: ForwardSystem, frames: FrameMotion) -> None:
        from .dynamics.first_order import _link_body

        self.chain = system.chain
        self.modal = system.modal
        self.n = system.n
        self.bodies = [_link_body(b.data, b.offset - system.n_rigid) for b in system.bodies]
        zc = slice(system.n_rigid, system.n_x)
        self._frames = FrameMotion(frames.theta, frames.omega, frames.alpha, frames.origin,
                                   frames.origin_accel, [T[:, :, zc] for T in frames.T],
                                   [T[:, :, zc] for T in frames.T_dot],
                                   [T[:, :, zc] for T in frames.T_ddot])

    def frames(self, t: np.ndarray) -> FrameMotion:
        if t.shape[0] != self._frames.theta.shape[0]:
            raise ValueError("SolvedMotion only knows the output times of its run")
        return self._frames

    def xi_states(self, frames: FrameMotion, k: int, z: np.ndarray, zd: np.ndarray,
                  zdd: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ξ_k, ξ̇_k, ξ̈_k (nt, 3+n_k) from z, ż, z̈."""
        sl = self.bodies[k].slice
        T, Td, Tdd = frames.T[k], frames.T_dot[k], frames.T_ddot[k]

        def apply(M: np.ndarray, v: np.ndarray) -> np.ndarray:
            return np.einsum("tai,ti->ta", M, v)

        xi = np.concatenate([apply(T, z), z[:, sl]], 1)
        xi_d = np.concatenate([apply(T, zd) + apply(Td, z), zd[:, sl]], 1)
        xi_dd = np.concatenate([apply(T, zdd) + 2 * apply(Td, zd) + apply(Tdd, z), zdd[:, sl]], 1)
        return xi, xi_d, xi_dd


def _check_small_deflections(system: ForwardSystem, t: np.ndarray, z: np.ndarray) -> None:
    """Refuse a result whose tip deflection exceeds the link's length (diverged model)."""
    for body, link in zip(system.bodies, system.chain.links):
        tip = np.abs(z[:, slice(body.offset - system.n_rigid,
                                body.offset - system.n_rigid + body.data.n)]
                     @ body.data.tip_value)
        if tip.max() > link.length:
            when = t[int(np.argmax(tip > link.length))]
            raise SimulationError(
                f"the tip deflection of {link.name} exceeds its length ({link.length:g} m) at "
                f"t = {when:.4g} s: the first-order model is not valid here")
