"""Geometrically nonlinear assumed-modes model of a chain (docs/nonlinear.md).

Each link is an inextensible Euler–Bernoulli beam whose cross-section rotation relative to its
clamped frame is ψ_k(x, t) = Φ_k′(x) q_k(t). Link k is clamped at link k−1's actual tip, turned
by β_k from its actual tip section. The absolute angle of every section is therefore *linear*
in the coordinates, with constant coefficients:

    α(s) = A(s) q + B(s) β,

and every position is an arc integral r(s) = ∫ e(α) dσ, e = (cos, sin), along the chain. On the
Gauss nodes j of all links (α_j = A_j q + B_j β) a point p is at r_p = Σ_j W_pj e(α_j), W a
constant matrix of (cumulative) quadrature weights. With G = Wᵀ diag(m_p) W the generalized
inertia forces of the point masses m_p (beam quadrature masses and tip masses) are

    Σ_p m_p (∂r_p/∂q)ᵀ r̈_p = Aᵀ u,
    u_j = Σ_l G_jl [cos(α_j − α_l) α̈_l + sin(α_j − α_l) α̇_l²],

and the tip rotary inertias add J_t a_tᵀ α̈_t. The same u with Bᵀ in place of Aᵀ is the vector
of joint torques. The bending energy ½∫EI ψ′² dx = ½ qᵀ K q has the linear model's constant K.
All evaluations take a leading batch axis (times or states).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..model import Chain, PiezoActuator
from ..model.settings import InitialName
from ..modes import highest_frequency
from .actuators import actuator_matrix, open_loop_voltages
from .arc import ArcQuadrature, arc_quadrature
from .first_order import chain_modal_data
from .kinematics import JointHistory, joint_history
from .nonlinear_bodies import body_nodes, body_rows
from .nonlinear_kernel import NonlinearData, StageInputs, coupling_weights, stage_rows


@dataclass(frozen=True)
class NodeInputs:
    """The prescribed joint motion carried to the nodes (B β, B β̇, B β̈) and to the tip
    sections (B_t β̈), for a batch of times: (b, nodes) and (b, N), rad, rad/s, rad/s²; and
    the applied generalized forces on q (b, n): the actuators' B V (N·m)."""

    angle: np.ndarray
    rate: np.ndarray
    acceleration: np.ndarray
    tip_acceleration: np.ndarray
    load: np.ndarray

    def __getitem__(self, index: int | slice) -> NodeInputs:
        return NodeInputs(self.angle[index], self.rate[index], self.acceleration[index],
                          self.tip_acceleration[index], self.load[index])

    def stage_inputs(self, load: np.ndarray | None = None) -> StageInputs:
        """The rows as the compiled kernels take them (`NonlinearData`: the tips are the
        rotary inertias, u the loads on q); ``load`` in place of the open-loop one."""
        return stage_rows(self.angle, self.rate, self.acceleration, self.tip_acceleration,
                          self.load if load is None else load)


@dataclass(frozen=True, eq=False)
class LinkArc:
    """Quadrature of one link on the chain's node axis."""

    quad: ArcQuadrature
    nodes: slice  # this link's Gauss nodes on the chain's node axis
    coords: slice  # this link's q_k in q
    dphi: np.ndarray  # (p, n_k) Φ′ at the nodes, 1/m
    ddphi: np.ndarray  # (p, n_k) Φ″ at the nodes, 1/m²


class NonlinearSystem:
    """The assembled nonlinear model: constant matrices, evaluated on batches of states."""

    def __init__(self, chain: Chain, panels: int | None = None,
                 points_per_panel: int | None = None,
                 actuators: Sequence[PiezoActuator] = (),
                 gravity: Sequence[float] = (0.0, 0.0), initial: InitialName = "rest") -> None:
        """``gravity``: uniform field [gx, gy] (m/s², global axes), the hub's acceleration
        −g in the inertia forces of every point mass (`base_moments`); ``initial``: the
        links at t = 0 undeformed ("rest") or in static equilibrium (`initial_coordinates`)."""
        # The basis (mode shapes, K, modal damping) is the first-order model's.
        self.chain = chain
        self.gravity = np.array([float(gravity[0]), float(gravity[1])])
        self.initial = initial
        self.modal = chain_modal_data(chain)
        # Piezo actuators: B V on q, the same function as in the first-order model (the moment
        # pair's virtual work M δ(ψ(x_e) − ψ(x_s)) with ψ = Φ′q exact here).
        self.actuators = tuple(actuators)
        self.actuator_B = actuator_matrix(self.actuators, self.modal)  # (n, n_act), N·m/V
        offsets = np.concatenate([[0], np.cumsum([d.n for d in self.modal])]).astype(int)
        self.n = int(offsets[-1])
        n_links = len(chain.links)
        self.arcs: list[LinkArc] = []
        start = 0
        for k, d in enumerate(self.modal):
            quad = arc_quadrature(d.length, float(d.shapes.beta_l.max(initial=0.0)), panels,
                                  points_per_panel)
            coords = slice(int(offsets[k]), int(offsets[k + 1]))
            self.arcs.append(LinkArc(quad, slice(start, start + quad.size), coords,
                                     d.shapes.evaluate(quad.x, 1), d.shapes.evaluate(quad.x, 2)))
            start += quad.size
        self.nodes = start + body_nodes(chain)  # the beams' nodes, then the bodies'

        # Section angles: rows of A (on q) and B (on β) for every node and every link tip.
        self.A = np.zeros((self.nodes, self.n))
        self.B = np.zeros((self.nodes, n_links))
        self.angle0 = np.zeros(self.nodes)  # constant angle offsets (bodies' nodes), rad
        self.tip_A = np.zeros((n_links, self.n))
        self.tip_B = np.zeros((n_links, n_links))
        base = np.zeros(self.n)  # angle of link k's clamped frame, on q
        for k, (arc, d) in enumerate(zip(self.arcs, self.modal)):
            self.A[arc.nodes] = base
            self.A[arc.nodes, arc.coords] = arc.dphi
            self.B[arc.nodes, : k + 1] = 1.0
            base = base.copy()
            base[arc.coords] = d.tip_slope
            self.tip_A[k] = base
            self.tip_B[k, : k + 1] = 1.0
        self.root_A = np.vstack([np.zeros(self.n), self.tip_A[:-1]])  # clamped-frame angles

        # Point masses (beam quadrature masses, the bodies' centres) and the bodies' rotary
        # inertias: from here on tip_A, tip_B, tip_inertia are the rotary rows.
        rows, masses, rotary = [], [], []
        node = start
        for k, (arc, link, d) in enumerate(zip(self.arcs, chain.links, self.modal)):
            rows.append(self.position_rows(k, arc.quad.x))
            masses.append(link.mass_per_length * arc.quad.w)
            body = body_rows(link, d, arc.coords, self.root_A[k], self.tip_B[k],
                             lambda x, k=k: self.position_rows(k, x), node)
            rows.append(body.W)
            masses.append(body.mass)
            self.A[body.nodes], self.B[body.nodes] = body.node_A, body.node_B
            self.angle0[body.nodes] = body.node_offset
            node += len(body.nodes)
            rotary.append(body)
        self.tip_A = np.vstack([b.rot_A for b in rotary])
        self.tip_B = np.vstack([b.rot_B for b in rotary])
        self.W = np.vstack(rows)
        self.point_mass = np.concatenate(masses)
        self.R = np.sqrt(self.point_mass)[:, None] * self.W
        self.G = coupling_weights(self.W, self.point_mass)
        self.lift = self.W.T @ self.point_mass  # the mass each node's direction carries, kg
        self.tip_inertia = np.concatenate([b.rot_J for b in rotary])
        self._At = np.ascontiguousarray(self.A.T)
        self._tip_At = np.ascontiguousarray(self.tip_A.T)

        self.K = np.zeros((self.n, self.n))
        self.D = np.zeros((self.n, self.n))
        for arc, d in zip(self.arcs, self.modal):
            self.K[arc.coords, arc.coords] = d.stiffness_matrix
            self.D[arc.coords, arc.coords] = d.damping_matrix

    # -- geometry -----------------------------------------------------------------------------
    def position_rows(self, k: int, x: np.ndarray) -> np.ndarray:
        """W rows (len(x), nodes): r(x on link k) = Σ_j W_j e(α_j), global frame (m)."""
        x = np.atleast_1d(np.asarray(x, dtype=float))
        out = np.zeros((x.size, self.nodes))
        for arc in self.arcs[:k]:
            out[:, arc.nodes] = arc.quad.w
        out[:, self.arcs[k].nodes] = self.arcs[k].quad.cumulative(x)
        return out

    def point_jacobian(self, k: int, x: float, q: np.ndarray, beta: np.ndarray) -> np.ndarray:
        """∂r/∂q (b, 2, n) of the point x (m) of link k: Σ_j W_j e⊥(α_j) A_j (global axes)."""
        row = self.position_rows(k, np.array([x]))[0]
        alpha = self.node_angles(q, beta)
        jx = (-np.sin(alpha) * row) @ self.A
        jy = (np.cos(alpha) * row) @ self.A
        return np.stack([jx, jy], axis=-2)

    def joint_history(self, t: np.ndarray) -> JointHistory:
        """Prescribed joint angles, rates, accelerations at times t (s)."""
        return joint_history(self.chain.joints, t)

    def node_angles(self, q: np.ndarray, beta: np.ndarray) -> np.ndarray:
        """α at every node, (b, nodes), rad (a body's node: its section's angle turned to
        the body's centre, `angle0`)."""
        return q @ self.A.T + beta @ self.B.T + self.angle0

    def node_rates(self, qd: np.ndarray, beta_dot: np.ndarray) -> np.ndarray:
        """α̇ (or α̈ from q̈, β̈) at every node, (b, nodes)."""
        return qd @ self.A.T + beta_dot @ self.B.T

    # -- equations ----------------------------------------------------------------------------
    def _kernel(self, c: np.ndarray, s: np.ndarray, vectors: list[np.ndarray]) -> list[np.ndarray]:
        """For each v (b, nodes): Σ_l G_jl cos(α_j − α_l) v_l and Σ_l G_jl sin(α_j − α_l) v_l."""
        stacked = np.stack([c * v for v in vectors] + [s * v for v in vectors], -1)
        g = self.G @ stacked  # (b, nodes, 2m)
        m = len(vectors)
        gc, gs = g[..., :m], g[..., m:]
        out = []
        for i in range(m):
            out.append(c * gc[..., i] + s * gs[..., i])  # cos part
            out.append(s * gc[..., i] - c * gs[..., i])  # sin part
        return out

    def mass_matrix(self, alpha: np.ndarray) -> np.ndarray:
        """M(q, β) (b, n, n), kg·m² per coordinate unit."""
        c, s = np.cos(alpha), np.sin(alpha)
        Yc = self.R @ (c[..., None] * self.A)
        Ys = self.R @ (s[..., None] * self.A)
        M = np.swapaxes(Yc, -1, -2) @ Yc + np.swapaxes(Ys, -1, -2) @ Ys
        return M + np.einsum("k,ki,kj->ij", self.tip_inertia, self.tip_A, self.tip_A)

    def inertia_load(self, alpha: np.ndarray, alpha_dot: np.ndarray,
                     beta_ddot: np.ndarray) -> np.ndarray:
        """u_j with α̈ = Bβ̈ (the part of the inertia forces not proportional to q̈), (b, nodes)."""
        c, s = np.cos(alpha), np.sin(alpha)
        cos_b, _, _, sin_v = self._kernel(c, s, [beta_ddot @ self.B.T, alpha_dot**2])
        return cos_b + sin_v + self.base_moments(c, s)

    def base_moments(self, c: np.ndarray, s: np.ndarray) -> np.ndarray:
        """The nodes' share of the inertia forces of the hub's acceleration a = −g (the fixed
        hub in the field g: equivalence principle), lift_j e⊥(α_j)·a, (b, nodes), from cos α,
        sin α of the nodes: where gravity enters the nonlinear model (numpy; compiled:
        `_nonlinear_numba.inertia_elastic`)."""
        ax, ay = -self.gravity
        if ax == 0.0 and ay == 0.0:
            return np.zeros(c.shape)
        return self.lift * (c * ay - s * ax)

    def initial_coordinates(self) -> np.ndarray:
        """q at t = 0 (n,): zero, or with ``initial = "equilibrium"`` the static deflection
        under the loads at t = 0 (the residual at rest vanishes: Newton, `equilibrium.solve`)."""
        if self.initial != "equilibrium" or self.n == 0:
            return np.zeros(self.n)
        from . import equilibrium

        inputs = self.node_inputs(np.zeros(1))

        def residuals(q: np.ndarray) -> np.ndarray:
            index = np.zeros(q.shape[0], dtype=int)
            rest = np.zeros_like(q)
            return self.residual(q, rest, rest, inputs[index])

        return equilibrium.solve(residuals, np.zeros(self.n))

    def kernel_data(self) -> NonlinearData:
        """The constant arrays for the compiled kernels: every rigid coordinate prescribed,
        the tips' inertias the rotary ones (cached)."""
        if not hasattr(self, "_kernel_data"):
            c = np.ascontiguousarray
            self._kernel_data = NonlinearData(
                Ay=c(self.A, dtype=float), G=c(self.G, dtype=float), s=c(self.lift, dtype=float),
                m_tot=float(self.point_mass.sum()), translation=False,
                rot_y=c(self.tip_A, dtype=float), rot_J=c(self.tip_inertia, dtype=float),
                Dq=c(self.D, dtype=float), Kq=c(self.K, dtype=float), n=self.n, nu=0,
                gravity=c(self.gravity, dtype=float), cart=0, rail=np.zeros(2),
                line_node=np.zeros(0, dtype=np.int64), line_col=np.zeros(0, dtype=np.int64),
                line_u=np.zeros((0, 3), dtype=np.int64))
        return self._kernel_data

    def voltages(self, t: np.ndarray) -> np.ndarray:
        """Open-loop actuator voltages (b, n_act), V, clipped to the limits."""
        return open_loop_voltages(self.actuators, t)

    def forces(self, q: np.ndarray, qd: np.ndarray, beta: np.ndarray, beta_dot: np.ndarray,
               beta_ddot: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """M (b, n, n) and f (b, n) of M q̈ = f: f = −Aᵀu₀ − J_t a_t (b_t β̈) − D q̇ − K q
        (without the applied loads)."""
        alpha = self.node_angles(q, beta)
        alpha_dot = self.node_rates(qd, beta_dot)
        u0 = self.inertia_load(alpha, alpha_dot, beta_ddot)
        rot = (beta_ddot @ self.tip_B.T) * self.tip_inertia
        f = -(u0 @ self.A + rot @ self.tip_A + qd @ self.D + q @ self.K)
        return self.mass_matrix(alpha), f

    def accelerations(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray,
                      compiled: bool = True, load: np.ndarray | None = None) -> np.ndarray:
        """q̈ (b, n) from the equations of motion at times t (b,), s. ``compiled``: the numba
        kernel (numba is a dependency), or the numpy expressions it is tested against.
        ``load`` (b, n): the applied forces on q (default: the open-loop actuators')."""
        if compiled:
            from . import _nonlinear_numba as compiled_kernels  # numba: only when used

            inputs = self.node_inputs(t)
            if load is not None:
                inputs = NodeInputs(inputs.angle, inputs.rate, inputs.acceleration,
                                    inputs.tip_acceleration, load)
            return compiled_kernels.accelerations(
                self.kernel_data(), *(np.ascontiguousarray(a, dtype=float) for a in (
                    q, qd, inputs.angle, inputs.rate, inputs.acceleration,
                    inputs.tip_acceleration, inputs.load)))
        hist = self.joint_history(t)
        M, f = self.forces(q, qd, hist.angle, hist.rate, hist.acceleration)
        f = f + (self.voltages(t) @ self.actuator_B.T if load is None else load)
        return np.linalg.solve(M, f[..., None])[..., 0]

    def node_inputs(self, t: np.ndarray, hist: JointHistory | None = None) -> NodeInputs:
        """The joint prescriptions at times t (b,) (or their given history) on the nodes and
        tips, and the open-loop actuators' forces."""
        hist = self.joint_history(t) if hist is None else hist
        return NodeInputs(hist.angle @ self.B.T + self.angle0, hist.rate @ self.B.T,
                          hist.acceleration @ self.B.T, hist.acceleration @ self.tip_B.T,
                          self.voltages(t) @ self.actuator_B.T)

    def _inertia(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                 inputs: NodeInputs) -> tuple[np.ndarray, np.ndarray]:
        """u (b, nodes) and the tip torques J_t α̈_t (b, N) of the full motion."""
        alpha = q @ self._At + inputs.angle
        alpha_dot = qd @ self._At + inputs.rate
        alpha_ddot = qdd @ self._At + inputs.acceleration
        c, s = np.cos(alpha), np.sin(alpha)
        v = alpha_dot**2
        stacked = np.stack([c * alpha_ddot, s * alpha_ddot, c * v, s * v])  # (4, b, nodes)
        g = (stacked.reshape(-1, self.nodes) @ self.G).reshape(stacked.shape)  # G symmetric
        g = np.moveaxis(g, 0, -1)
        # u = c∘G(c∘α̈) + s∘G(s∘α̈) + s∘G(c∘α̇²) − c∘G(s∘α̇²)
        u = c * (g[..., 0] - g[..., 3]) + s * (g[..., 1] + g[..., 2]) + self.base_moments(c, s)
        tip = (qdd @ self._tip_At + inputs.tip_acceleration) * self.tip_inertia
        return u, tip

    def residual(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                 inputs: NodeInputs) -> np.ndarray:
        """Generalized inertia + damping + elastic − applied forces (b, n): zero on a
        solution."""
        u, tip = self._inertia(q, qd, qdd, inputs)
        return u @ self.A + tip @ self.tip_A + qd @ self.D + q @ self.K - inputs.load

    def joint_torques(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                      hist: JointHistory | None = None) -> np.ndarray:
        """Motor torque of every joint (b, N), N·m: the generalized inertia force of β_k."""
        u, tip = self._inertia(q, qd, qdd, self.node_inputs(t, hist))
        return u @ self.B + tip @ self.tip_B

    def energy(self, t: np.ndarray, q: np.ndarray, qd: np.ndarray) -> tuple[np.ndarray,
                                                                            np.ndarray]:
        """Kinetic and elastic energy (b,), J."""
        hist = self.joint_history(t)
        alpha = self.node_angles(q, hist.angle)
        alpha_dot = self.node_rates(qd, hist.rate)
        vx = -np.sin(alpha) * alpha_dot @ self.R.T
        vy = np.cos(alpha) * alpha_dot @ self.R.T
        tip_rate = qd @ self.tip_A.T + hist.rate @ self.tip_B.T
        kinetic = 0.5 * (np.sum(vx**2 + vy**2, -1) + tip_rate**2 @ self.tip_inertia)
        return kinetic, 0.5 * np.einsum("bi,ij,bj->b", q, self.K, q)

    def potential(self, t: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Gravitational potential energy −Σ m_p g·r_p (b,), J (zero with the hub's point at
        the origin's height)."""
        alpha = self.node_angles(q, self.joint_history(t).angle)
        r = np.stack([np.cos(alpha) @ self.W.T, np.sin(alpha) @ self.W.T], -1)
        return -np.einsum("bpi,p,i->b", r, self.point_mass, self.gravity)

    @property
    def max_frequency(self) -> float:
        """Highest clamped natural frequency of any link, rad/s."""
        return highest_frequency(self.modal)
