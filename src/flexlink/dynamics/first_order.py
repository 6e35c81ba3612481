"""First-order equations of a chain with prescribed joints:

    M(t) z̈ + C(t) ż + K(t) z = f(t),   z = [q_1, …, q_N]

obtained by linearising the generalized inertia forces −∫(∂r/∂z)·r̈ dm about the prescribed
rigid motion (docs/derivation.md). Per link, in its zero-order frame, the body matrices are the
paper's eq. (14a) M_0 and a gyroscopic G_0; the kinematical synthesis T̂_k = [T_k; E_k] maps them
onto z. Second-order position terms acting on the zero-order inertia loads give the rotation
coupling and, with ``geometric_stiffening``, the foreshortening (centrifugal) stiffness.
All evaluations are vectorised over a leading time axis.
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from ..model import Base, Chain, Link, PiezoActuator, PrismaticJoint, TorqueDrive, is_driven
from ..model.basis import carries_links, chosen_mode_shapes, free_hub
from ..model.joints import initial_angle
from ..model.prismatic import guide
from ..modes import (
    ModalData,
    highest_frequency,
    hub_loaded_modes,
    modal_data,
    modal_data_for_stiffness,
    tip_loaded_modes,
)
from ..modes.section_loaded import section_loaded_modes
from .actuators import actuator_matrix
from .histories import input_breakpoints
from .kinematics import FrameMotion, JointHistory, frame_motion, joint_history, rotation

_Solution = TypeVar("_Solution")  # a solvers.Solution (solvers import dynamics, not back)


@dataclass(frozen=True)
class LinkBody:
    """Constant body matrices of one link in the coordinates ξ = [ρx, ρy, θ1, q]."""

    data: ModalData
    offset: int  # index of q_k[0] in z
    M0: np.ndarray  # translational mass matrix (paper eq. 14a), (3+n, 3+n)
    M_rot: np.ndarray  # the bodies' rotary inertias Σ J_b c_b c_bᵀ, c_b = [0, 0, 1, Φ'(x_b)]
    G0: np.ndarray  # ∫ P̂ᵀ S P̂ dm, skew, (3+n, 3+n)

    @property
    def slice(self) -> slice:
        return slice(self.offset, self.offset + self.data.n)


def link_body(data: ModalData, offset: int) -> LinkBody:
    n = data.n
    m, s1, J = data.mass, data.first_moment, data.second_moment
    M0 = np.zeros((3 + n, 3 + n))
    M0[:3, :3] = [[m, 0.0, 0.0], [0.0, m, s1], [0.0, s1, J]]
    M0[1, 3:] = M0[3:, 1] = data.phi_bar
    M0[2, 3:] = M0[3:, 2] = data.phi_tilde
    M0[3:, 3:] = data.mass_matrix
    # a body's centre across the link (c_y): P̂_x = [1, 0, −c_y, −c_y Φ'(x_b)]
    M0[0, 2] = M0[2, 0] = -data.lateral_moment
    M0[0, 3:] = M0[3:, 0] = -data.lateral_slope
    # Σ J_b c_b c_bᵀ of the bodies' rotary inertias, c_b = [0, 0, 1, Φ'(x_b)]
    M_rot = np.zeros((3 + n, 3 + n))
    M_rot[2, 2] = data.rotary_inertia
    M_rot[2, 3:] = M_rot[3:, 2] = data.rotary_slope
    M_rot[3:, 3:] = data.rotary_matrix
    # ∫ p_y dm with p_y = [0, 1, x, Φ(x)]: the only non-zero column of N in G0 = N − Nᵀ.
    py = np.concatenate([[0.0, m, s1], data.phi_bar])
    N = np.zeros((3 + n, 3 + n))
    N[:, 0] = py
    return LinkBody(data, offset, M0, M_rot, N - N.T + data.lateral_gyroscopic)


def outboard_body(chain: Chain, k: int, base: Base | None = None) -> tuple[float, float]:
    """(mass kg, rotary inertia kg·m² about link k's tip) of link k's tip bodies plus the links
    its tip carries, rigid and straight in their t = 0 joint angles (a joint with a drive:
    its initial angle). The carried links are those after k up to the next that starts a
    branch on the base. A torque-driven joint turns freely: the links beyond it add their
    mass and the motor's inertia but not their own rotary inertia. The offset of their centre
    of mass is not part of the body: this only chooses a basis, the dynamics keep every
    coupling."""
    link = chain.links[k]
    mass, inertia, _ = link.tip_body()
    position, angle, turning = np.zeros(2), 0.0, True
    for j in range(k + 1, len(chain.links)):
        if base is not None and base.attachment(j) is not None:
            break
        outer, joint = chain.links[j], chain.joints[j]
        if isinstance(joint, PrismaticJoint):  # its block starts s0 along its line
            line = angle + joint.axis_angle
            position = position + guide(joint).initial_travel() * np.array(
                [np.cos(line), np.sin(line)])
        angle += initial_angle(joint)
        if is_driven(joint):
            inertia += joint.motor_inertia if turning else 0.0
            turning = turning and not isinstance(joint, TorqueDrive)
        axis = np.array([np.cos(angle), np.sin(angle)])
        m, L = outer.mass_per_length * outer.length, outer.length
        mass += m + sum(b.mass for b in outer.all_bodies())
        if turning:
            d = float(position @ axis)  # rigid link from `position` along `axis`, ∫|r|² dm:
            inertia += m * (position @ position + d * L + L**2 / 3)
            for b in outer.all_bodies():  # centres taken on the axis: a basis, not dynamics
                centre = position + (b.at + b.offset[0]) * axis
                inertia += b.mass * float(centre @ centre) + b.inertia
        position = position + L * axis
    return mass, inertia


def carried_section(chain: Chain, k: int) -> float | None:
    """The section x_a (m) inside link k (0 ≤ x_a < L) where the next link hangs: a slider's
    line through it (`PrismaticJoint.at`); None when the next link hangs on the tip."""
    joint = chain.joints[k + 1] if k + 1 < len(chain.joints) else None
    at = joint.at if isinstance(joint, PrismaticJoint) else None
    return None if at is None or at >= chain.links[k].length else float(at)


def _section_loaded_shapes(chain: Chain, k: int, base: Base | None,
                           hub: tuple[float, float] | None) -> tuple:
    """The `section_loaded_modes` arguments of link k, whose next link hangs inside its span
    (`carried_section`): what it carries (`outboard_body` less its own tip body) at that
    section, its own tip body at its tip, clamped or on its free ``hub``. Carried at the
    joint itself (x_a = 0), the body only adds to the hub's inertia."""
    link, at = chain.links[k], carried_section(chain, k)
    own_mass, own_inertia, _ = link.tip_body()
    mass, inertia = outboard_body(chain, k, base)
    mass, inertia = mass - own_mass, inertia - own_inertia
    if at > 0.0:
        return ("section", link.length, link.modes, link.mass_per_length, at, mass, inertia,
                own_mass, own_inertia) + (() if hub is None else tuple(hub))
    own = (link.length, link.modes, link.mass_per_length, link.EI, own_mass, own_inertia)
    if hub is None:
        return own
    return own + (hub[0] + inertia + mass * hub[1] ** 2, hub[1])


def _outboard_loaded_shapes(chain: Chain, k: int, base: Base | None) -> tuple:
    """The `tip_loaded_modes` arguments of link k's cantilever modes carrying its tip body
    plus the links its tip carries (`outboard_body`); those of `section_loaded_modes` when
    the next link hangs inside its span (`carried_section`)."""
    link = chain.links[k]
    if carried_section(chain, k) is not None:
        return _section_loaded_shapes(chain, k, base, None)
    mass, inertia = outboard_body(chain, k, base)
    return (link.length, link.modes, link.mass_per_length, link.EI, mass, inertia)


def _hub_loaded_shapes(chain: Chain, k: int, base: Base | None) -> tuple:
    """The arguments of link k's modes on its free hub (`model.basis.free_hub`; those of
    `hub_loaded_modes`) with its tip body, or with what its tip carries (`outboard_body`;
    inside its span: `section_loaded_modes`). A link clamped to a prescribed joint is the
    limit of an infinite hub inertia: its tip- or outboard-loaded modes (the arguments of
    `tip_loaded_modes`, two fewer)."""
    link, hub = chain.links[k], free_hub(chain, k, base)
    if carries_links(chain, k, base) and carried_section(chain, k) is not None:
        return _section_loaded_shapes(chain, k, base, hub)
    mass, inertia = (outboard_body(chain, k, base) if carries_links(chain, k, base)
                     else link.tip_body()[:2])
    own = (link.length, link.modes, link.mass_per_length, link.EI, mass, inertia)
    return own if hub is None else own + tuple(hub)


@functools.lru_cache(maxsize=64)
def _loaded_modal_data(link: Link, shapes: tuple) -> ModalData:
    """`modal_data` of a link on the modes of `tip_loaded_modes(*shapes)` or, with a hub's
    inertia and radius after them, `hub_loaded_modes(*shapes)`: cached per process, since a
    run's sensitivities and a sweep's cases assemble the same link on the same loads again.
    A tuple that starts with "section": `section_loaded_modes(*shapes[1:])`."""
    if shapes[0] == "section":
        modes = section_loaded_modes(*shapes[1:])
    else:
        modes = hub_loaded_modes(*shapes) if len(shapes) == 8 else tip_loaded_modes(*shapes)
    return modal_data(link, shapes=modes)


@functools.lru_cache(maxsize=64)
def _link_modal_data(link: Link) -> ModalData:
    """Modal integrals of a link (immutable): computed once per process, reused by every run
    of the same link (sweeps over manoeuvres, repeated runs). Always rescaled from the link's
    data at EI = 1 (`modes.modal_data_for_stiffness`, itself cached): a sweep over EI, E or
    damping integrates the modes once, and a sweep case equals its single run bit for bit."""
    return modal_data_for_stiffness(link)


def chain_modal_data(chain: Chain, base: Base | None = None) -> list[ModalData]:
    """The modal basis of every link (outboard-loaded modes depend on the whole chain and on
    where its branches start on the ``base``)."""
    out = []
    for k, (link, kind) in enumerate(zip(chain.links, chosen_mode_shapes(chain, base))):
        if kind != link.mode_shapes:
            link = dataclasses.replace(link, mode_shapes=kind)
        if kind == "outboard_loaded":
            out.append(_loaded_modal_data(link, _outboard_loaded_shapes(chain, k, base)))
        elif kind == "hub_loaded":
            out.append(_loaded_modal_data(link, _hub_loaded_shapes(chain, k, base)))
        else:
            out.append(_link_modal_data(link))
    return out


def initial_modal_rates(chain: Chain, modal: Sequence[ModalData]) -> np.ndarray:
    """ż(0) (m/s): every link's `Link.initial_modal_rates` in its basis, zeros for a link
    without them (at rest); ValueError naming the link when their count is not its modes'."""
    out = []
    for k, (link, data) in enumerate(zip(chain.links, modal, strict=True)):
        rates = np.asarray(link.initial_modal_rates, dtype=float)
        if rates.size and (rates.shape != (data.n,) or not np.all(np.isfinite(rates))):
            raise ValueError(f"links[{k}].initial_modal_rates: need {data.n} finite rates "
                             f"(m/s, one per mode of link {link.name!r}), got "
                             f"{list(link.initial_modal_rates)}")
        out.append(rates if rates.size else np.zeros(data.n))
    return np.concatenate(out) if out else np.zeros(0)


class FirstOrderSystem:
    """The assembled first-order model of a chain; evaluate its matrices at any times."""

    def __init__(self, chain: Chain, geometric_stiffening: bool = False,
                 actuators: Sequence[PiezoActuator] = (),
                 gravity: Sequence[float] = (0.0, 0.0)) -> None:
        """``gravity``: uniform field [gx, gy] (m/s², global axes), entering only through the
        hub's acceleration in the kinematical synthesis (`kinematics.inertial_acceleration`)."""
        self.chain = chain
        self.geometric_stiffening = geometric_stiffening
        self.gravity: tuple[float, float] = (float(gravity[0]), float(gravity[1]))
        self.modal: list[ModalData] = chain_modal_data(chain)
        # open-loop piezo actuators: f gets B V(t) (dynamics/actuators.py)
        self.actuators = tuple(actuators)
        self.actuator_B = actuator_matrix(self.actuators, self.modal)
        offsets = np.concatenate([[0], np.cumsum([d.n for d in self.modal])]).astype(int)
        self.offsets: list[int] = [int(o) for o in offsets[:-1]]
        self.n: int = int(offsets[-1])
        self.bodies = [link_body(d, o) for d, o in zip(self.modal, self.offsets)]
        self._frames_cache: tuple[np.ndarray, FrameMotion] | None = None
        self._history_cache: list[tuple[np.ndarray, JointHistory]] = []
        self._first_history: tuple[np.ndarray, JointHistory] | None = None
        # The equations are written for w = z − z_start (so every integrator starts at rest
        # at w = 0): f becomes f − K z_start. None: z_start = 0 (`start_from`).
        self.z_start: np.ndarray | None = None

    def equilibrium(self, t0: float = 0.0) -> np.ndarray:
        """The elastic coordinates z (n,) in static equilibrium with the loads at time t0 (s):
        K(t0) z = f(t0) with ż = z̈ = 0 (gravity, and the joints' state at t0)."""
        saved, self.z_start = self.z_start, None
        try:
            _, _, K, f = self.matrices(np.array([float(t0)]))
        finally:
            self.z_start = saved
        return np.linalg.solve(K[0], f[0])

    def start_from(self, z_start: np.ndarray | None) -> None:
        """Integrate w = z − z_start (the solvers start at rest at w = 0): the run starts at
        rest at z = z_start; add z_start back to the solution's coordinates
        (`shift_solution`)."""
        self.z_start = None if z_start is None else np.asarray(z_start, dtype=float).copy()

    def tip_bounds(self) -> np.ndarray:
        """Rows (links, 2n+1) over the integrated state [w, ẇ, 1] giving each link's tip
        deflection w(L) of z = w + z_start over its length: a magnitude beyond 1 is a tip
        beyond its length, where the first-order model has diverged (the integrators that
        read it check every step, `solvers.solution.tip_bounds`)."""
        rows = np.zeros((len(self.bodies), 2 * self.n + 1))
        for k, (body, d) in enumerate(zip(self.bodies, self.modal)):
            if d.n == 0:
                continue
            rows[k, body.slice] = d.tip_value / d.length
            if self.z_start is not None:
                rows[k, -1] = self.z_start[body.slice] @ d.tip_value / d.length
        return rows

    def shift_solution(self, solution: _Solution) -> _Solution:
        """The solution (a frozen dataclass with coordinates ``q``) in z of one integrated in
        w = z − z_start."""
        if self.z_start is None:
            return solution
        return dataclasses.replace(solution, q=solution.q + self.z_start)  # type: ignore

    @property
    def max_frequency(self) -> float:
        """Highest clamped natural frequency of any link, rad/s."""
        return highest_frequency(self.modal)

    # -- kinematics -------------------------------------------------------------------------
    def joint_history(self, t: np.ndarray) -> JointHistory:
        """Prescribed joint angles, rates, accelerations at times t (s); remembered for the
        first t asked for (a run's output times, asked for again by its channels after the
        table's many sample times) and the last three."""
        t = np.asarray(t, dtype=float)
        first = self._first_history
        if first is not None and first[0].shape == t.shape and np.array_equal(first[0], t):
            return first[1]
        for i, (times, history) in enumerate(self._history_cache):
            if times.shape == t.shape and np.array_equal(times, t):
                if i:  # most recent first
                    self._history_cache.insert(0, self._history_cache.pop(i))
                return history
        even = None  # the output times' history, when t adds their midpoints (the table's keys)
        if first is not None and t.ndim == 1 and t.size == 2 * first[0].size - 1 \
                and np.array_equal(t[0::2], first[0]):
            even = first[1]
        history = joint_history(self.chain.joints, t, even)
        if first is None:
            self._first_history = (t.copy(), history)
        else:
            self._history_cache = [(t.copy(), history), *self._history_cache[:2]]
        return history

    def frames(self, t: np.ndarray) -> FrameMotion:
        """Frame motion at times t (s). Computed once per distinct joint state (a rest phase
        repeats one state thousands of times) and remembered for the last t asked for: the
        sensors, the joint torques and the tip paths of one run all need the same frames."""
        t = np.asarray(t, dtype=float)
        cached = self._frames_cache
        if cached is not None and cached[0].shape == t.shape and np.array_equal(cached[0], t):
            return cached[1]
        unique, inverse = self.joint_history(t).distinct
        fr = frame_motion(unique, self.modal, self.offsets, self.n, self.gravity)
        if unique.angle.shape[0] < inverse.size:
            fr = fr.at_rows(inverse)
        self._frames_cache = (t.copy(), fr)
        return fr

    def breakpoints(self) -> np.ndarray:
        """Times (s) where a joint's acceleration, and so the coefficients, are not smooth
        (from each motion's ``breakpoints``, where it has them)."""
        return input_breakpoints(self.chain.joints, self.actuators)

    def coefficient_keys(self, t: np.ndarray) -> np.ndarray:
        """Integer labels of the times t: equal labels ⇒ equal M, C, K, f.

        With prescribed joints the coefficients depend on time only through the joint angles,
        rates and accelerations, so every instant of a joint at rest shares one label: the
        solver then computes one propagator for a whole rest phase. Open-loop actuator
        voltages count as part of the state of the inputs."""
        keys = self.joint_history(t).distinct[1]
        if not self.actuators:
            return keys
        rows = np.column_stack([keys, self.voltages(t)])
        new = np.ones(rows.shape[0], dtype=bool)
        new[1:] = np.any(rows[1:] != rows[:-1], axis=1)
        return np.cumsum(new) - 1

    def resting_intervals(self, t_out: np.ndarray) -> np.ndarray | None:
        """Per output interval of t_out (s), whether the coefficients are equal at both its
        ends and its middle (the joints rest there): what
        `coefficient_table.resting_from_keys` gives of `coefficient_keys`, with the joints
        evaluated at the middles of the intervals whose ends are alike only (a Lawson table's
        rest phases, without the joint history of every middle). None with actuators (their
        voltages are part of the keys: the table then asks the keys)."""
        if self.actuators:
            return None
        t_out = np.asarray(t_out, dtype=float)
        at = self.joint_history(t_out)
        run = at.distinct[1]
        resting = run[1:] == run[:-1]  # the ends alike
        ends = np.flatnonzero(resting)
        if ends.size:
            # the middles as resting_from_keys places them, to the bit
            middle = joint_history(self.chain.joints,
                                   t_out[ends] + 0.5 * (t_out[ends + 1] - t_out[ends]))
            # Column by column: numpy's all over axis 1 of these (intervals, joints) arrays
            # reduces each short row in its own inner loop, ~5x slower (~0.2 ms a case).
            alike = np.ones(ends.size, dtype=bool)
            for values, mid in ((at.angle, middle.angle), (at.rate, middle.rate),
                                (at.acceleration, middle.acceleration)):
                for k in range(values.shape[1]):
                    alike &= mid[:, k] == values[ends, k]
            resting[ends] = alike
        return resting

    def voltages(self, t: np.ndarray) -> np.ndarray:
        """Open-loop actuator voltages (nt, n_act), V, clipped to each actuator's limit."""
        t = np.asarray(t, dtype=float)
        return np.column_stack([np.clip(a.voltage.value(t), -a.limit, a.limit)
                                for a in self.actuators]).reshape(t.size, len(self.actuators))

    def xi_maps(self, frames: FrameMotion, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """T̂_k = [T_k; E_k] and its time derivatives, each (nt, 3+n_k, n)."""
        return xi_maps(frames, self.bodies[k], k, self.n)

    def xi_states(
        self, frames: FrameMotion, k: int, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """ξ_k, ξ̇_k, ξ̈_k (each (nt, 3+n_k)) from z, ż, z̈ (nt, n)."""
        return xi_states(frames, k, self.bodies[k].slice, z, zd, zdd)

    # -- equations --------------------------------------------------------------------------
    def matrices(
        self, t: np.ndarray, frames: FrameMotion | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """M, C, K (nt, n, n) and f (nt, n) of M z̈ + C ż + K z = f at times t (s); in
        w = z − z_start when a start is set (f − K z_start: `start_from`)."""
        M, C, K, f = self._matrices(t, frames)
        if self.actuators:
            f = f + self.voltages(t) @ self.actuator_B.T
        if self.z_start is not None:
            f = f - K @ self.z_start
        return M, C, K, f

    def _matrices(
        self, t: np.ndarray, frames: FrameMotion | None = None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """matrices without the actuators' forces."""
        if frames is not None:
            return self._assemble(frames)
        # Assemble once per distinct joint state: rest phases repeat one state many times.
        unique, inverse = self.joint_history(t).distinct
        coefficients = self._assemble(
            frame_motion(unique, self.modal, self.offsets, self.n, self.gravity))
        if unique.angle.shape[0] == inverse.size:
            return coefficients
        M, C, K, f = (a[inverse] for a in coefficients)
        return M, C, K, f

    def _assemble(self, fr: FrameMotion) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """M, C, K, f at the instants of a frame motion."""
        nt = fr.theta.shape[0]
        n = self.n
        M = np.zeros((nt, n, n))
        C = np.zeros((nt, n, n))
        K = np.zeros((nt, n, n))
        f = np.zeros((nt, n))
        outboard = self._outboard_inertia_force(fr)
        for k, body in enumerate(self.bodies):
            add_link_terms(body, fr, k, self.xi_maps(fr, k), self._rigid_load(body, fr, k),
                           self._second_order_stiffness(body, fr, k, outboard[:, k]), M, C, K, f)
        return M, C, K, f

    def accelerations(self, t: np.ndarray, z: np.ndarray, zd: np.ndarray) -> np.ndarray:
        """z̈ (nt, n) from the equations of motion, given z, ż (nt, n)."""
        M, C, K, f = self.matrices(t)
        rhs = f - np.einsum("tij,tj->ti", C, zd) - np.einsum("tij,tj->ti", K, z)
        return np.linalg.solve(M, rhs[..., None])[..., 0]

    # -- pieces -----------------------------------------------------------------------------
    def _rigid_load(self, body: LinkBody, fr: FrameMotion, k: int) -> np.ndarray:
        """rigid_load of link k (a method: the energy test removes one of its terms)."""
        return rigid_load(body, fr, k)

    def _outboard_inertia_force(self, fr: FrameMotion) -> np.ndarray:
        """Σ_{j>k} ∫_j a0 dm in frame k's axes (N): minus the joint force at link k's tip."""
        nt, n_links = fr.theta.shape
        out = np.zeros((nt, n_links, 2))
        for k in range(n_links - 2, -1, -1):
            d = self.modal[k + 1]
            ax, ay = fr.origin_accel[:, k + 1, 0], fr.origin_accel[:, k + 1, 1]
            w, wd = fr.omega[:, k + 1], fr.alpha[:, k + 1]
            own = np.stack([d.mass * ax - w**2 * d.first_moment - wd * d.lateral_moment,
                            d.mass * ay + wd * d.first_moment - w**2 * d.lateral_moment], -1)
            turn = rotation(fr.theta[:, k + 1] - fr.theta[:, k])
            out[:, k] = np.einsum("tij,tj->ti", turn, out[:, k + 1] + own)
        return out

    def _second_order_stiffness(
        self, body: LinkBody, fr: FrameMotion, k: int, outboard: np.ndarray
    ) -> np.ndarray:
        """second_order_stiffness of link k in z (docs/derivation.md §4)."""
        return second_order_stiffness(body, fr, k, outboard, self.geometric_stiffening)


# -- per-link terms, shared with the forward-dynamics system (dynamics/forward.py) ------------
def xi_maps(fr: FrameMotion, body: LinkBody, k: int, n_total: int
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """T̂_k = [T_k; E_k] and its time derivatives, each (nt, 3+n_k, n_total); E_k picks q_k
    out of the n_total coordinates, so its derivatives are zero."""
    nt = fr.theta.shape[0]
    nk = body.data.n
    E = np.zeros((nt, nk, n_total))
    E[:, :, body.slice] = np.eye(nk)
    zero = np.zeros_like(E)
    return (
        np.concatenate([fr.T[k], E], axis=1),
        np.concatenate([fr.T_dot[k], zero], axis=1),
        np.concatenate([fr.T_ddot[k], zero], axis=1),
    )


def xi_states(frames: FrameMotion, k: int, own: slice, z: np.ndarray, zd: np.ndarray,
              zdd: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """ξ_k = [ρx, ρy, θ1, q_k], ξ̇_k, ξ̈_k (each (nt, 3+n_k)) from z, ż, z̈ (nt, n); ``own``
    picks link k's modal coordinates q_k out of z."""
    # T̂ = [T; E] with E picking q_k, constant: the rows of its derivatives are zero.
    head, head_d, head_dd = frames.heads(k, z, zd, zdd)
    return (np.concatenate([head, z[:, own]], axis=1),
            np.concatenate([head_d, zd[:, own]], axis=1),
            np.concatenate([head_dd, zdd[:, own]], axis=1))


def add_link_terms(
    body: LinkBody, fr: FrameMotion, k: int, maps: tuple[np.ndarray, np.ndarray, np.ndarray],
    load: np.ndarray, second_order: np.ndarray,
    M: np.ndarray, C: np.ndarray, K: np.ndarray, f: np.ndarray,
) -> None:
    """Add link k's inertia, gyroscopic, elastic and damping terms to M, C, K, f in place.

    maps: T̂_k and its derivatives (xi_maps); load: its zero-order inertia load (rigid_load);
    second_order: its second-order stiffness (second_order_stiffness)."""
    w = fr.omega[:, k, None, None]
    wd = fr.alpha[:, k, None, None]
    Th, Th_d, Th_dd = maps
    Mtot = body.M0 + body.M_rot
    ThT = np.swapaxes(Th, 1, 2)
    M += ThT @ Mtot @ Th
    C += ThT @ (2.0 * Mtot @ Th_d + 2.0 * w * (body.G0 @ Th))
    K += ThT @ (
        Mtot @ Th_dd + 2.0 * w * (body.G0 @ Th_d) + (wd * body.G0 - w**2 * body.M0) @ Th
    )
    f -= np.einsum("tai,ta->ti", Th, load)
    K -= second_order
    sl = body.slice
    K[:, sl, sl] += body.data.stiffness_matrix
    C[:, sl, sl] += body.data.damping_matrix


def rigid_load(body: LinkBody, fr: FrameMotion, k: int) -> np.ndarray:
    """∫ P̂ᵀ a0 dm + Σ J_b c_b ω̇: zero-order inertia load of link k in ξ space, (nt, 3+n)."""
    d = body.data
    ax, ay = fr.origin_accel[:, k, 0], fr.origin_accel[:, k, 1]
    w, wd = fr.omega[:, k], fr.alpha[:, k]
    m, s1, J = d.mass, d.first_moment, d.second_moment
    head = np.stack([m * ax - w**2 * s1, m * ay + wd * s1, s1 * ay + J * wd], -1)
    elastic = ay[:, None] * d.phi_bar + wd[:, None] * d.phi_tilde
    load = np.concatenate([head, elastic], -1)
    load[:, 2] += d.rotary_inertia * wd
    load[:, 3:] += wd[:, None] * d.rotary_slope
    if d.lateral:  # bodies' centres across the link, a0 = [−ω̇c_y, −ω²c_y] more
        sy = d.lateral_moment
        load[:, 0] -= wd * sy
        load[:, 1] -= w**2 * sy
        load[:, 2] -= ax * sy
        load[:, 3:] += (w**2)[:, None] * d.lateral_tilde - ax[:, None] * d.lateral_slope
    return load


def second_order_stiffness(
    body: LinkBody, fr: FrameMotion, k: int, outboard: np.ndarray, geometric_stiffening: bool,
    at: Any = None,
) -> np.ndarray:
    """∫ (∂r₂/∂x)·a0 dm of link k plus the outboard load (outboard[:, 0], N, along frame k's x)
    acting on its tip's r₂, (nt, n, n) over whatever coordinates fr.T[k] maps from; ``at``
    (a `prismatic.Hang`) the section the outboard load acts on if not the tip.

    r₂ in frame k is [u_x − θ1 w − x θ1²/2, 0] with foreshortening u_x = −½ qᵀS(x)q.
    """
    d = body.data
    ax = fr.origin_accel[:, k, 0]
    w2 = fr.omega[:, k] ** 2
    N = outboard[:, 0]
    ay, wd = fr.origin_accel[:, k, 1], fr.alpha[:, k]
    x_out, value_out, fore_out = ((d.length, d.tip_value, d.foreshortening_tip) if at is None
                                  else (at.x, at.value, at.shortening))
    vec = ax[:, None] * d.phi_bar - w2[:, None] * d.phi_tilde + N[:, None] * value_out
    scal = ax * d.first_moment - w2 * d.second_moment + N * x_out
    if d.lateral:  # bodies' centres across the link: r₂ ∋ −½(θ1 + ψ)² c
        vec = vec + ay[:, None] * d.lateral_slope + wd[:, None] * d.lateral_tilde
        scal = scal + ay * d.lateral_moment
    theta1 = fr.T[k][:, 2, :]  # (nt, n)
    sl = body.slice
    out = scal[:, None, None] * theta1[:, :, None] * theta1[:, None, :]
    cross = theta1[:, :, None] * vec[:, None, :]  # Θᵀ v, columns on q_k
    out[:, :, sl] += cross
    out[:, sl, :] += np.swapaxes(cross, 1, 2)
    if geometric_stiffening:
        out[:, sl, sl] += (
            ax[:, None, None] * d.foreshortening_mass
            - w2[:, None, None] * d.foreshortening_moment
            + N[:, None, None] * fore_out
        )
        if d.lateral:
            out[:, sl, sl] += (ay[:, None, None] * d.lateral_shortening
                               + wd[:, None, None] * d.lateral_shortening_moment)
    return out
