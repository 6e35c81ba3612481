"""Forward dynamics of the geometrically nonlinear model (docs/nonlinear.md §7): a fixed,
pinned or free base or a cart on a rail, prescribed and driven joints, branches on the base.

The rigid coordinates are more generalized coordinates of the same Lagrangian. Every section
angle stays linear in all coordinates with constant coefficients,

    α_j = A_j q + B_j p + α0_j,   p = [base x, y, attitude θ_b (as the base moves), β₁ … β_N],

and every point sits at r_p = R_b + Σ_j W_pj e(α_j), R_b the base's reference point (moving
only on a free base). The turn of a branch's attachment point c is one more "node" of the
node axis: its angle θ_b + arg c (B row on θ_b, constant α0), its weight |c| in the W row of
every point of the branch. With G = Wᵀ diag(m) W, s = Wᵀ m and m_tot = Σ m (the base's mass
is a point with an empty W row) the generalized inertia forces are

    Aᵀ ũ (on q) and B_freeᵀ ũ (on the free p),   ũ_j = u_j + s_j e⊥(α_j)·R̈_b,
    u_j = Σ_l G_jl [cos(α_j − α_l) α̈_l + sin(α_j − α_l) α̇_l²],
    F = m_tot R̈_b + Σ_l s_l [e⊥(α_l) α̈_l − e(α_l) α̇_l²]     (on R_b),

(a cart: R_b = R_0 + s e along its rail's direction e, its generalized force e·F on s when
s is free, s̈ an input when prescribed), plus J α̈ of the rotary inertias (tip inertias, the base's inertia on θ_b, motor inertias on
their β_k). Applied forces (drive torques, servo laws, base loads) are the first-order forward
model's (`ForwardSystem.applied`, dynamics/servos.py): the same rigid coordinates.

The unknowns y = [q, p_free, σ]: σ per servo with an integrator, σ̇ = the integral of its
error, σ̈ = the integral's rate, so that the second-order collocation of solvers/gauss_forward.py
integrates it too; its residual row is σ̈ − (servo law's integral rate).
This module is the numpy reference; `_nonlinear_forward_numba.py` is the same residual
compiled (tests/unit/test_nonlinear_forward.py compares them).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import Base, Chain, PiezoActuator, is_driven
from ..model.settings import InitialName
from .arc import ArcQuadrature, arc_quadrature
from .elastic_joints import spring_energy, spring_frequency
from .forward import ForwardSystem
from .nonlinear_bodies import body_nodes, body_rows
from .nonlinear_kernel import (
    NonlinearForwardData,
    StageInputs,
    coupling_weights,
    forward_data,
    stage_rows,
)
from .prismatic import sliders

RIGID_POINTS = 2  # Gauss points of a link without modes


@dataclass(frozen=True, eq=False)
class ForwardArc:
    """Quadrature of one link on the node axis."""

    quad: ArcQuadrature
    nodes: slice  # its Gauss nodes
    coords: slice  # its q_k in q
    dphi: np.ndarray  # (p, n_k) Φ′ at the nodes, 1/m


class NonlinearForwardSystem:
    """Constant matrices of the nonlinear model with rigid coordinates; evaluations take a
    leading batch axis."""

    def __init__(self, chain: Chain, base: Base | None = None,
                 actuators: Sequence[PiezoActuator] = (),
                 gravity: Sequence[float] = (0.0, 0.0), initial: InitialName = "rest") -> None:
        """``gravity``: uniform field [gx, gy] (m/s², global axes), entering as the base
        point's acceleration R̈_b − g (`_inertia`); ``initial``: "rest" or "equilibrium"
        (`initial_state`)."""
        base = Base() if base is None else base
        self.chain, self.base = chain, base
        self.gravity = np.array([float(gravity[0]), float(gravity[1])])
        self.initial = initial
        # Rigid bookkeeping, initial state and applied loads (piezo actuators included: their
        # force B V on q is the same function in both models, ψ = Φ′q being exact): the
        # first-order forward model's (its gravity: the kernels read it from its data).
        self.loads = ForwardSystem(chain, base, actuators=actuators, gravity=gravity)
        self.chain = chain = self.loads.chain  # a slider's block: a body at its link's root
        self.actuators = self.loads.actuators
        self.modal = self.loads.modal
        N = len(chain.links)
        offsets = np.concatenate([[0], np.cumsum([d.n for d in self.modal])]).astype(int)
        self.n = n = int(offsets[-1])
        self.n_base = nb = self.loads.n_base
        self.n_rigid = nr = self.loads.n_rigid
        self.free = list(self.loads.free)
        self.nu = len(self.free)
        self.servos = list(self.loads.servos)
        self.integrating = [s for s, k in enumerate(self.servos)
                            if getattr(self.loads.servo_of(k)[0], "integrator", False)]
        self.ns = len(self.servos)
        self.n_y = n + self.nu + self.ns
        attitude = nb - 1 if base.turns else None

        # Node axis: every link's Gauss nodes, then one node per offset attachment point.
        self.arcs: list[ForwardArc] = []
        start = 0
        for k, d in enumerate(self.modal):
            # A rigid link's nodes share one angle: its positions are x e(α) and its mass
            # moments up to ∫x² dm, which two Gauss points integrate exactly.
            quad = arc_quadrature(d.length, float(d.shapes.beta_l.max(initial=0.0)),
                                  points_per_panel=RIGID_POINTS if d.n == 0 else None,
                                  breaks=getattr(d.shapes, "breaks", ()))
            self.arcs.append(ForwardArc(quad, slice(start, start + quad.size),
                                        slice(int(offsets[k]), int(offsets[k + 1])),
                                        d.shapes.evaluate(quad.x, 1)))
            start += quad.size
        self.attach = [base.attachment(k) for k in range(N)]
        self.pivot: dict[int, int] = {}  # branch root link → its attachment node
        for k, c in enumerate(self.attach):
            if c is not None and np.hypot(*c) > 0.0:
                self.pivot[k] = start
                start += 1
        # A slider's line (dynamics/prismatic.py): one node turned by the axis angle from the
        # parent's section at the line's point (its tip by default), its length the travel s
        # (`line_weights`); link k's root sits at that point of the exactly deformed parent.
        self.slides = sliders(chain.joints)
        self.line_node = {}
        for k in self.slides:
            self.line_node[k] = start
            start += 1
        bodies = start  # then one node per body offset along its section
        self.nodes = nodes = start + body_nodes(chain)
        A = np.zeros((nodes, n))
        B = np.zeros((nodes, nr))
        self.offset = np.zeros(nodes)
        self.root_A = np.zeros((N, n))  # clamped-frame angle of each link, on q
        self.root_B = np.zeros((N, nr))  # … on p
        self.tip_A = np.zeros((N, n))
        self.tip_B = np.zeros((N, nr))
        self.root_W = np.zeros((N, nodes))  # root position − R_b = root_W ρ e(α)
        self.link_offset = np.zeros(N)  # the sliders' link angles in each clamped frame, rad
        for k, (arc, d) in enumerate(zip(self.arcs, self.modal)):
            c = self.attach[k]
            if c is not None:
                if attitude is not None:
                    self.root_B[k, attitude] = 1.0
                if k in self.pivot:
                    j = self.pivot[k]
                    B[j] = self.root_B[k]
                    self.offset[j] = np.arctan2(c[1], c[0])
                    self.root_W[k, j] = np.hypot(*c)
            else:
                self.root_A[k], self.root_B[k] = self.tip_A[k - 1], self.tip_B[k - 1]
                self.root_W[k] = self.root_W[k - 1]
                self.root_W[k, self.arcs[k - 1].nodes] = self.arcs[k - 1].quad.w
                self.link_offset[k] = self.link_offset[k - 1]
                hang = self.loads.hang[k - 1]
                if hang.x != self.modal[k - 1].length:  # a slider's line inside the parent
                    self.root_A[k] = self.root_A[k - 1].copy()
                    self.root_A[k, self.arcs[k - 1].coords] += hang.slope
                    self.root_W[k, self.arcs[k - 1].nodes] = \
                        self.arcs[k - 1].quad.cumulative(np.array([hang.x]))[0]
            if k in self.line_node:  # link k rides its parent's line: no angle of its own
                joint, j = chain.joints[k], self.line_node[k]
                A[j], B[j] = self.root_A[k], self.root_B[k]
                self.offset[j] = self.link_offset[k - 1] + joint.axis_angle
                self.root_W[k, j] = 1.0
                self.link_offset[k] += joint.link_angle
            else:
                self.root_B[k, nb + k] += 1.0
            self.offset[arc.nodes] = self.link_offset[k]
            A[arc.nodes] = self.root_A[k]
            A[arc.nodes, arc.coords] = arc.dphi
            B[arc.nodes] = self.root_B[k]
            self.tip_A[k] = self.root_A[k]
            self.tip_A[k, arc.coords] += d.tip_slope
            self.tip_B[k] = self.root_B[k]
        # A cart's constant attitude turns every link and pivot (rad).
        self.root_offset = base.attitude if base.cart is not None else 0.0
        self.offset += self.root_offset
        self.A, self.B = A, B

        # Point masses (beam quadrature, the bodies' centres, a free base's mass) and rotary
        # inertias (the bodies', the base's on θ_b, motors' on their joint angle).
        rows, masses = [], []
        rot_A, rot_B, rot_J, absolute = [], [], [], []
        for k, (arc, link, d) in enumerate(zip(self.arcs, chain.links, self.modal)):
            rows.append(self.position_rows(k, arc.quad.x))
            masses.append(link.mass_per_length * arc.quad.w)
            body = body_rows(link, d, arc.coords, self.root_A[k], self.root_B[k],
                             lambda x, k=k: self.position_rows(k, x), bodies)
            rows.append(body.W)
            masses.append(body.mass)
            A[body.nodes], B[body.nodes] = body.node_A, body.node_B
            self.offset[body.nodes] = body.node_offset + self.link_offset[k]
            bodies += len(body.nodes)
            rot_A.extend(body.rot_A)
            rot_B.extend(body.rot_B)
            rot_J.extend(body.rot_J)
            absolute.extend([True] * body.rot_J.size)  # they turn with their section
        if base.kind in ("free", "cart") and base.mass > 0.0:
            rows.append(np.zeros((1, nodes)))
            masses.append(np.array([base.mass]))
        if attitude is not None and base.inertia > 0.0:
            rot_A.append(np.zeros(n))
            rot_B.append(np.eye(nr)[attitude])
            rot_J.append(base.inertia)
            absolute.append(True)
        for k, joint in enumerate(chain.joints):
            if is_driven(joint) and joint.motor_inertia > 0.0:  # type: ignore[union-attr]
                rot_A.append(np.zeros(n))
                rot_B.append(np.eye(nr)[nb + k])
                rot_J.append(joint.motor_inertia)  # type: ignore[union-attr]
                absolute.append(False)  # turns with β_k relative to its parent
        for k in self.loads.elastic:  # an elastic joint's rotor: ½ J_m θ̇_m² (Spong)
            rot_A.append(np.zeros(n))
            rot_B.append(np.eye(nr)[self.loads.motor_index(k)])
            rot_J.append(chain.joints[k].rotor_inertia)  # type: ignore[union-attr]
            absolute.append(False)
        self.W = np.vstack(rows)
        self.point_mass = np.concatenate(masses)
        self.G = coupling_weights(self.W, self.point_mass)
        self.s = self.W.T @ self.point_mass
        self.m_tot = float(self.point_mass.sum())
        # explicit row counts: with every link rigid (n = 0) the -1 of reshape is undefined
        self.rot_A = np.array(rot_A, dtype=float).reshape(len(rot_A), n)
        self.rot_B = np.array(rot_B, dtype=float).reshape(len(rot_B), nr)
        self.rot_J = np.array(rot_J, dtype=float)
        self.rot_absolute = np.array(absolute, dtype=bool)
        self.K = np.zeros((n, n))
        self.D = np.zeros((n, n))
        for arc, d in zip(self.arcs, self.modal):
            self.K[arc.coords, arc.coords] = d.stiffness_matrix
            self.D[arc.coords, arc.coords] = d.damping_matrix

        # Columns on y = [q, p_free, σ]; the prescribed joints are inputs.
        self.prescribed = [i for i in range(nb, nr) if i not in self.free]
        self.Ay = np.zeros((nodes, self.n_y))
        self.Ay[:, :n] = A
        self.Ay[:, n:n + self.nu] = B[:, self.free]
        self.rot_y = np.zeros((self.rot_J.size, self.n_y))
        self.rot_y[:, :n] = self.rot_A
        self.rot_y[:, n:n + self.nu] = self.rot_B[:, self.free]
        self.translation = base.kind == "free"  # y[n], y[n + 1] are the base's x, y
        # A cart: its rail direction, and whether its travel s is y[n] (else an input).
        self.rail = None if base.cart is None else np.array(base.cart.direction)
        self.cart_free = base.cart is not None and not base.cart.prescribed
        # Each slider's line node, the column of its travel in y (−1: prescribed, an input)
        # and its prescribed travel's input columns (s, ṡ, s̈: `forward_kernel.inputs`).
        self.lines = np.array([self.line_node[k] for k in self.slides], dtype=np.int64)
        self.line_col = np.array([n + self.free.index(nb + k) if nb + k in self.free else -1
                                  for k in self.slides], dtype=np.int64)
        self.line_u = np.array([[k, N + k, 2 * N + k] for k in self.slides],
                               dtype=np.int64).reshape(len(self.slides), 3)

    # -- geometry -----------------------------------------------------------------------------
    def position_rows(self, k: int, x: np.ndarray) -> np.ndarray:
        """W rows (len(x), nodes): r(x on link k) − R_b = Σ_j W_j e(α_j), global axes (m)."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        out = np.repeat(self.root_W[k][None, :], x.size, axis=0)
        out[:, self.arcs[k].nodes] = self.arcs[k].quad.cumulative(x)
        return out

    def rigid_state(self, t: np.ndarray, y: np.ndarray, v: np.ndarray, a: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Full p, ṗ, p̈ (b, n_rigid) from y, ẏ, ÿ: free coordinates solved, joints prescribed."""
        n, nu = self.n, self.nu
        return self.loads.rigid_state(t, y[:, n:n + nu], v[:, n:n + nu], a[:, n:n + nu])

    def free_travels(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`ForwardSystem.free_travels` with the columns in y (m) (copies of the system's:
        the step loop checks them after every batch)."""
        if not hasattr(self, "_free_travels"):
            columns, lo, hi = self.loads.free_travels()
            self._free_travels = (columns + self.n, lo, hi)
        return tuple(x.copy() for x in self._free_travels)  # type: ignore[return-value]

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """y and ẏ at t = 0: the rigid coordinates as given (servos on their reference), the
        links undeformed, at rest but for their initial modal rates, the servo integrals
        zero."""
        start = self.loads.initial_state()
        y, v = np.zeros(self.n_y), np.zeros(self.n_y)
        y[self.n:self.n + self.nu] = start[:self.nu]
        v[self.n:self.n + self.nu] = start[self.nu:2 * self.nu]
        v[:self.n] = start[2 * self.nu + self.n:2 * (self.nu + self.n)]  # initial modal rates
        if self.initial == "equilibrium":
            y, v = self._equilibrium(y, v)
        return y, v

    def _equilibrium(self, y: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """y, ẏ with q, and each servo-held joint (its angle, or its integral σ̇ if it has
        an integrator), at rest in static equilibrium at t = 0: q̈ and those joints' β̈
        vanish (as ForwardSystem.equilibrium_state; `equilibrium.solve`)."""
        from . import equilibrium

        n, nu = self.n, self.nu
        in_y, in_v, rows = list(range(n)), [], list(range(n))
        for s, k in enumerate(self.servos):
            servo, i = self.loads.servo_of(k)
            j = n + self.free.index(i)
            rows.append(j)
            if servo.integrator:
                in_v.append(n + nu + s)
            else:
                in_y.append(j)
        for k in self.loads.elastic:  # the link held by its spring
            rows.append(n + self.free.index(self.n_base + k))
            in_y.append(rows[-1])
        cut = len(in_y)
        columns, watched = self.loads.unheld()
        rows += [n + j for j in columns]

        def residuals(x: np.ndarray) -> np.ndarray:
            Y, V = np.repeat(y[None], x.shape[0], 0), np.repeat(v[None], x.shape[0], 0)
            Y[:, in_y], V[:, in_v] = x[:, :cut], x[:, cut:]
            return self.accelerations(np.zeros(x.shape[0]), Y, V)[:, rows]

        x = equilibrium.solve(residuals, np.concatenate([y[in_y], v[in_v]]), watched)
        y, v = y.copy(), v.copy()
        y[in_y], v[in_v] = x[:cut], x[cut:]
        return y, v

    def from_solution(self, solution: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """y, ẏ, ÿ (nt, n_y) from a Solution of coordinates [p_free, q] with the servo
        integrals as ``extra`` (σ itself and σ̈ are not kept: zero)."""
        n, nu = self.n, self.nu
        out = []
        for i, x in enumerate((solution.q, solution.q_dot, solution.q_ddot)):
            y = np.zeros((x.shape[0], self.n_y))
            y[:, :n], y[:, n:n + nu] = x[:, nu:], x[:, :nu]
            if i == 1 and self.ns:
                y[:, n + nu:] = solution.extra
            out.append(y)
        return out[0], out[1], out[2]

    def stage_inputs(self, t: np.ndarray, reuse: StageInputs | None = None) -> StageInputs:
        """The prescribed parts of the motion and the load inputs at times t (b,), s.
        ``reuse``: rows of an earlier call for at least b times, whose parts that do not
        depend on time (every joint free: the nodes' constant angles, zero rates and
        accelerations) are returned as views of its first b rows instead of made again (a
        caller that only reads them, as the step loops: writing the nodes' rows of one
        batch of steps costs more than its inputs)."""
        from .forward_kernel import inputs

        t = np.asarray(t, dtype=float)
        if not self.prescribed:  # every joint free: the nodes' constant angles alone
            u = inputs(self.loads, t)
            if reuse is not None and reuse.u.shape[0] >= t.size:
                return StageInputs(*(x[:t.size] for x in reuse[:4]), u)
            shape = (t.size, self.nodes)
            return StageInputs(np.broadcast_to(self.offset, shape).copy(), np.zeros(shape),
                               np.zeros(shape), np.zeros((t.size, self.rot_J.size)), u)
        zero = np.zeros((t.size, self.nu))
        p, pd, pdd = self.loads.rigid_state(t, zero, zero, zero)
        Bp = self.B[:, self.prescribed]
        rot = self.rot_B[:, self.prescribed]
        pres = [a[:, self.prescribed] for a in (p, pd, pdd)]
        return StageInputs(pres[0] @ Bp.T + self.offset, pres[1] @ Bp.T, pres[2] @ Bp.T,
                           pres[2] @ rot.T, inputs(self.loads, t))

    # -- equations ----------------------------------------------------------------------------
    def line_weights(self, y: np.ndarray, v: np.ndarray, a: np.ndarray, inp: StageInputs
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each node's length ρ and its rate and acceleration (b, nodes): 1, 0, 0 except on a
        slider's line, where they are its travel s, ṡ, s̈ (m, m/s, m/s²): y's when free, the
        input rows' when prescribed."""
        shape = y.shape[:-1] + (self.nodes,)
        rho, rho_d, rho_dd = np.ones(shape), np.zeros(shape), np.zeros(shape)
        for i, (node, col) in enumerate(zip(self.lines, self.line_col)):
            for r, (out, x) in enumerate(zip((rho, rho_d, rho_dd), (y, v, a))):
                out[..., node] = x[..., col] if col >= 0 else inp.u[..., self.line_u[i, r]]
        return rho, rho_d, rho_dd

    def _inertia(self, y: np.ndarray, v: np.ndarray, a: np.ndarray, inp: StageInputs
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, tuple[np.ndarray, ...],
                            np.ndarray]:
        """ũ (b, nodes), the translation force F (b, 2) and the rotary torques J α̈ (b, n_rot)
        of the motion y, ẏ, ÿ; the node angles, rates, accelerations; and the inertia force
        along each slider's line (b, n_lines), N (gravity included)."""
        alpha = y @ self.Ay.T + inp.angle
        alpha_d = v @ self.Ay.T + inp.rate
        alpha_dd = a @ self.Ay.T + inp.acceleration
        c, s = np.cos(alpha), np.sin(alpha)
        rho, rho_d, rho_dd = self.line_weights(y, v, a, inp)
        # a_j = ρ(α̈ e⊥ − α̇² e) + 2ρ̇α̇ e⊥ + ρ̈ e = T e⊥ − R e; F_j = Σ_l G_jl a_l
        tangential = rho * alpha_dd + 2.0 * rho_d * alpha_d
        radial = rho * alpha_d**2 - rho_dd
        g = [(x @ self.G) for x in (c * tangential, s * tangential, c * radial, s * radial)]
        u = c * (g[0] - g[3]) + s * (g[1] + g[2])  # e⊥_j·F_j (G symmetric)
        Fx, Fy = -(g[1] + g[2]), g[0] - g[3]
        F = np.zeros(y.shape[:-1] + (2,))
        # The base point's acceleration minus gravity (global axes): where the field enters
        # this model (equivalence principle), as −g on a base that does not translate.
        Rdd = np.broadcast_to(-self.gravity, y.shape[:-1] + (2,))
        if self.translation:
            n = self.n
            Rdd = a[..., n:n + 2] + Rdd
        if self.rail is not None:
            Rdd = self._cart_acceleration(a, inp)[..., None] * self.rail + Rdd
        if self.translation or self.rail is not None or self.gravity.any():
            u = u + self.s * (-s * Rdd[..., :1] + c * Rdd[..., 1:])
            Fx, Fy = Fx + self.s * Rdd[..., :1], Fy + self.s * Rdd[..., 1:]
        line = (c * Fx + s * Fy)[..., self.lines]  # e_l·F_l on each slider's travel
        u = rho * u
        if self.translation or self.rail is not None:
            F = self.m_tot * Rdd + np.stack([(-s * tangential - c * radial) @ self.s,
                                             (c * tangential - s * radial) @ self.s], -1)
        rot = (a @ self.rot_y.T + inp.rot_acceleration) * self.rot_J
        return u, F, rot, (alpha, alpha_d, alpha_dd), line

    def _cart_acceleration(self, a: np.ndarray, inp: StageInputs) -> np.ndarray:
        """A cart's s̈ (b,), m/s²: y's when its travel is free, else its input column."""
        return a[..., self.n] if self.cart_free else inp.u[..., -2]

    def applied(self, t: np.ndarray, y: np.ndarray, v: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
        """Applied generalized forces on the free rigid coordinates (b, nu) and the servo
        integral rates (b, ns): ForwardSystem.applied at the solved rigid state."""
        p, pd, _ = self.rigid_state(t, y, v, np.zeros_like(y))
        integral = v[:, self.n + self.nu:]
        Q, rates = self.loads.applied(t, p, pd, integral)
        return Q[:, self.free], rates

    def residual(self, t: np.ndarray, y: np.ndarray, v: np.ndarray, a: np.ndarray,
                 inp: StageInputs) -> np.ndarray:
        """Inertia + damping + elastic − applied forces on y (b, n_y), and on σ the
        difference of σ̈ and the integral rate: zero on a solution."""
        n, nu = self.n, self.nu
        u, F, rot, _, line = self._inertia(y, v, a, inp)
        out = u @ self.Ay + rot @ self.rot_y
        free = self.line_col >= 0
        out[:, self.line_col[free]] += line[:, free]  # a free travel: the force along its line
        out[:, :n] += v[:, :n] @ self.D + y[:, :n] @ self.K
        if self.translation:
            out[:, n:n + 2] += F
        if self.cart_free:  # the inertia force along the rail on s
            out[:, n] += F @ self.rail
        Q, rates = self.applied(t, y, v)
        out[:, n:n + nu] -= Q
        if self.actuators:  # B V on q, V the input rows' voltages (a closed loop's held ones)
            from .forward_kernel import voltage_columns

            out[:, :n] -= inp.u[:, voltage_columns(self.loads)] @ self.loads.actuator_B.T
        out[:, n + nu:] = a[:, n + nu:] - rates
        return out

    def accelerations(self, t: np.ndarray, y: np.ndarray, v: np.ndarray,
                      compiled: bool = True) -> np.ndarray:
        """ÿ (b, n_y) at times t (b,): the residual is affine in ÿ, so M's columns are its
        changes under unit accelerations. ``compiled``: the numba kernel, else numpy."""
        inp = self.stage_inputs(t)
        if compiled:
            from ._nonlinear_forward_numba import accelerations

            return accelerations(self.kernel_data(), np.ascontiguousarray(y, dtype=float),
                                 np.ascontiguousarray(v, dtype=float), *stage_rows(*inp))
        b, m = y.shape[0], self.n_y
        trials = np.concatenate([np.zeros((1, m)), np.eye(m)])
        rep = np.repeat
        index = rep(np.arange(b), m + 1)
        R = self.residual(t[index], y[index], v[index], np.tile(trials, (b, 1)),
                          StageInputs(*(x[index] for x in inp))).reshape(b, m + 1, m)
        M = np.swapaxes(R[:, 1:] - R[:, :1], 1, 2)
        return np.linalg.solve(M, -R[:, 0][..., None])[..., 0]

    def kernel_data(self) -> NonlinearForwardData:
        """The constant arrays for the compiled kernels, with the first-order model's
        ForwardData of the applied loads (cached)."""
        if not hasattr(self, "_kernel_data"):
            from . import forward_kernel

            c = np.ascontiguousarray
            self._kernel_data = forward_data({
                "Ay": c(self.Ay), "G": c(self.G), "s": c(self.s), "m_tot": self.m_tot,
                "translation": bool(self.translation), "rot_y": c(self.rot_y),
                "rot_J": c(self.rot_J), "Dq": c(self.D), "Kq": c(self.K), "n": self.n,
                "nu": self.nu, "gravity": c(self.gravity, dtype=float),
                "cart": 0 if self.rail is None else (1 if self.cart_free else 2),
                "rail": np.zeros(2) if self.rail is None else c(self.rail, dtype=float),
                "line_node": c(self.lines), "line_col": c(self.line_col),
                "line_u": c(self.line_u)},
                forward_kernel.pack(self.loads))
        return self._kernel_data

    # -- readings -----------------------------------------------------------------------------
    def joint_torques(self, t: np.ndarray, y: np.ndarray, v: np.ndarray, a: np.ndarray,
                      compiled: bool = True, inp: StageInputs | None = None) -> np.ndarray:
        """Torque each joint's motor applies (b, N), N·m: the generalized inertia force of β_k
        (with the motor inertia; for a driven joint equal to its drive torque); a slider's
        column: the force along its line, N (the drive's, or what a prescribed travel takes).
        ``compiled``: the numba kernel, else numpy; ``inp``: stage_inputs(t) if known."""
        joints = slice(self.n_base, self.n_base + len(self.chain.links))
        inp = self.stage_inputs(t) if inp is None else inp
        if compiled:
            from ._nonlinear_forward_numba import joint_torques

            m, c = self.n + self.nu, np.ascontiguousarray
            rows = m + np.asarray(self.slides, dtype=np.int64)  # each line's force: its joint
            rot_joint = np.hstack([self.rot_y[:, :m], self.rot_B[:, joints]])
            rot_joint[:, rows] = 0.0  # a slider's column is its line's force alone
            out = np.empty((y.shape[0], len(self.chain.links)))
            joint_torques(self.kernel_data(), c(np.hstack([self.Ay[:, :m], self.B[:, joints]])),
                          c(rot_joint), rows, c(y, dtype=float), c(v, dtype=float),
                          c(a, dtype=float), *stage_rows(*inp), out)
            return out
        u, _, rot, _, line = self._inertia(y, v, a, inp)
        out = u @ self.B[:, joints] + rot @ self.rot_B[:, joints]
        out[:, self.slides] = line
        return out

    def cart_force(self, t: np.ndarray, y: np.ndarray, v: np.ndarray, a: np.ndarray,
                   inp: StageInputs | None = None) -> np.ndarray:
        """Force along the rail (b,), N, that a cart's drive applies: the inertia force of
        the whole system along the rail (gravity included) less the base loads along it
        (``inp``: stage_inputs(t) if known)."""
        _, F, _, _, _ = self._inertia(y, v, a, self.stage_inputs(t) if inp is None else inp)
        return F @ self.rail - self.loads.rail_loads(t)

    def node_motion(self, t: np.ndarray, y: np.ndarray, v: np.ndarray, a: np.ndarray,
                    inp: StageInputs | None = None) -> tuple[np.ndarray, ...]:
        """α, α̇, α̈ at the nodes (b, nodes) and R_b, Ṙ_b, R̈_b (b, 2) (zero unless free;
        ``inp``: stage_inputs(t) if known)."""
        inp = self.stage_inputs(t) if inp is None else inp
        alphas = (y @ self.Ay.T + inp.angle, v @ self.Ay.T + inp.rate,
                  a @ self.Ay.T + inp.acceleration)
        n = self.n
        trans = tuple(x[:, n:n + 2] if self.translation else np.zeros((x.shape[0], 2))
                      for x in (y, v, a))
        if self.rail is not None:
            p, pd, pdd = self.rigid_state(t, y, v, a)
            trans = (np.asarray(self.base.position) + p[:, :1] * self.rail,
                     pd[:, :1] * self.rail, pdd[:, :1] * self.rail)
        return alphas + trans

    def point_motion(self, t: np.ndarray, y: np.ndarray, v: np.ndarray,
                     inp: StageInputs | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities (b, points, 2) of the point masses, global (m, m/s)
        (``inp``: stage_inputs(t) if known)."""
        zero = np.zeros_like(y)
        inp = self.stage_inputs(t) if inp is None else inp
        alpha, alpha_d, _, R, Rd, _ = self.node_motion(t, y, v, zero, inp)
        rho, rho_d, _ = self.line_weights(y, v, zero, inp)
        c, s = np.cos(alpha), np.sin(alpha)
        r = np.stack([(rho * c) @ self.W.T, (rho * s) @ self.W.T], -1) + R[:, None]
        rate = rho * alpha_d
        rd = np.stack([(rho_d * c - s * rate) @ self.W.T, (rho_d * s + c * rate) @ self.W.T],
                      -1) + Rd[:, None]
        return r, rd

    def rotary_rates(self, t: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Rates (b, n_rot) of the rotary inertias, rad/s."""
        _, pd, _ = self.loads.rigid_state(t, v[:, self.n:self.n + self.nu],
                                          v[:, self.n:self.n + self.nu],
                                          np.zeros((t.size, self.nu)))
        return v[:, :self.n] @ self.rot_A.T + pd @ self.rot_B.T

    def energy(self, t: np.ndarray, y: np.ndarray, v: np.ndarray) -> tuple[np.ndarray,
                                                                           np.ndarray]:
        """Kinetic (rotors included) and elastic energy (b,), J: the links' strain energy
        and the elastic joints' springs."""
        _, rd = self.point_motion(t, y, v)
        kinetic = 0.5 * (np.einsum("bpi,bpi,p->b", rd, rd, self.point_mass)
                         + self.rotary_rates(t, v)**2 @ self.rot_J)
        q = y[:, :self.n]
        strain = 0.5 * np.einsum("bi,ij,bj->b", q, self.K, q)
        if self.loads.elastic:
            p, _, _ = self.rigid_state(t, y, v, np.zeros_like(y))
            strain = strain + spring_energy(self.loads, p)
        return kinetic, strain

    def potential(self, t: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Gravitational potential energy −Σ m_p g·r_p (b,), J (zero at the origin's
        height)."""
        r, _ = self.point_motion(t, y, np.zeros_like(y))
        return -np.einsum("bpi,p,i->b", r, self.point_mass, self.gravity)

    def momentum(self, t: np.ndarray, y: np.ndarray, v: np.ndarray,
                 inp: StageInputs | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Linear momentum (b, 2), N·s, and angular momentum about the origin (b,), N·m·s,
        exact, from the kinematics: Σ m ṙ, Σ m r × ṙ + J α̇ of the tip and base inertias (a
        motor's rotor turns with its joint angle relative to its parent: ∂L/∂θ̇_b has no
        share of it, as in the first-order model; ``inp``: stage_inputs(t) if known)."""
        r, rd = self.point_motion(t, y, v, inp)
        linear = np.einsum("bpi,p->bi", rd, self.point_mass)
        angular = np.einsum("bp,p->b", r[..., 0] * rd[..., 1] - r[..., 1] * rd[..., 0],
                            self.point_mass)
        absolute = self.rot_absolute
        rates = self.rotary_rates(t, v)
        return linear, angular + rates[:, absolute] @ self.rot_J[absolute]

    def root_frames(self, t: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Rigid frames (the links straight at the solved base pose and joint angles): origins
        (b, N, 2), m, and angles (b, N), rad."""
        zero = np.zeros_like(y)
        p, _, _ = self.rigid_state(t, y, zero, zero)
        nb = self.n_base
        b, N = y.shape[0], len(self.chain.links)
        R = p[:, :2] if self.base.kind == "free" else np.zeros((b, 2))
        th_b = p[:, nb - 1] if self.base.turns else np.full(b, self.base.attitude)
        if self.rail is not None:
            R = np.asarray(self.base.position) + p[:, :1] * self.rail
        origin, angle = np.zeros((b, N, 2)), np.zeros((b, N))
        for k, c in enumerate(self.attach):
            if c is not None:
                cb, sb = np.cos(th_b), np.sin(th_b)
                origin[:, k] = R + np.stack([cb * c[0] - sb * c[1], sb * c[0] + cb * c[1]], -1)
                angle[:, k] = th_b + p[:, nb + k]
            else:
                L = self.loads.hang[k - 1].x  # the tip, or a slider's line point
                origin[:, k] = origin[:, k - 1] + L * np.stack(
                    [np.cos(angle[:, k - 1]), np.sin(angle[:, k - 1])], -1)
                angle[:, k] = angle[:, k - 1] + p[:, nb + k]
                if k in self.line_node:  # on the block, along the line
                    joint = self.chain.joints[k]
                    line = angle[:, k - 1] + joint.axis_angle
                    origin[:, k] += p[:, nb + k, None] * np.stack([np.cos(line), np.sin(line)],
                                                                   -1)
                    angle[:, k] = angle[:, k - 1] + joint.link_angle
        return origin, angle

    @property
    def max_frequency(self) -> float:
        """Highest clamped natural frequency of any link, or of an elastic joint's spring
        (`elastic_joints.spring_frequency`), rad/s."""
        from ..modes import highest_frequency

        return max(highest_frequency(self.modal), spring_frequency(self.loads))

