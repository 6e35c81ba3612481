"""The forward dynamics of a `ForwardSystem` as data for the compiled kernels
(`_forward_numba.py`): constant arrays (`ForwardData`) and the input rows u(t).

The kernels evaluate the same equations as the numpy `ForwardSystem` (the reference,
docs/derivation.md §10); `tests/unit/test_forward_kernel.py` compares them to round-off.
Inputs — prescribed joint motions, servo references, torque histories, base loads — are
Python objects: they are evaluated here, vectorised over every time the integrator will need,
and handed to the compiled loop as rows (`inputs`).
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from ..model import (
    ElasticJoint,
    JointMotion,
    PositionServo,
    TorqueDrive,
    VelocityServo,
)
from ..model.joints import drive_side
from .forward import ForwardSystem
from .histories import input_breakpoints

if TYPE_CHECKING:
    from ..modes import ModalData

ForwardData = namedtuple("ForwardData", [
    "n_base", "base_kind", "n_rigid", "n_x", "stiffening", "base_mass", "base_inertia",
    "free", "attached", "point", "length", "mass", "s1", "J", "Jt", "n_modes", "offset",
    "Mtot", "M0", "G0", "phi_bar", "phi_tilde", "tip_value", "tip_slope", "stiffness",
    "damping", "fore_mass", "fore_moment", "fore_tip", "joint_kind", "motor_inertia",
    "servo_index", "P", "I", "D", "saturation", "rate_per_volt", "loop_gain", "torque_limit",
    "bandwidth", "rate_limit", "load_point", "load_body", "actuator_B", "gravity", "rot_slope",
    "lateral", "sy", "lat_slope", "lat_tilde", "lat_fore", "lat_fore_moment",
    "motor_row", "motor_kind", "spring_k", "spring_c", "gear", "rotor_inertia", "rail",
    "attitude", "rail_origin", "slide", "slide_axis", "slide_angle"])
ForwardData.__doc__ = ("Constant arrays of a ForwardSystem for the kernels: SI units, link "
                       "arrays padded to the most modes, offsets into x = [δp; z]; "
                       "actuator_B (n, n_act) the actuators' forces on z per volt; gravity "
                       "(2,) the uniform field [gx, gy], m/s², global axes; Jt, rot_slope the "
                       "bodies' rotary inertia Σ J_b (kg·m²) and Σ J_b Φ'(x_b) of each link; "
                       "lateral, sy, lat_*: the modal data's lateral_* (bodies' centres "
                       "across the link); the elastic joints' arrays (N each): "
                       "dynamics/_elastic_numba.py; rail (2,) a cart's rail direction, "
                       "rail_origin (2,) its position at zero travel (m, global axes) and "
                       "attitude its constant attitude (rad); the drive arrays (joint_kind … "
                       "rate_limit) have N + 1 entries, the last the cart's drive; slide "
                       "(N,) whether joint k is a slider (its coordinate the travel, m), "
                       "slide_axis (N, 2) its line's direction in the parent's tip axes and "
                       "slide_angle (N,) the carried link's constant angle (rad): "
                       "dynamics/prismatic.py; length, tip_value, tip_slope, fore_tip: x (m), "
                       "Φ, Φ' and S at the section of link k that link k + 1 hangs on (its "
                       "tip, or a slider's line point: `ForwardSystem.hang`).")


def pack(system: ForwardSystem) -> ForwardData:
    """The constant data of ``system`` (see ForwardData)."""
    from ._forward_numba import (
        CART,
        ELASTIC,
        FIXED,
        FREE,
        PINNED,
        POSITION_SERVO,
        PRESCRIBED,
        TORQUE,
        VELOCITY_SERVO,
    )

    chain, base = system.chain, system.base
    N = len(chain.links)
    nm = max(d.n for d in system.modal)
    m = 3 + nm

    def pad(values: list[np.ndarray], shape: tuple[int, ...]) -> np.ndarray:
        return _padded(values, N, shape)

    bodies, modal = system.bodies, system.modal
    kind = np.zeros(N + 1, dtype=np.int64)
    servo_index = np.full(N + 1, -1, dtype=np.int64)
    params = {name: np.zeros(N + 1) for name in ("P", "I", "D", "saturation", "rate_per_volt",
                                                 "loop_gain", "bandwidth", "rate_limit")}
    torque_limit = np.full(N + 1, np.inf)
    motor = np.zeros(N + 1)
    motor_row, motor_kind = np.full(N, -1, dtype=np.int64), np.zeros(N, dtype=np.int64)
    spring = {name: np.zeros(N) for name in ("spring_k", "spring_c", "rotor_inertia")}
    gear = np.ones(N)
    for k, elastic in enumerate(chain.joints):
        if isinstance(elastic, ElasticJoint):
            motor_row[k] = system.motor_index(k)
            spring["spring_k"][k], spring["spring_c"][k] = elastic.stiffness, elastic.damping
            spring["rotor_inertia"][k], gear[k] = elastic.rotor_inertia, elastic.gear_ratio
    cart = base.cart
    # An elastic joint's drive is its motor's; the last drive is the cart's.
    drives = [*map(drive_side, chain.joints), cart.drive if cart is not None else None]
    for k, joint in enumerate(drives):
        if isinstance(joint, TorqueDrive):
            kind[k] = TORQUE
        elif isinstance(joint, VelocityServo):
            kind[k] = VELOCITY_SERVO
            for name in ("P", "I", "D", "saturation", "rate_per_volt"):
                params[name][k] = getattr(joint, name)
        elif isinstance(joint, PositionServo):
            kind[k] = POSITION_SERVO
            params["bandwidth"][k], params["rate_limit"][k] = joint.bandwidth, joint.rate_limit
        else:
            kind[k] = PRESCRIBED
        if isinstance(joint, VelocityServo | PositionServo):
            servo_index[k] = system.servos.index(k) if k in system.servos else -1
            params["loop_gain"][k] = joint.loop_gain
            torque_limit[k] = joint.torque_limit
        if k < N and motor_row[k] >= 0:  # the drive's kind is the motor's
            motor_kind[k], kind[k] = kind[k], ELASTIC
        elif kind[k] != PRESCRIBED:
            motor[k] = joint.motor_inertia  # type: ignore[union-attr]
    loads = base.loads if base.kind != "fixed" else ()
    return ForwardData(
        n_base=system.n_base,
        base_kind={"fixed": FIXED, "pinned": PINNED, "free": FREE, "cart": CART}[base.kind],
        n_rigid=system.n_rigid, n_x=system.n_x, stiffening=bool(system.geometric_stiffening),
        base_mass=float(base.mass), base_inertia=float(base.inertia),
        free=np.asarray(system.free, dtype=np.int64),
        attached=np.array([a is not None for a in system.attach]),
        point=np.array([a if a is not None else (0.0, 0.0) for a in system.attach], dtype=float),
        length=np.array([h.x for h in system.hang]), mass=np.array([d.mass for d in modal]),
        s1=np.array([d.first_moment for d in modal]), J=np.array([d.second_moment for d in modal]),
        Jt=np.array([d.rotary_inertia for d in modal]),
        n_modes=np.array([d.n for d in modal], dtype=np.int64),
        offset=np.array([b.offset for b in bodies], dtype=np.int64),
        Mtot=pad([b.M0 + b.M_rot for b in bodies], (m, m)), M0=pad([b.M0 for b in bodies], (m, m)),
        G0=pad([b.G0 for b in bodies], (m, m)),
        phi_bar=pad([d.phi_bar for d in modal], (nm,)),
        phi_tilde=pad([d.phi_tilde for d in modal], (nm,)),
        tip_value=pad([h.value for h in system.hang], (nm,)),
        tip_slope=pad([h.slope for h in system.hang], (nm,)),
        stiffness=pad([d.stiffness_matrix for d in modal], (nm, nm)),
        damping=pad([d.damping_matrix for d in modal], (nm, nm)),
        fore_mass=pad([d.foreshortening_mass for d in modal], (nm, nm)),
        fore_moment=pad([d.foreshortening_moment for d in modal], (nm, nm)),
        fore_tip=pad([h.shortening for h in system.hang], (nm, nm)),
        joint_kind=kind, motor_inertia=motor, servo_index=servo_index, torque_limit=torque_limit,
        **params,
        load_point=np.array([ld.point for ld in loads], dtype=float).reshape(len(loads), 2),
        load_body=np.array([ld.frame == "body" for ld in loads], dtype=bool),
        actuator_B=np.ascontiguousarray(system.actuator_B, dtype=float),
        gravity=np.array(system.gravity, dtype=float),
        rot_slope=pad([d.rotary_slope for d in modal], (nm,)),
        lateral=np.array([d.lateral for d in modal], dtype=bool),
        sy=np.array([d.lateral_moment for d in modal]),
        lat_slope=pad([d.lateral_slope for d in modal], (nm,)),
        lat_tilde=pad([d.lateral_tilde for d in modal], (nm,)),
        lat_fore=pad([d.lateral_shortening for d in modal], (nm, nm)),
        lat_fore_moment=pad([d.lateral_shortening_moment for d in modal], (nm, nm)),
        motor_row=motor_row, motor_kind=motor_kind, gear=gear, **spring,
        rail=np.array(cart.direction if cart is not None else (0.0, 0.0), dtype=float),
        attitude=float(base.attitude),
        rail_origin=np.array(base.position if cart is not None else (0.0, 0.0), dtype=float),
        **slide_arrays(chain.joints))


def _padded(values: Sequence[np.ndarray], N: int, shape: tuple[int, ...]) -> np.ndarray:
    """(N, *shape) zeros with ``values[k]`` in the leading corner of row k (links' arrays of
    fewer modes than the most)."""
    out = np.zeros((N, *shape))
    for k, v in enumerate(values):
        v = np.asarray(v)
        # the common shapes spelt out: this runs ~17 times per link and pack
        if v.ndim == 1:
            out[k, :v.shape[0]] = v
        elif v.ndim == 2:
            out[k, :v.shape[0], :v.shape[1]] = v
        else:
            out[(k, *map(slice, v.shape))] = v
    return out


def with_stiffness(data: ForwardData, modal: Sequence[ModalData]) -> ForwardData:
    """``data`` with the stiffness and damping matrices of ``modal``, the modal data of
    links that differ from those ``data`` was packed for in EI and damping alone (padded as
    `pack` pads them)."""
    N, nm = data.stiffness.shape[:2]
    return data._replace(
        stiffness=_padded([d.stiffness_matrix for d in modal], N, (nm, nm)),
        damping=_padded([d.damping_matrix for d in modal], N, (nm, nm)))


def slide_arrays(joints: tuple | list) -> dict[str, np.ndarray]:
    """ForwardData's slider arrays (slide, slide_axis, slide_angle) of the joints."""
    from ..model import PrismaticJoint

    N = len(joints)
    out = {"slide": np.zeros(N, dtype=bool), "slide_axis": np.zeros((N, 2)),
           "slide_angle": np.zeros(N)}
    for k, joint in enumerate(joints):
        if isinstance(joint, PrismaticJoint):
            out["slide"][k] = True
            out["slide_axis"][k] = joint.direction
            out["slide_angle"][k] = joint.link_angle
    return out


def inputs(system: ForwardSystem, t: np.ndarray) -> np.ndarray:
    """Input rows u(t) (nt, 4N + 3·loads + actuators + 4): per joint its prescribed motion or
    servo reference (angle rad, rate rad/s, acceleration rad/s², N columns each), its drive
    torque (N·m, torque drives), then per base load F_x, F_y (N) and the moment (N·m), then per
    actuator its open-loop voltage (V, clipped; a closed loop overwrites these columns with
    its held voltages: `voltage_columns`), then a cart's prescribed or reference travel,
    speed, acceleration (m, m/s, m/s²) and drive force (N) (zero without a cart)."""
    t = np.asarray(t, dtype=float)
    chain, base = system.chain, system.base
    N = len(chain.links)
    loads = base.loads if base.kind != "fixed" else ()
    na = len(system.actuators)
    u = np.zeros((t.size, 4 * N + 3 * len(loads) + na + 4))
    for k, joint in enumerate(map(drive_side, chain.joints)):  # an elastic joint's: its motor's
        _drive_inputs(joint, t, u, [i * N + k for i in range(4)])
    if base.cart is not None:
        _drive_inputs(base.cart.drive, t, u, [u.shape[1] - 4 + i for i in range(4)])
    nl = len(loads)
    for j, load in enumerate(loads):
        u[:, 4 * N + j] = load.force_x.value(t)
        u[:, 4 * N + nl + j] = load.force_y.value(t)
        u[:, 4 * N + 2 * nl + j] = load.moment.value(t)
    if na:
        u[:, voltage_columns(system)] = system.voltages(t)
    return u


def _drive_inputs(joint: object, t: np.ndarray, u: np.ndarray, columns: list[int]) -> None:
    """Fill a drive's input columns [motion or reference, its rate, its acceleration, torque or
    force] of the rows u at times t."""
    if isinstance(joint, TorqueDrive):
        u[:, columns[3]] = joint.torque.value(t)
        return
    motion: JointMotion = (joint.reference if isinstance(joint, VelocityServo | PositionServo)
                           else joint)  # type: ignore[assignment]
    for i, v in enumerate(motion.evaluate(t)):
        u[:, columns[i]] = np.broadcast_to(v, t.shape)


def voltage_columns(system: ForwardSystem) -> slice:
    """The actuator voltages' columns of the input rows."""
    loads = system.base.loads if system.base.kind != "fixed" else ()
    start = 4 * len(system.chain.links) + 3 * len(loads)
    return slice(start, start + len(system.actuators))


def applied_columns(n_links: int, n_loads: int, n_actuators: int) -> np.ndarray:
    """The columns of the input rows (`inputs`' layout) that only the applied forces read
    (`_forward_numba.applied`): the drives' torques, the base loads, the actuators'
    voltages and a cart's drive force; not a motion or reference, which the frames or the
    drives' errors read."""
    N, rest = n_links, 3 * n_loads + n_actuators
    return np.r_[3 * N:4 * N, 4 * N:4 * N + rest, 4 * N + rest + 3]


def breakpoints(system: ForwardSystem) -> np.ndarray:
    """Sorted times (s) where an input (motion, reference, torque, base load, voltage) is not
    smooth: the compiled integrator ends steps there."""
    loads = system.base.loads if system.base.kind != "fixed" else ()
    cart = () if system.base.cart is None else (system.base.cart.drive,)
    return input_breakpoints((*system.chain.joints, *cart), system.actuators,
                             (h for load in loads for h in (load.force_x, load.force_y,
                                                            load.moment)))


def accelerations(system: ForwardSystem, t: np.ndarray, p_free: np.ndarray, pd_free: np.ndarray,
                  z: np.ndarray, zd: np.ndarray, integral: np.ndarray,
                  data: ForwardData | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ForwardSystem.accelerations through the compiled kernel: p̈_free, z̈, servo integral
    rates at times t (same shapes)."""
    from ._forward_numba import rates, workspace

    data = pack(system) if data is None else data
    work = workspace(data, len(system.servos))
    u = inputs(system, t)
    nu, n = len(system.free), system.n
    y = np.hstack([p_free, pd_free, z, zd, integral])
    dy = np.empty_like(y)
    for i in range(t.size):
        rates(data, work, u[i], y[i], dy[i])
    return dy[:, nu:2 * nu], dy[:, 2 * nu + n:2 * nu + 2 * n], dy[:, 2 * nu + 2 * n:]


def joint_torques(system: ForwardSystem, p: np.ndarray, pd: np.ndarray, pdd: np.ndarray,
                  z: np.ndarray, zd: np.ndarray, zdd: np.ndarray,
                  data: ForwardData | None = None) -> np.ndarray:
    """ForwardSystem.joint_torques through the compiled kernel: (nt, N) in N·m from the
    rigid states p, ṗ, p̈ (nt, n_rigid) and z, ż, z̈ (nt, n)."""
    from ._forward_numba import joint_torques as kernel
    from ._forward_numba import workspace

    data = pack(system) if data is None else data
    out = np.empty((p.shape[0], len(system.chain.links)))
    c = np.ascontiguousarray
    kernel(data, workspace(data, len(system.servos)), c(p, dtype=float), c(pd, dtype=float),
           c(pdd, dtype=float), c(z, dtype=float), c(zd, dtype=float), c(zdd, dtype=float), out)
    return out
