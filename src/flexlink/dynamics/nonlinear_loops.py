"""Closed loops on the geometrically nonlinear model: a `NonlinearForwardSystem` (the tree)
and the joints that close its loops (`model.loops.Closure`), as data for the compiled kernels
(`_nonlinear_loops_numba.py`, where the exact closure equations are written out).

The checks before anything runs (enough free joints, independent closure equations), the
choice of the dependent joints and the closed start at t = 0 are the first-order loops'
(`loops.LoopSystem` on the tree's first-order twin ``system.loads``): a
closed loop starts from rest undeformed (q = 0), where the first-order positions are the
exact ones, so the same joint angles close both models.
"""

from __future__ import annotations

from collections import namedtuple
from collections.abc import Sequence

import numpy as np

from ..errors import SimulationError
from ..model import Closure
from .forward_kernel import inputs
from .loops import LoopSystem, least_residual, nearest_branch
from .nonlinear_forward import NonlinearForwardSystem

NonlinearLoopData = namedtuple("NonlinearLoopData", [
    "fwd", "At", "kind", "D", "ground", "normal", "row", "dep", "tol", "B_pres", "offset", "rot_pres",
    "B_joint", "turn", "moving"])
NonlinearLoopData.__doc__ = (
    "Constant arrays of the closures on the nonlinear model: fwd the tree's "
    "NonlinearForwardData; At its Ay transposed (contiguous); per closure its kind (REVOLUTE, SLIDER), D (nodes,) the arc "
    "weights of its point on ``link`` less those of its point on ``to_link`` (none: the "
    "ground), the ground point (m), the slider line's unit normal, its first equation row; "
    "dep the dependent joint angles (indices into y); tol the Newton tolerance (m); B_pres "
    "(nodes, N) and offset (nodes,) the node angles' prescribed part (coefficients on the "
    "prescribed joints' angles, zero columns for the free ones; constant offsets, rad); "
    "rot_pres (n_rot, N) the rotary inertias' coefficients on the prescribed joints; "
    "B_joint (nodes, N) every joint angle's coefficients in the node angles; turn the "
    "column of a turning base's attitude θ_b in y (−1: none), which turns the ground points "
    "and slider lines (given in the base's axes); moving the columns of y whose mass-matrix "
    "columns come from the residual: those that translate the base (a free base's x, y; a "
    "cart's free travel).")



class NonlinearLoopSystem:
    """The nonlinear tree ``system`` with its loop-closing ``closures``.

    Raises SimulationError naming ``closures[i]`` when the loops cannot be held (as
    `loops.LoopSystem`): too few free joints, dependent equations, a loop that
    does not close at t = 0, with its residual in metres)."""

    def __init__(self, system: NonlinearForwardSystem, closures: Sequence[Closure]) -> None:
        self.system = system
        self.closures = tuple(closures)
        # no closures: the open tree on the same kernel (what a sampled controller's run on
        # the nonlinear forward path integrates), from the tree's own initial state
        # with a slider in the chain the first-order loops' kinematics leave its travel out:
        # the dependent joints and the closed start are this model's (`_own_dependent`)
        own = bool(self.closures) and bool(system.slides)
        self.first_order = (LoopSystem(system.loads, self.closures, start=not own)
                            if self.closures else None)
        self.n_c = self.first_order.n_c if self.first_order is not None else 0
        self.size = (self.first_order.size if self.first_order is not None
                     else float(sum(d.length for d in system.modal)))
        if own:
            self._own_dependent()
        self.data = self._pack()
        self.y0 = self._closed_start() if self.first_order is not None else np.concatenate(
            system.initial_state())

    def _pack(self) -> NonlinearLoopData:
        s, lo = self.system, self.first_order
        N = len(s.chain.links)
        joints = slice(s.n_base, s.n_base + N)
        B_joint = np.ascontiguousarray(s.B[:, joints])
        B_pres = B_joint.copy()
        rot_pres = np.ascontiguousarray(s.rot_B[:, joints]).copy()
        for i in s.free:
            if s.n_base <= i < s.n_base + N:
                B_pres[:, i - s.n_base] = 0.0
                rot_pres[:, i - s.n_base] = 0.0
        D = np.zeros((len(self.closures), s.nodes))
        for c, cl in enumerate(self.closures):
            D[c] = s.position_rows(cl.link, np.array([cl.x]))[0]
            if cl.to_link is not None:
                D[c] -= s.position_rows(cl.to_link, np.array([cl.x_to]))[0]
        nc = len(self.closures)
        ground = np.array([c.ground if c.to_link is None else (0.0, 0.0)
                           for c in self.closures], dtype=float).reshape(nc, 2)
        empty = np.zeros(0, dtype=np.int64)
        kind, rows, dep, tol, normal = ((lo.data.kind, lo.data.row, lo.dep, lo.data.tol,
                                         lo.data.normal) if lo is not None else (empty, empty, empty, 1.0,
                                                                     ()))
        normal = np.array(normal, dtype=float).reshape(nc, 2)
        # Ground points and lines are fixed in the base: a cart's constant attitude turns
        # them once here, a turning base's attitude in the kernel.
        c0, s0 = np.cos(s.root_offset), np.sin(s.root_offset)
        turn = np.array([[c0, -s0], [s0, c0]])
        ground, normal = ground @ turn.T, normal @ turn.T
        base = s.base
        attitude = (s.n + s.free.index(s.n_base - 1)) if base.turns else -1
        moving = ([s.n, s.n + 1] if s.translation else [s.n] if s.cart_free else [])
        return NonlinearLoopData(
            fwd=s.kernel_data(), At=np.ascontiguousarray(s.kernel_data().Ay.T), kind=np.asarray(kind, dtype=np.int64),
            D=D, ground=ground,
            normal=np.ascontiguousarray(normal),
            row=np.asarray(rows, dtype=np.int64),
            dep=np.asarray(s.n + dep, dtype=np.int64), tol=float(tol),
            B_pres=B_pres, offset=np.ascontiguousarray(s.offset, dtype=float),
            rot_pres=rot_pres, B_joint=B_joint, turn=int(attitude),
            moving=np.array(moving, dtype=np.int64))

    def _own_dependent(self) -> None:
        """The dependent joints chosen on this model's G at the tree's initial guesses (as
        `LoopSystem._dependent` on the first-order one's)."""
        from ._nonlinear_loops_numba import constraints

        s, lo = self.system, self.first_order
        lo.dep = np.arange(self.n_c, dtype=np.int64)  # a placeholder for packing
        self.data = self._pack()
        work = self.workspace()
        Y = np.zeros(2 * s.n_y)
        start = self._rigid_start()
        Y[s.n:s.n + s.nu], Y[s.n_y + s.n:s.n_y + s.n + s.nu] = start[:s.nu], start[s.nu:2 * s.nu]
        constraints(self.data, work, inputs(s.loads, np.zeros(1))[0], Y)
        G = np.zeros((self.n_c, s.n_rigid))
        G[:, s.free] = work.G[:, s.n:s.n + s.nu]
        lo.dep = lo._dependent(G)
        lo.data = lo._pack(lo.dep)

    def _rigid_start(self) -> np.ndarray:
        """The free rigid coordinates and rates at t = 0 before the nonlinear projection:
        the first-order loops' closed start, or (own start) the tree's as given."""
        lo = self.first_order
        return lo.y0 if lo.y0 is not None else self.system.loads.initial_state()

    def workspace(self):
        from ._nonlinear_loops_numba import workspace

        return workspace(self.data, 2 * self.system.n_y)

    def _closed_start(self) -> np.ndarray:
        """[y, ẏ] at t = 0: the first-order loops' closed start at rest (q = 0, the servo
        integrals zero) carried over, then projected on the exact closures (a check: it
        moves nothing beyond round-off); with ``initial = "equilibrium"`` then moved to
        static equilibrium on the closed loops (`loop_equilibrium`)."""
        from ._nonlinear_loops_numba import project

        s, nu = self.system, self.system.nu
        # the tree's own start at rest (its elastic coordinates and rates as the system
        # gives them); with an equilibrium start the closed loop's equilibrium comes below
        y, v = ((np.zeros(s.n_y), np.zeros(s.n_y)) if s.initial == "equilibrium"
                else s.initial_state())
        start = self._rigid_start()
        y[s.n:s.n + nu], v[s.n:s.n + nu] = start[:nu], start[nu:2 * nu]
        Y = np.concatenate([y, v])
        guesses = Y.copy()
        u0 = inputs(s.loads, np.zeros(1))[0]
        work = self.workspace()
        own = self.first_order.y0 is None
        if not project(self.data, work, u0, Y) and not (own and self._close_far(
                work, u0, guesses, Y)):
            if own:  # its own start: named with the residual
                raise SimulationError(self.first_order._open_message(
                    work.Phi.copy(), "does not close at t = 0 (the residual left by Newton's "
                    "method from the free joints' initial angles)"))
            raise SimulationError("closures: the loop does not close at t = 0 on the "
                                  "nonlinear model's kinematics")
        if own:  # on the branch nearest the guesses, as the first-order loops'
            nearest_branch(Y, guesses, s.n + self.first_order._turned(), self.size,
                           lambda other, pull: self._close_far(work, u0, guesses, other, pull))
            project(self.data, work, u0, Y)  # w: the closed state's Φ, G, γ
        if s.initial == "equilibrium":
            from .loop_equilibrium import closed_nonlinear_equilibrium

            return closed_nonlinear_equilibrium(self, Y, u0)
        return Y


    def _close_far(self, work, u0: np.ndarray, guesses: np.ndarray, Y: np.ndarray,
                   pull: float = 0.0) -> bool:
        """Y ← the loops closed from ``guesses`` by least squares over the dependent joint
        angles (`loops.least_residual`), then Newton's projection; False when that leaves
        them open (as `LoopSystem._close_far` on this model's kinematics)."""
        from ._nonlinear_loops_numba import constraints, project

        dep = np.asarray(self.data.dep, dtype=np.int64)

        def evaluate(trial: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            constraints(self.data, work, u0, trial)
            return work.Phi, work.G[:, dep]

        trial = least_residual(guesses, dep, evaluate, tol=1e-14, gtol=1e-14, pull=pull)
        if not project(self.data, work, u0, trial):
            return False
        Y[:] = trial
        return True


def closed_states(loops: NonlinearLoopSystem, t: np.ndarray, states: np.ndarray,
                  u: np.ndarray | None = None) -> tuple[np.ndarray, ...]:
    """States [y, ẏ] at times t projected onto the loops (a copy) with the input rows ``u``
    (default `forward_kernel.inputs` at t; a controlled run's carry the held voltages),
    ÿ (nt, n_y), the multipliers λ (nt, n_c: force on each closure's point, N, global axes; a slider's along
    its line's normal), the constraint forces' torque on each joint (nt, N; N·m) and the
    largest |Φ| (nt,), m."""
    from ._nonlinear_loops_numba import closed_states as kernel

    out = np.ascontiguousarray(states, dtype=float).copy()
    nt = out.shape[0]
    acc = np.empty((nt, loops.system.n_y))
    lam = np.empty((nt, loops.n_c))
    joint = np.empty((nt, len(loops.system.chain.links)))
    residual = np.empty(nt)
    u = inputs(loops.system.loads, t) if u is None else np.ascontiguousarray(u, dtype=float)
    kernel(loops.data, loops.workspace(), u, out, acc, lam, joint, residual)
    return out, acc, lam, joint, residual

