"""Forward dynamics: rigid coordinates (base pose, joint angles) and elastic coordinates together.

Coordinates u = [p; z]: p the rigid coordinates (the base's x, y, attitude if it moves, then
one angle β_k per joint, then each elastic joint's motor angle: dynamics/elastic_joints.py),
z the elastic coordinates. At any rigid state (p, ṗ, p̈) the
first-order equations of docs/derivation.md are assembled in the perturbation coordinates
x = [δp; z]: a joint or base perturbation is a rigid displacement/rotation of a frame, so it
enters the kinematical synthesis as extra columns of the maps T_k, and every term of the
prescribed-joint model (mass, gyroscopic, centrifugal, second-order stiffness, zero-order load)
carries over unchanged. With δp = 0 (the expansion is about the current rigid state) this gives

    M[:, z] z̈ + C[:, z] ż + K(p̈)[:, z] z = f(p̈) + Q,

linear in the unknown accelerations (p̈ of the free coordinates, z̈): the rigid rows are the
exact nonlinear rigid-body equations plus their first-order elastic coupling, the elastic rows
the first-order equations (docs/derivation.md, "Forward dynamics"). Arrays carry a leading
axis over (time, trial acceleration) pairs.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..model import (
    Base,
    Chain,
    JointMotion,
    PiezoActuator,
    PositionServo,
    TorqueDrive,
    VelocityServo,
    is_driven,
)
from ..model.joints import drive_side
from ..model.settings import InitialName
from ..modes import ModalData
from . import elastic_joints, prismatic
from .actuators import actuator_matrix, open_loop_voltages
from .first_order import (
    LinkBody,
    add_link_terms,
    chain_modal_data,
    initial_modal_rates,
    link_body,
    rigid_load,
    second_order_stiffness,
    xi_maps,
)
from .kinematics import TURN, FrameMotion, block_map, inertial_acceleration, rotation


class ForwardSystem:
    """A base plus a chain (or tree) of flexible links with prescribed and driven joints."""

    def __init__(self, chain: Chain, base: Base, geometric_stiffening: bool = False,
                 actuators: Sequence[PiezoActuator] = (),
                 modal: Sequence[ModalData] | None = None,
                 gravity: Sequence[float] = (0.0, 0.0),
                 initial: InitialName = "rest") -> None:
        """``modal``: the links' modal data when the caller has them already (default:
        `first_order.chain_modal_data`). ``gravity``: uniform field [gx, gy] (m/s², global
        axes), entering only as the base's acceleration a − g of the kinematical synthesis
        and of the free base's own inertia (`kinematics.inertial_acceleration`).
        ``initial``: "rest" (links undeformed) or "equilibrium" (`equilibrium_state`)."""
        # A slider's block is a point body at the root of the link it carries.
        self.chain = chain = prismatic.with_slider_masses(chain)
        self.slides = prismatic.sliders(chain.joints)
        self.base = base
        self.geometric_stiffening = geometric_stiffening
        self.gravity: tuple[float, float] = (float(gravity[0]), float(gravity[1]))
        self.initial = initial
        # False: an equilibrium start refuses joints that nothing holds and the loads turn
        # (`unheld`); True: they may (a frozen-time plant about that start).
        self.unheld_may_move = False
        self._start: np.ndarray | None = None
        self.modal: list[ModalData] = (list(modal) if modal is not None
                                       else chain_modal_data(chain, base))
        n_links = len(chain.links)
        # The section each link's successor hangs on (a slider's line point, else the tip).
        self.hang = prismatic.hang_points(chain, self.modal)
        self.n_base = len(base.coordinates)
        # Elastic joints' motor angles follow the joint angles (dynamics/elastic_joints.py).
        self.elastic = elastic_joints.elastic_joints(chain.joints)
        self.n_rigid = self.n_base + n_links + len(self.elastic)
        offsets = np.concatenate([[0], np.cumsum([d.n for d in self.modal])]).astype(int)
        self.n = int(offsets[-1])  # elastic coordinates
        self.n_x = self.n_rigid + self.n
        self.bodies: list[LinkBody] = [link_body(d, self.n_rigid + int(o))
                                       for d, o in zip(self.modal, offsets[:-1])]
        self.attach = [base.attachment(k) for k in range(n_links)]
        self.driven = [k for k, j in enumerate(chain.joints) if is_driven(j)]
        # Free rigid coordinates: the base's (not a prescribed cart's), then the driven
        # joints', then the driven motors'.
        own = [] if base.cart is not None and base.cart.prescribed else range(self.n_base)
        self.free = (list(own) + [self.n_base + k for k in self.driven]
                     + [self.motor_index(k) for k in elastic_joints.driven_motors(chain.joints)])
        self.servos = [k for k in self.driven
                       if isinstance(drive_side(chain.joints[k]), VelocityServo | PositionServo)]
        if base.cart is not None and getattr(base.cart.drive, "integrator", False):
            self.servos.append(n_links)  # the cart's servo integral: index N (`servo_of`)
        # Piezo actuators: generalized forces B V on z (dynamics/actuators.py), V the
        # open-loop voltages unless a closed loop holds its own (``applied(voltages=…)``).
        self.actuators = tuple(actuators)
        self.actuator_B = actuator_matrix(self.actuators, self.modal)  # (n, n_act), N·m/V

    # -- rigid state ------------------------------------------------------------------------
    def initial_state(self) -> np.ndarray:
        """[p_free, ṗ_free, z, ż, integrals] at t = 0: base and driven joints as given
        (servos start on their reference), elastic coordinates at rest, undeformed or (with
        ``initial = "equilibrium"``) in static equilibrium (`equilibrium_state`)."""
        if self._start is None:
            start = self._rest_state()
            if self.initial == "equilibrium":
                start = self.equilibrium_state(start)
            self._start = start
        return self._start.copy()

    def equilibrium_state(self, start: np.ndarray, t0: float = 0.0) -> np.ndarray:
        """``start`` with the elastic coordinates, and the joints held by servos, at rest in
        static equilibrium with the loads at t0 (s): z̈ = 0 and each servo joint's β̈ = 0 with
        ż = 0. A servo with an integrator holds its reference and its integral takes the load;
        one without holds the angle where its torque balances it. The base and torque-driven
        joints keep their given state (a falling base: equilibrium relative to it).
        Newton's method on the numpy equations (`equilibrium.solve`)."""
        from . import equilibrium

        nu, n = len(self.free), self.n
        unknowns = list(range(2 * nu, 2 * nu + n))  # z
        rows = list(range(nu, nu + n))  # z̈ in the accelerations [p̈_free, z̈]
        for k in self.servos:
            joint, i = self.servo_of(k)
            j = self.free.index(i)
            rows.append(j)
            unknowns.append(2 * nu + 2 * n + self.servos.index(k) if joint.integrator else j)
        for k in self.elastic:  # the link held by its spring
            rows.append(self.free.index(self.joint_index(k)))
            unknowns.append(rows[-1])

        def residuals(x: np.ndarray) -> np.ndarray:
            states = np.repeat(start[None], x.shape[0], 0)
            states[:, unknowns] = x
            pdd, zdd, _ = self.accelerations(
                np.full(x.shape[0], float(t0)), states[:, :nu], states[:, nu:2 * nu],
                states[:, 2 * nu:2 * nu + n], states[:, 2 * nu + n:2 * nu + 2 * n],
                states[:, 2 * nu + 2 * n:])
            return np.concatenate([pdd, zdd], 1)[:, rows]

        columns, watched = self.unheld()
        rows += columns
        y = start.copy()
        y[unknowns] = equilibrium.solve(residuals, start[unknowns], watched)
        return y

    def unheld(self, dependent: Sequence[int] = ()) -> tuple[list[int], list[Any]]:
        """The joints' free coordinates (indices into ``free``) that no servo or spring
        holds at an equilibrium start, but for the ``dependent`` ones (a loop's, which its
        closures hold), and their `equilibrium.Unheld` names: a torque-driven or free joint
        (or motor) must be at rest with the loads at t = 0 by itself. The base's
        coordinates are left out: the equilibrium is relative to the base, which may move.
        None of them with ``unheld_may_move``."""
        from .equilibrium import Unheld

        if self.unheld_may_move:
            return [], []
        held = {self.servo_of(k)[1] for k in self.servos}
        held |= {self.joint_index(k) for k in self.elastic}
        columns, names = [], []
        for j, i in enumerate(self.free):
            if i < self.n_base or i in held or j in dependent:
                continue
            links = len(self.chain.links)
            k, motor = ((i - self.n_base, False) if i < self.n_base + links
                        else (self.elastic[i - self.n_base - links], True))
            columns.append(j)
            names.append(Unheld(f"joints[{k}]" + ("'s motor" if motor else ""),
                                "m/s²" if k in self.slides else "rad/s²"))
        return columns, names

    def _rest_state(self) -> np.ndarray:
        """initial_state with the links undeformed, at rest but for their initial modal
        rates (`Link.initial_modal_rates`)."""
        b = self.base
        p0, v0 = {"free": ([*b.position, b.attitude], [*b.velocity, b.rate]),
                  "pinned": ([b.attitude], [b.rate]), "fixed": ([], []), "cart": ([], [])}[b.kind]
        if b.cart is not None and not b.cart.prescribed:
            s0, r0 = elastic_joints.start(b.cart.drive)
            p0, v0 = [s0], [r0]
        p, v = list(p0), list(v0)
        for k in self.driven:
            joint = self.chain.joints[k]
            angle, rate = elastic_joints.start(joint.drive if k in self.slides else joint)
            p.append(angle)
            v.append(rate)
        for k in elastic_joints.driven_motors(self.chain.joints):
            angle, rate = elastic_joints.start(self.chain.joints[k].motor)  # type: ignore
            p.append(angle)
            v.append(rate)
        return np.concatenate([p, v, np.zeros(self.n), initial_modal_rates(self.chain, self.modal),
                               np.zeros(len(self.servos))])

    def joint_index(self, k: int) -> int:
        return self.n_base + k

    def motor_index(self, k: int) -> int:
        """The rigid coordinate of elastic joint k's motor angle."""
        return self.n_base + len(self.chain.links) + self.elastic.index(k)

    def drive_index(self, k: int) -> int:
        """The rigid coordinate joint k's drive turns: its motor's if elastic."""
        return self.motor_index(k) if k in self.elastic else self.joint_index(k)

    def servo_of(self, k: int) -> tuple[Any, int]:
        """The servo of ``servos`` entry k and the rigid coordinate it turns: joint k's drive
        (its motor's if elastic), or at k = N the cart's on its travel (coordinate 0)."""
        if k == len(self.chain.links):
            assert self.base.cart is not None
            return self.base.cart.drive, 0
        return drive_side(self.chain.joints[k]), self.drive_index(k)

    def free_travels(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The free rigid coordinates that are a travel with a finite range (a driven
        cart's, driven sliders'): their columns in p_free and their lower and upper ends
        (m), which an integrator stops at (the run's travel check then names them)."""
        columns, lo, hi = [], [], []
        cart = self.base.cart
        ranges = ([(0, cart.travel)] if cart is not None and not cart.prescribed else [])
        ranges += [(self.joint_index(k), self.chain.joints[k].travel)
                   for k in self.slides if self.joint_index(k) in self.free]
        for i, (a, b) in ranges:
            if np.isfinite(a) or np.isfinite(b):
                columns.append(self.free.index(i))
                lo.append(a)
                hi.append(b)
        return np.array(columns, dtype=np.int64), np.array(lo, float), np.array(hi, float)

    def rigid_state(self, t: np.ndarray, p_free: np.ndarray, pd_free: np.ndarray,
                    pdd_free: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Full p, ṗ, p̈ (nt, n_rigid): free coordinates given, prescribed joints evaluated."""
        nt = t.shape[0]
        out = [np.zeros((nt, self.n_rigid)) for _ in range(3)]
        for k, joint in enumerate(self.chain.joints):
            if not is_driven(joint):
                assert isinstance(joint, JointMotion)
                for arr, v in zip(out, joint.evaluate(t)):
                    arr[:, self.joint_index(k)] = np.broadcast_to(v, t.shape)
        elastic_joints.prescribed_motors(self, t, out)
        cart = self.base.cart
        if cart is not None and cart.prescribed:
            for arr, v in zip(out, cart.drive.evaluate(t)):  # type: ignore[union-attr]
                arr[:, 0] = np.broadcast_to(v, t.shape)
        for arr, v in zip(out, (p_free, pd_free, pdd_free)):
            arr[:, self.free] = v
        return out[0], out[1], out[2]

    # -- kinematics -------------------------------------------------------------------------
    def frames(self, p: np.ndarray, pd: np.ndarray, pdd: np.ndarray) -> FrameMotion:
        """Zero-order frames at rigid states (nt, n_rigid) and maps x → [ρx, ρy, θ1]."""
        nt, nb = p.shape[0], self.n_base
        n_links = len(self.chain.links)
        beta, beta_d, beta_dd = prismatic.joint_angles(
            self.chain.joints, *(a[:, nb:nb + n_links] for a in (p, pd, pdd)))
        base_pos = np.zeros((nt, 2))
        base_acc = self._base_acceleration(pdd)
        th_b, w_b, a_b = (np.zeros(nt) for _ in range(3))
        if self.base.kind == "free":
            base_pos = p[:, :2]
        if self.base.turns:
            th_b, w_b, a_b = p[:, nb - 1], pd[:, nb - 1], pdd[:, nb - 1]
        rail = self._rail()
        if rail is not None:  # a cart: its travel s along the rail, its attitude constant
            base_pos = np.asarray(self.base.position) + p[:, :1] * rail
            th_b = np.full(nt, self.base.attitude)
        theta = np.zeros((nt, n_links))
        omega = np.zeros_like(theta)
        alpha = np.zeros_like(theta)
        origin = np.zeros((nt, n_links, 2))
        origin_accel = np.zeros((nt, n_links, 2))
        T, T_d, T_dd = [], [], []
        for k in range(n_links):
            Tk, Tk_d, Tk_dd = (np.zeros((nt, 3, self.n_x)) for _ in range(3))
            back = rotation(-beta[:, k])
            bd, bdd = beta_d[:, k, None, None], beta_dd[:, k, None, None]
            back_d = -bd * (TURN @ back)
            back_dd = (-bdd * TURN - bd**2 * np.eye(2)) @ back
            point = self.attach[k]
            if point is not None:  # branch start on the base
                theta[:, k] = th_b + beta[:, k]
                omega[:, k] = w_b + beta_d[:, k]
                alpha[:, k] = a_b + beta_dd[:, k]
                c = np.einsum("tij,j->ti", rotation(th_b), np.asarray(point, dtype=float))
                origin[:, k] = base_pos + c
                acc = base_acc + a_b[:, None] * (c @ TURN.T) - (w_b**2)[:, None] * c
                origin_accel[:, k] = np.einsum("tji,tj->ti", rotation(theta[:, k]), acc)
                if self.base.kind in ("free", "cart"):  # δx, δy or δs: a global translation
                    A = rotation(-theta[:, k])  # seen in frame k
                    w, a = omega[:, k, None, None], alpha[:, k, None, None]
                    cols = slice(0, 2) if rail is None else slice(0, 1)
                    E = np.eye(2) if rail is None else rail[:, None]
                    Tk[:, :2, cols] = A @ E
                    Tk_d[:, :2, cols] = -w * (TURN @ A) @ E
                    Tk_dd[:, :2, cols] = (-a * TURN - w**2 * np.eye(2)) @ A @ E
                if self.base.turns:  # δθ_b: turns the attachment point and frame
                    Sc = TURN @ np.asarray(point, dtype=float)
                    Tk[:, :2, nb - 1] = back @ Sc
                    Tk_d[:, :2, nb - 1] = back_d @ Sc
                    Tk_dd[:, :2, nb - 1] = back_dd @ Sc
                    Tk[:, 2, nb - 1] = 1.0
            else:  # on the deformed tip of link k − 1 (a slider: its line's section)
                j, hang = k - 1, self.hang[k - 1]
                theta[:, k] = theta[:, j] + beta[:, k]
                omega[:, k] = omega[:, j] + beta_d[:, k]
                alpha[:, k] = alpha[:, j] + beta_dd[:, k]
                e_j = rotation(theta[:, j])
                origin[:, k] = origin[:, j] + hang.x * e_j[:, :, 0]
                tip_acc = origin_accel[:, j] + hang.x * np.stack(
                    [-omega[:, j] ** 2, alpha[:, j]], -1)
                P = prismatic.hang_map(hang)
                U, U_d, U_dd = (np.einsum("ij,tjn->tin", P[:, :3], M) for M in
                                (T[j], T_d[j], T_dd[j]))
                U[:, :, self.bodies[j].slice] += P[:, 3:]
                if k in self.slides:  # the block on its line through the tip
                    joint, i = self.chain.joints[k], self.joint_index(k)
                    tip_acc = tip_acc + prismatic.lever(joint, p[:, i], pd[:, i], pdd[:, i],
                                                        omega[:, j], alpha[:, j], U, U_d, U_dd)
                    origin[:, k] += p[:, i, None] * (e_j @ np.array(joint.direction))
                origin_accel[:, k] = np.einsum("tij,tj->ti", back, tip_acc)
                R, R_d, R_dd = block_map(back), block_map(back_d, 0.0), block_map(back_dd, 0.0)
                Tk = R @ U
                Tk_d = R_d @ U + R @ U_d
                Tk_dd = R_dd @ U + 2.0 * R_d @ U_d + R @ U_dd
            if k in self.slides:  # δs_k moves frame k along the line
                Tk[:, :2, self.joint_index(k)] += back @ np.array(self.chain.joints[k].direction)
            else:
                Tk[:, 2, self.joint_index(k)] += 1.0  # δβ_k turns frame k
            T.append(Tk)
            T_d.append(Tk_d)
            T_dd.append(Tk_dd)
        return FrameMotion(theta, omega, alpha, origin, origin_accel, T, T_d, T_dd)

    def xi_maps(self, fr: FrameMotion, k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """T̂_k = [T_k; E_k] and its time derivatives, each (nt, 3+n_k, n_x)."""
        return xi_maps(fr, self.bodies[k], k, self.n_x)

    # -- equations --------------------------------------------------------------------------
    def matrices(self, p: np.ndarray, pd: np.ndarray, pdd: np.ndarray,
                 frames: FrameMotion | None = None
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """M, C, K (nt, n_x, n_x) and f (nt, n_x) of the perturbation equations in x = [δp; z]
        about rigid states p, ṗ, p̈ (nt, n_rigid); f is minus the zero-order inertia force.
        ``frames``: `frames` at those states, if the caller has them."""
        fr = self.frames(p, pd, pdd) if frames is None else frames
        nt, n_x = p.shape[0], self.n_x
        M = np.zeros((nt, n_x, n_x))
        C = np.zeros_like(M)
        K = np.zeros_like(M)
        f = np.zeros((nt, n_x))
        own, outboard = self._inertia_forces(fr)
        for k, body in enumerate(self.bodies):
            add_link_terms(body, fr, k, self.xi_maps(fr, k), rigid_load(body, fr, k),
                           self._second_order_stiffness(body, fr, k, outboard[:, k]), M, C, K, f)
        self._base_inertia(pdd, M, f)
        self._attachment_turn(p, fr, own, K)
        prismatic.lever_stiffness(self, p, fr, outboard, K)
        for k in self.driven:
            i = self.joint_index(k)
            M[:, i, i] += self.chain.joints[k].motor_inertia  # type: ignore[union-attr]
            f[:, i] -= self.chain.joints[k].motor_inertia * pdd[:, i]  # type: ignore[union-attr]
        elastic_joints.add_rotor_inertia(self, pdd, M, f)
        return M, C, K, f

    def inertia_shares(self, p: np.ndarray, pd: np.ndarray, pdd: np.ndarray) -> np.ndarray:
        """Each link's largest share, over the free rigid coordinates and the rigid states
        p, ṗ, p̈ (nt, n_rigid), of a free coordinate's inertia (the diagonal of M's rigid
        block: its own T̂ᵀ M T̂ over the whole M, with base, motors and rotors): 1 where a
        free joint turns the link alone, 0 where no free coordinate moves it; (links,)."""
        out = np.zeros(len(self.bodies))
        free = np.array(self.free, dtype=np.int64)
        if free.size == 0 or p.shape[0] == 0:
            return out
        fr = self.frames(p, pd, pdd)
        whole = self.matrices(p, pd, pdd, fr)[0][:, free, free]  # (nt, nu)
        for k, body in enumerate(self.bodies):
            Th = self.xi_maps(fr, k)[0][:, :, free]  # (nt, 3 + n_k, nu)
            own = np.einsum("tai,ab,tbi->ti", Th, body.M0 + body.M_rot, Th)
            share = np.divide(own, whole, out=np.zeros_like(own), where=whole > 0.0)
            out[k] = float(share.max())
        return out

    def _rail(self) -> np.ndarray | None:
        """A cart's rail direction (2,), global axes; None for other bases."""
        cart = self.base.cart
        return None if cart is None else np.array(cart.direction)

    def _base_acceleration(self, pdd: np.ndarray) -> np.ndarray:
        """The base reference point's acceleration minus gravity (nt, 2), global axes: what
        the synthesis and the base's own inertia take (kinematics.inertial_acceleration)."""
        moving = pdd[:, :2] if self.base.kind == "free" else np.zeros((pdd.shape[0], 2))
        rail = self._rail()
        if rail is not None:
            moving = pdd[:, :1] * rail
        return inertial_acceleration(moving, self.gravity)

    def _base_inertia(self, pdd: np.ndarray, M: np.ndarray, f: np.ndarray) -> None:
        """The rigid base's own mass and inertia and their zero-order inertia load."""
        b, nb = self.base, self.n_base
        if b.kind == "fixed":
            return
        rail = self._rail()
        if rail is not None:  # the cart's mass along its rail
            M[:, 0, 0] += b.mass
            f[:, 0] -= b.mass * (self._base_acceleration(pdd) @ rail)
            return
        if b.kind == "free":
            M[:, 0, 0] += b.mass
            M[:, 1, 1] += b.mass
            f[:, :2] -= b.mass * self._base_acceleration(pdd)
        M[:, nb - 1, nb - 1] += b.inertia
        f[:, nb - 1] -= b.inertia * pdd[:, nb - 1]

    def _attachment_turn(self, p: np.ndarray, fr: FrameMotion, own: np.ndarray,
                         K: np.ndarray) -> None:
        """The second-order turn of each branch's attachment point on a turning base."""
        nb = self.n_base
        if not self.base.turns:
            return
        # A branch hangs on the point c: r = R_b + A(θ_b + δθ) c has −½δθ² A(θ_b)c at second
        # order, so the branch's inertia force F (global) adds −(A c)·F δθ to the θ_b row.
        th_b = p[:, nb - 1]
        for k, point in enumerate(self.attach):
            if point is None:
                continue
            force = np.zeros((p.shape[0], 2))
            j = k
            while True:
                force += np.einsum("tij,tj->ti", rotation(fr.theta[:, j]), own[:, j])
                j += 1
                if j >= len(self.attach) or self.attach[j] is not None:
                    break
            c = np.einsum("tij,j->ti", rotation(th_b), np.asarray(point, dtype=float))
            K[:, nb - 1, nb - 1] -= np.einsum("ti,ti->t", c, force)

    def _inertia_forces(self, fr: FrameMotion) -> tuple[np.ndarray, np.ndarray]:
        """Each link's own ∫a0 dm and the outboard Σ_{j>k, same branch} ∫_j a0 dm, both in
        frame k's axes, (nt, N, 2)."""
        nt, n_links = fr.theta.shape
        own = np.zeros((nt, n_links, 2))
        for k, d in enumerate(self.modal):
            ax, ay = fr.origin_accel[:, k, 0], fr.origin_accel[:, k, 1]
            w, wd = fr.omega[:, k], fr.alpha[:, k]
            own[:, k] = np.stack([d.mass * ax - w**2 * d.first_moment - wd * d.lateral_moment,
                                  d.mass * ay + wd * d.first_moment - w**2 * d.lateral_moment],
                                 -1)
        out = np.zeros((nt, n_links, 2))
        for k in range(n_links - 2, -1, -1):
            if self.attach[k + 1] is not None:  # link k + 1 starts a new branch
                continue
            turn = rotation(fr.theta[:, k + 1] - fr.theta[:, k])
            out[:, k] = np.einsum("tij,tj->ti", turn, out[:, k + 1] + own[:, k + 1])
        return own, out

    def _second_order_stiffness(self, body: LinkBody, fr: FrameMotion, k: int,
                                outboard: np.ndarray) -> np.ndarray:
        """first_order.second_order_stiffness over x (docs/derivation.md §4)."""
        return second_order_stiffness(body, fr, k, outboard, self.geometric_stiffening,
                                      self.hang[k])

    # -- applied loads ----------------------------------------------------------------------
    def voltages(self, t: np.ndarray) -> np.ndarray:
        """Open-loop actuator voltages (nt, n_act), V, clipped to the limits."""
        return open_loop_voltages(self.actuators, t)

    def rail_loads(self, t: np.ndarray) -> np.ndarray:
        """The base loads' component along a cart's rail (nt,), N; the rail takes the rest."""
        b, rail = self.base, self._rail()
        assert rail is not None
        turn = rotation(np.full(t.shape[0], b.attitude))
        out = np.zeros(t.shape[0])
        for load in b.loads:
            F = np.stack([load.force_x.value(t), load.force_y.value(t)], -1)
            if load.frame == "body":
                F = np.einsum("tij,tj->ti", turn, F)
            out += F @ rail
        return out

    def applied(self, t: np.ndarray, p: np.ndarray, pd: np.ndarray,
                integral: np.ndarray, voltages: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """Generalized applied forces Q (nt, n_x) and the servos' integral-state rates
        (nt, n_servos). ``integral`` (nt, n_servos) is the integral of each servo's error;
        ``voltages`` (nt, n_act) the actuators' (default: the open-loop ones at t)."""
        Q = np.zeros((t.shape[0], self.n_x))
        if self.actuators:
            V = self.voltages(t) if voltages is None else voltages
            Q[:, self.n_rigid:] += V @ self.actuator_B.T
        from .servos import servo_torque

        rates = np.zeros((t.shape[0], len(self.servos)))
        for k in self.driven:
            joint, i = drive_side(self.chain.joints[k]), self.drive_index(k)
            if not is_driven(joint):  # an elastic joint's prescribed motor
                continue
            if isinstance(joint, TorqueDrive):
                Q[:, i] = joint.torque.value(t)
            else:
                s = self.servos.index(k)
                Q[:, i], rates[:, s] = servo_torque(joint, t, p[:, i], pd[:, i], integral[:, s])
        elastic_joints.add_spring_torques(self, p, pd, Q)
        b, nb = self.base, self.n_base
        if b.cart is not None:  # the rail takes the loads across it and their moment
            if len(self.chain.links) in self.servos:  # a servo with an integral
                s = self.servos.index(len(self.chain.links))
                force, rates[:, s] = servo_torque(b.cart.drive, t, p[:, 0], pd[:, 0],
                                                  integral[:, s])
                Q[:, 0] += force
            elif not b.cart.prescribed:
                Q[:, 0] += _cart_force(b.cart.drive, t, p[:, 0], pd[:, 0])
            Q[:, 0] += self.rail_loads(t)
        elif b.kind != "fixed":
            th = p[:, nb - 1]
            for load in b.loads:
                F = np.stack([load.force_x.value(t), load.force_y.value(t)], -1)
                if load.frame == "body":
                    F = np.einsum("tij,tj->ti", rotation(th), F)
                arm = np.einsum("tij,j->ti", rotation(th), np.asarray(load.point, dtype=float))
                Q[:, nb - 1] += load.moment.value(t) + arm[:, 0] * F[:, 1] - arm[:, 1] * F[:, 0]
                if b.kind == "free":
                    Q[:, :2] += F
        return Q, rates

    # -- the coupled equations --------------------------------------------------------------
    def accelerations(self, t: np.ndarray, p_free: np.ndarray, pd_free: np.ndarray,
                      z: np.ndarray, zd: np.ndarray, integral: np.ndarray,
                      voltages: np.ndarray | None = None
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """p̈ of the free rigid coordinates, z̈, and the servo integral rates at times t
        (``voltages``: the actuators', default the open-loop ones).

        K and f are affine in p̈, so the equations are assembled at p̈_free = 0 and at each
        unit p̈_free (a trial axis) and the linear system in (p̈_free, z̈) is solved."""
        nt, nu, n, rig = t.shape[0], len(self.free), self.n, self.n_rigid
        trials = np.concatenate([np.zeros((1, nu)), np.eye(nu)])  # (1 + nu, nu)
        rep = np.repeat
        tt = rep(t, nu + 1)
        pdd_try = np.tile(trials, (nt, 1))
        p, pd, pdd = self.rigid_state(tt, rep(p_free, nu + 1, 0), rep(pd_free, nu + 1, 0),
                                      pdd_try)
        M, C, K, f = (a.reshape((nt, nu + 1) + a.shape[1:]) for a in self.matrices(p, pd, pdd))
        Q, rates = self.applied(t, p[:: nu + 1], pd[:: nu + 1], integral, voltages)
        rows = self.free + list(range(rig, self.n_x))
        zcols = slice(rig, self.n_x)
        A = np.zeros((nt, len(rows), nu + n))
        lin_f = f[:, 1:] - f[:, :1]  # (nt, nu, n_x): ∂f/∂p̈_j
        lin_K = K[:, 1:, :, zcols] - K[:, :1, :, zcols]
        A[:, :, :nu] = np.swapaxes(-lin_f + np.einsum("tjaz,tz->tja", lin_K, z), 1, 2)[:, rows]
        A[:, :, nu:] = M[:, 0][:, rows, zcols]
        rhs = (f[:, 0] + Q - np.einsum("taz,tz->ta", C[:, 0, :, zcols], zd)
               - np.einsum("taz,tz->ta", K[:, 0, :, zcols], z))[:, rows]
        sol = np.linalg.solve(A, rhs[..., None])[..., 0]
        return sol[:, :nu], sol[:, nu:], rates

    def joint_torques(self, p: np.ndarray, pd: np.ndarray, pdd: np.ndarray, z: np.ndarray,
                      zd: np.ndarray, zdd: np.ndarray) -> np.ndarray:
        """Torque each joint's motor applies (nt, N), N·m: the joint row of the equations,
        τ_k = (M ẍ + C ẋ + K x − f)_k with x = [0; z] (plus J_m β̈ of a driven joint)."""
        M, C, K, f = self.matrices(p, pd, pdd)
        zc = slice(self.n_rigid, self.n_x)
        res = (np.einsum("taz,tz->ta", M[:, :, zc], zdd) + np.einsum("taz,tz->ta", C[:, :, zc], zd)
               + np.einsum("taz,tz->ta", K[:, :, zc], z) - f)
        return res[:, self.n_base:self.n_base + len(self.chain.links)]

    def cart_force(self, t: np.ndarray, p: np.ndarray, pd: np.ndarray, pdd: np.ndarray,
                   z: np.ndarray, zd: np.ndarray, zdd: np.ndarray) -> np.ndarray:
        """Force along the rail (nt,), N, that the cart's drive applies at times t: the travel
        row of the equations, (M ẍ + C ẋ + K x − f)_s with x = [0; z] (cart mass included),
        less the base loads along the rail (a force drive's force; what a prescribed travel
        takes). Assembled in blocks of times: the matrices of a whole run need not fit."""
        out = np.empty(t.shape[0])
        zc = slice(self.n_rigid, self.n_x)
        for i in range(0, t.shape[0], 2048):
            b = slice(i, i + 2048)
            M, C, K, f = self.matrices(p[b], pd[b], pdd[b])
            out[b] = (np.einsum("tz,tz->t", M[:, 0, zc], zdd[b])
                      + np.einsum("tz,tz->t", C[:, 0, zc], zd[b])
                      + np.einsum("tz,tz->t", K[:, 0, zc], z[b]) - f[:, 0])
        return out - self.rail_loads(t)


def drive_force(system: ForwardSystem, t: np.ndarray, p: np.ndarray, pd: np.ndarray,
                integral: np.ndarray) -> np.ndarray:
    """The force (nt,), N, of a driven (not prescribed) cart's drive at the solved rigid
    states p, ṗ (nt, n_rigid) and servo integrals (nt, n_servos): its law, as the equations
    apply it (`ForwardSystem.applied`). At accelerations that solve the equations it is the
    travel row `ForwardSystem.cart_force` gives, without assembling the matrices."""
    Q, _ = system.applied(t, p, pd, integral)
    return Q[:, 0] - system.rail_loads(t)


def _cart_force(drive: object, t: np.ndarray, s: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """The force (nt,), N, of a driven cart's drive at travel s (m) and speed ṡ (m/s): its
    force history, or its servo law on the travel without an integral state (one with an
    integral: `ForwardSystem.applied`)."""
    from .servos import servo_torque

    if isinstance(drive, TorqueDrive):
        return drive.torque.value(t)
    return servo_torque(drive, t, s, sd, np.zeros_like(s))[0]  # type: ignore[arg-type]


def momentum(system: ForwardSystem, p: np.ndarray, pd: np.ndarray, z: np.ndarray,
             zd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Linear momentum (nt, 2) in N·s and angular momentum about the origin (nt,) in N·m·s of
    base and links, to first order in z, straight from the kinematics (not the equations):

        ∫ṙ dm = m Ṙ + e(∫ġ dm + ω S(∫X dm + ∫g dm)),
        ∫r×ṙ dm = m R'×V' + R'×(∫ġ + ωS∫(X+g)) + ∫(X+g)dm×V' + h_y·ξ̇ + ω(J + 2 s₁ρx)
                  + J_t(ω + cᵀξ̇),

    with R' = eᵀR, V' = eᵀṘ the origin's position and velocity in frame axes, X = [x, 0],
    g = P̂(x)ξ, ξ = T̂x (docs/derivation.md, "Forward dynamics")."""
    nt = p.shape[0]
    fr = system.frames(p, pd, np.zeros_like(p))
    b, nb = system.base, system.n_base
    x = np.concatenate([np.zeros((nt, system.n_rigid)), z], 1)
    xd = np.concatenate([np.zeros((nt, system.n_rigid)), zd], 1)
    lin = np.zeros((nt, 2))
    ang = np.zeros(nt)
    base_vel = pd[:, :2] if b.kind == "free" else np.zeros((nt, 2))
    base_pos = p[:, :2] if b.kind == "free" else np.zeros((nt, 2))
    w_b = pd[:, nb - 1] if b.turns else np.zeros(nt)
    rail = system._rail()
    if rail is not None:
        base_vel, base_pos = pd[:, :1] * rail, np.asarray(b.position) + p[:, :1] * rail
    if b.kind in ("free", "cart"):
        lin += b.mass * base_vel
        ang += b.mass * _cross(base_pos, base_vel)
    if b.turns:
        ang += b.inertia * w_b
    velocity = np.zeros((nt, len(system.bodies), 2))  # zero-order origin velocities, global
    for k, body in enumerate(system.bodies):
        d = body.data
        if system.attach[k] is not None:
            c = fr.origin[:, k] - base_pos
            velocity[:, k] = base_vel + w_b[:, None] * (c @ TURN.T)
        else:  # the parent's section at hang.x, and a slider's block along its line
            e, w_j = rotation(fr.theta[:, k - 1]), fr.omega[:, k - 1, None]
            velocity[:, k] = velocity[:, k - 1] + system.hang[k - 1].x * w_j * e[:, :, 1]
            if k in system.slides:
                i, u = system.joint_index(k), np.array(system.chain.joints[k].direction)
                velocity[:, k] += np.einsum("tij,tj->ti", e, pd[:, i, None] * u
                                            + w_j * p[:, i, None] * (TURN @ u))
        Th, Th_d, _ = system.xi_maps(fr, k)
        xi = np.einsum("tai,ti->ta", Th, x)
        xi_d = np.einsum("tai,ti->ta", Th, xd) + np.einsum("tai,ti->ta", Th_d, x)
        ny = np.concatenate([[0.0, d.mass, d.first_moment], d.phi_bar])
        # ∫ X × ġ dm = hy·ξ̇, X = [x, y] (a body's centre across the link has y = c_y)
        hy = np.concatenate([[-d.lateral_moment, d.first_moment, d.second_moment], d.phi_tilde])
        nx = body.M0[0]  # ∫ g_x dm = nx·ξ
        w = fr.omega[:, k]
        int_g = np.stack([xi @ nx, xi @ ny], -1)
        int_gd = np.stack([xi_d @ nx, xi_d @ ny], -1)
        int_X = np.stack([np.full(nt, d.first_moment), np.full(nt, d.lateral_moment)], -1)
        inner = int_gd + w[:, None] * ((int_X + int_g) @ TURN.T)  # ∫ġ + ωS(X+g) dm, frame axes
        e = rotation(fr.theta[:, k])
        R = np.einsum("tji,tj->ti", e, fr.origin[:, k])
        V = np.einsum("tji,tj->ti", e, velocity[:, k])
        lin += d.mass * velocity[:, k] + np.einsum("tij,tj->ti", e, inner)
        ang += (d.mass * _cross(R, V) + _cross(R, inner) + _cross(int_X + int_g, V)
                + xi_d @ hy + w * (d.second_moment + 2 * d.first_moment * xi[:, 0]
                                   + 2 * (d.lateral_moment * xi[:, 1] - xi[:, 3:] @ d.lateral_tilde))
                + d.rotary_inertia * (w + xi_d[:, 2]) + xi_d[:, 3:] @ d.rotary_slope)
    return lin, ang


def _cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]
