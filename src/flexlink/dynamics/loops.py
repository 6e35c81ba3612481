"""Closed loops on the first-order forward model: a `ForwardSystem` (the tree: links on
their joints, branches on the base) and the joints that close its loops
(`model.loops.Closure`), as data for the compiled kernels (`_loops_numba.py`, where the
equations are written out).

`LoopSystem` checks what the kernels need before anything runs — enough free joints, independent closure equations, a loop that closes at t = 0 — and chooses the
dependent coordinates: the free joint angles that the closures determine, solved from the
others at every evaluation (coordinate partitioning).
"""

from __future__ import annotations

import functools
from collections import namedtuple
from collections.abc import Callable, Sequence

import numpy as np

from ..errors import SimulationError
from ..model import Closure
from .forward import ForwardSystem
from .forward_kernel import ForwardData, inputs, pack

LoopData = namedtuple("LoopData", [
    "fwd", "kind", "link", "x", "phi", "fore", "to_link", "x_to", "phi_to", "fore_to",
    "ground", "normal", "row", "dep", "tol"])
LoopData.__doc__ = ("Constant arrays of the closures for the kernels: fwd the tree's "
                    "ForwardData; per closure its kind (REVOLUTE, SLIDER), link, point x (m) "
                    "with its mode values and foreshortening matrix ∫₀ˣΦ'ᵀΦ' there, the "
                    "other link (−1: ground) with its point and those, the ground point (m), the slider line's unit normal, its "
                    "first equation row; dep the dependent coordinates (indices into the "
                    "free ones); tol the closure's Newton tolerance (m).")

# |Φ| the projection reaches, relative to the loop's size (the links' total length)
CLOSURE_TOLERANCE = 1e-12
# A dependent joint angle closed farther than this from its guess (rad) has its closure
# checked against the least-squares one from the guesses (`LoopSystem._nearest_branch`).
BRANCH_CHECK = np.radians(30.0)
# The pull of the guesses on a second least-squares closure, per metre of the links (m/rad):
# the residual's minimum, kept near the guesses, lies between them and the branch nearest
# them, from where the projection's Newton steps close the loop on that branch.
PULL_PER_SIZE = 0.3
FORE_POINTS = 48  # Gauss points of ∫₀ˣΦ'ᵀΦ' at a closure's point (the modes: ≤ 20 half-waves)


@functools.cache
def _fore_rule() -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre nodes and weights on [−1, 1] of FORE_POINTS points (computed once)."""
    return np.polynomial.legendre.leggauss(FORE_POINTS)


class LoopSystem:
    """The tree ``system`` with its loop-closing ``closures``.

    Raises SimulationError naming ``closures[i]`` when the loops cannot be held: fewer
    free joints than closure equations, dependent equations, or a loop that
    does not close at t = 0 from the joints' initial angles (the residual in metres)."""

    def __init__(self, system: ForwardSystem, closures: Sequence[Closure],
                 start: bool = True) -> None:
        """``start``: choose the dependent joints and close the loops at t = 0 here (False:
        the caller does, `y0` None: the nonlinear model with a slider in the chain, which
        closes its loops on its own kinematics)."""
        self.system = system
        self.closures = tuple(closures)
        rows = np.cumsum([0] + [c.equations for c in self.closures])
        self.n_c = int(rows[-1])
        if len(system.free) < self.n_c:
            held = ", ".join(f"joint{k + 1}" for k in range(len(system.chain.joints))
                             if system.n_base + k not in system.free)
            raise SimulationError(
                f"closures: {self.n_c} closure equations need as many joints whose angle "
                f"follows from the dynamics (drive = \"free\", \"torque\" or \"servo\"); the "
                f"tree has {len(system.free)}: the mechanism has more drives than degrees of "
                f"freedom, more prescribed joints than degrees of freedom (prescribed: {held})")
        self.size = float(sum(d.length for d in system.modal))
        self.fwd: ForwardData = pack(system)
        self._rows = rows
        self.dep = np.zeros(0, dtype=np.int64)
        self.data = self._pack(np.arange(self.n_c, dtype=np.int64))
        self.y0 = self._closed_start() if start else None

    def _pack(self, dep: np.ndarray) -> LoopData:
        from ._loops_numba import REVOLUTE, SLIDER

        modal, nc = self.system.modal, len(self.closures)
        nm = max(1, max(d.n for d in modal))

        def values(link: int, x: float) -> np.ndarray:
            out = np.zeros(nm)
            if link >= 0 and modal[link].n:
                out[:modal[link].n] = modal[link].shapes.evaluate(np.array([x]))[0]
            return out

        def fore(link: int, x: float) -> np.ndarray:
            out = np.zeros((nm, nm))
            if link >= 0 and modal[link].n:
                g, wg = _fore_rule()
                s = 0.5 * x * (g + 1.0)
                slope = modal[link].shapes.evaluate(s, 1)
                n = modal[link].n
                out[:n, :n] = (slope * (0.5 * x * wg)[:, None]).T @ slope
            return out

        to = [c.to_link if c.to_link is not None else -1 for c in self.closures]
        return LoopData(
            fwd=self.fwd,
            kind=np.array([REVOLUTE if c.kind == "revolute" else SLIDER for c in self.closures],
                          dtype=np.int64),
            link=np.array([c.link for c in self.closures], dtype=np.int64),
            x=np.array([c.x for c in self.closures], dtype=float),
            phi=np.array([values(c.link, c.x) for c in self.closures]).reshape(nc, nm),
            fore=np.array([fore(c.link, c.x) for c in self.closures]).reshape(nc, nm, nm),
            to_link=np.array(to, dtype=np.int64),
            x_to=np.array([c.x_to for c in self.closures], dtype=float),
            phi_to=np.array([values(j, c.x_to) for c, j in zip(self.closures, to)]
                            ).reshape(nc, nm),
            fore_to=np.array([fore(j, c.x_to) for c, j in zip(self.closures, to)]
                             ).reshape(nc, nm, nm),
            ground=np.array([c.ground for c in self.closures], dtype=float).reshape(nc, 2),
            normal=np.array([(-np.sin(c.angle), np.cos(c.angle)) for c in self.closures]
                            ).reshape(nc, 2),
            row=self._rows[:-1].astype(np.int64), dep=np.asarray(dep, dtype=np.int64),
            tol=CLOSURE_TOLERANCE * self.size)

    def workspace(self, n_state: int, calls: bool = True):
        """The kernels' scratch arrays (``calls`` False: for the kinematics kernels only,
        which then compile without the model's residual: `_forward_numba.workspace`)."""
        from ._loops_numba import workspace

        return workspace(self.data, len(self.system.servos), n_state, calls)

    def _closed_start(self) -> np.ndarray:
        """The initial state with the dependent joints (chosen here) closing the loops."""
        from ._loops_numba import close

        equilibrium = self.system.initial == "equilibrium"  # the tree's would leave the loop
        y = self.system._rest_state() if equilibrium else self.system.initial_state()
        u0 = inputs(self.system, np.array([0.0]))[0]
        # kinematics only: the nonlinear model's loops, which start here, never compile
        # this model's residual
        work = self.workspace(y.size, calls=False)
        close(self.data, work, u0, y, 0)
        self.dep = self._dependent(work.G)
        self.data = self.data._replace(dep=np.asarray(self.dep, dtype=np.int64))
        start = y.copy()
        if not close(self.data, work, u0, y, 1) and not self._close_far(work, u0, start, y):
            raise SimulationError(self._open_message(
                self._closest(work, u0, start), "does not close at t = 0 (the residual is "
                "the least its free joints reach from their initial angles)"))
        self._nearest_branch(work, u0, start, y)
        if equilibrium:
            from .loop_equilibrium import closed_equilibrium

            return closed_equilibrium(self, y, u0)
        return y

    def _turned(self) -> np.ndarray:
        """Indices (into the free coordinates) of the dependent revolute joint angles that
        only the closures set: periodic in a turn (a slider's travel, a base coordinate and
        an elastic joint, whose spring reads the angle, are not)."""
        s = self.system
        joints = range(s.n_base, s.n_base + len(s.chain.links))
        return np.array([i for i in self.dep if s.free[i] in joints
                         and s.free[i] - s.n_base not in s.slides
                         and s.free[i] - s.n_base not in s.elastic], dtype=np.int64)

    def _nearest_branch(self, work, u0: np.ndarray, start: np.ndarray, y: np.ndarray) -> None:
        """`nearest_branch` on this model's kinematics (`_close_far`)."""
        nearest_branch(y, start, self._turned(), self.size,
                       lambda other, pull: self._close_far(work, u0, start, other, pull))

    def _close_far(self, work, u0: np.ndarray, start: np.ndarray, y: np.ndarray,
                   pull: float = 0.0) -> bool:
        """Close the loops from a guess too far for the projection's Newton steps: the
        dependent joints alone brought to the least |Φ| (the other free joints keeping their
        angles), then projected. y ← the closed state; False when even that leaves the
        loops open."""
        from ._loops_numba import close

        trial = self._least_residual(work, u0, start, np.asarray(self.dep, dtype=np.int64),
                                     tol=1e-14, gtol=1e-14, pull=pull)
        if not close(self.data, work, u0, trial, 1):
            return False
        y[:] = trial
        return True

    def _closest(self, work, u0: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Φ (m) where the free joints bring it closest to zero (least squares from y)."""
        self._least_residual(work, u0, y, np.arange(len(self.system.free)), tol=1e-12,
                             gtol=1e-8)
        return work.Phi.copy()

    def _least_residual(self, work, u0: np.ndarray, start: np.ndarray, moved: np.ndarray,
                        tol: float, gtol: float, pull: float = 0.0) -> np.ndarray:
        """`least_residual` of ``start``'s free coordinates ``moved`` (indices into the free
        ones); work holds Φ and G there."""
        from ._loops_numba import close

        columns = np.asarray(self.system.free, dtype=np.int64)[moved]

        def evaluate(trial: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            close(self.data, work, u0, trial, 0)
            return work.Phi, work.G[:, columns]

        return least_residual(start, moved, evaluate, tol, gtol, pull)

    def _dependent(self, G: np.ndarray) -> np.ndarray:
        """Indices (into the free coordinates) of the dependent ones: from the last free
        joint backwards, each whose column of G adds to the rank (a driven crank first in
        the tree stays independent)."""
        free = self.system.free
        chosen: list[int] = []
        for j in range(len(free) - 1, -1, -1):
            trial = chosen + [j]
            cols = G[:, [free[i] for i in trial]]
            if np.linalg.matrix_rank(cols, tol=1e-9 * max(1.0, np.abs(G).max())) == len(trial):
                chosen = trial
            if len(chosen) == self.n_c:
                return np.array(sorted(chosen), dtype=np.int64)
        raise SimulationError(self._open_message(
            np.full(self.n_c, np.nan), "has equations the free joints cannot meet (dependent "
            "closure equations, or a mechanism at a singular configuration at t = 0)"))

    def _open_message(self, phi: np.ndarray, why: str) -> str:
        parts = []
        for i, c in enumerate(self.closures):
            res = phi[self._rows[i]:self._rows[i + 1]]
            size = f"residual {np.linalg.norm(res):.3g} m" if np.all(np.isfinite(res)) else ""
            parts.append(f"closures[{i}] ({c.name!r}{', ' + size if size else ''})")
        return ("the mechanism " + why + ": " + "; ".join(parts) + ". Give the free joints' "
                "initial_angle_deg near a closed configuration, or check the closures' "
                "links, points and ground")


def nearest_branch(y: np.ndarray, start: np.ndarray, turned: np.ndarray, size: float,
                   close_far: Callable[[np.ndarray, float], bool]) -> None:
    """y ← the closed state whose dependent joint angles (indices ``turned`` into y) are
    nearest their guesses in ``start``: each turned to within half a turn of its guess
    (Newton's steps from a far guess may close a whole turn or more away), and, where
    Newton's closure left an angle more than BRANCH_CHECK from its guess, the least-squares
    closure from the guesses taken instead if it is nearer (Newton's steps may jump to the
    mechanism's other assembly branch). close_far(state, pull): the state overwritten by the
    least-squares closure from the guesses with the pull (m/rad) towards them, False when
    that leaves the loops open; ``size``: the loop's size (m)."""
    if turned.size == 0:
        return

    def wrapped(state: np.ndarray) -> np.ndarray:
        out = state.copy()
        out[turned] = start[turned] + np.remainder(state[turned] - start[turned] + np.pi,
                                                   2 * np.pi) - np.pi
        return out

    y[:] = wrapped(y)
    if np.max(np.abs(y[turned] - start[turned])) <= BRANCH_CHECK:
        return
    for pull in (0.0, PULL_PER_SIZE * size):
        other = y.copy()
        if close_far(other, pull):
            other = wrapped(other)
            if (np.linalg.norm(other[turned] - start[turned])
                    < np.linalg.norm(y[turned] - start[turned]) - 1e-9):
                y[:] = other


def least_residual(start: np.ndarray, moved: np.ndarray,
                   evaluate: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]],
                   tol: float, gtol: float, pull: float = 0.0) -> np.ndarray:
    """``start`` with its components ``moved`` brought to the least |Φ| by trust-region
    least squares (x and f tolerances ``tol``, gradient ``gtol``); evaluate(state) → Φ (m)
    and its columns over the moved components, left evaluated at the result. ``pull`` > 0
    (m/rad): |Φ|² + pull² |Δ|², Δ the moved components' change, is minimised instead (the
    steps kept near start)."""
    from scipy.optimize import least_squares

    trial = start.copy()

    def residual(values: np.ndarray) -> np.ndarray:
        trial[moved] = values
        phi = evaluate(trial)[0]
        if pull:
            return np.concatenate([phi, pull * (values - start[moved])])
        return phi.copy()

    def jacobian(values: np.ndarray) -> np.ndarray:
        trial[moved] = values
        G = evaluate(trial)[1]
        if pull:
            return np.vstack([G, pull * np.eye(moved.size)])
        return G.copy()

    best = least_squares(residual, start[moved], jac=jacobian, xtol=tol, ftol=tol, gtol=gtol)
    residual(best.x)
    return trial


def closed_states(loops: LoopSystem, t: np.ndarray, states: np.ndarray,
                  u: np.ndarray | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """States at times t projected onto the loops (a copy), their rates (nt, ·: the closed
    mechanism's dy/dt there), the multipliers λ (nt, n_c: force on each closure's point, N,
    global axes; a slider's along its line's normal), the constraint forces' torque on each
    joint's row (nt, N) and the largest |Φ| (nt,), m; ``u``: the input rows at t (default:
    the scenario's; a run with controllers passes its held voltages)."""
    from ._loops_numba import closed_states as kernel

    out = np.ascontiguousarray(states, dtype=float).copy()
    nt = out.shape[0]
    rates = np.empty_like(out)
    lam = np.empty((nt, loops.n_c))
    joint = np.empty((nt, len(loops.system.chain.links)))
    residual = np.empty(nt)
    u = inputs(loops.system, t) if u is None else np.ascontiguousarray(u, dtype=float)
    kernel(loops.data, loops.workspace(out.shape[1]), u, out, rates, lam, joint, residual)
    return out, rates, lam, joint, residual


def difference_steps(system: ForwardSystem, y: np.ndarray, step: float) -> np.ndarray:
    """Central-difference steps for each component of a state y = [p_free, ṗ_free, z, ż,
    integrals] of ``system``: step × max(scale, |y_i|), the scale 1 (rad, m and their rates)
    but for an elastic coordinate z_i the one that turns its link's axis by 1 rad (rms over
    the link, √(L/∫φ_i'² dx), m). A joint angle's step and a mode's then bend the mechanism
    alike: a high clamped mode's coordinate turns the axis by β_i per metre, and several of
    them with the joint angle nearly cancel in the kinetic energy (a near-singular mass
    matrix), so the rates are nonlinear in z on that scale and a step of 1e-6 m biases the
    Jacobian's large entries enough to turn a high mode into a real pair."""
    nu, n = len(system.free), system.n
    scale = np.ones(y.size)
    scale[2 * nu:2 * nu + n] = np.concatenate(
        [np.sqrt(d.length / np.diag(d.foreshortening_tip)) for d in system.modal if d.n]
        or [np.zeros(0)])
    return step * np.maximum(scale, np.abs(y))


def reduced_jacobian(loops: LoopSystem, t: float, y: np.ndarray | None = None,
                     step: float = 1e-6) -> tuple[np.ndarray, np.ndarray]:
    """The Jacobian ∂f/∂y of the closed mechanism's rates at time t (s) and state y (default:
    the closed initial state) over its independent components — the free coordinates not
    dependent on the closures, the elastic ones, their rates (and servo integrals) — by
    central differences of the compiled rates (`difference_steps`); and those components'
    indices into y."""
    y = loops.y0.copy() if y is None else np.asarray(y, dtype=float).copy()
    nu = len(loops.system.free)
    dep = {int(j) for j in loops.dep} | {int(j) + nu for j in loops.dep}
    keep = np.array([i for i in range(y.size) if i not in dep], dtype=int)
    u = inputs(loops.system, np.array([float(t)]))[0]
    from .loop_equilibrium import rates_function

    rates = rates_function(loops, loops.workspace(y.size))
    steps = difference_steps(loops.system, y, step)
    J = np.empty((keep.size, keep.size))
    up, down = np.empty_like(y), np.empty_like(y)
    for c, i in enumerate(keep):
        h = steps[i]
        for sign, out in ((1.0, up), (-1.0, down)):
            trial = y.copy()
            trial[i] += sign * h
            rates(u, trial, out)
        J[:, c] = (up[keep] - down[keep]) / (2 * h)
    return J, keep


def loop_frequencies(loops: LoopSystem, t: float = 0.0, y: np.ndarray | None = None
                     ) -> np.ndarray:
    """Natural frequencies (Hz, ascending, the zero ones of free mechanism motions included)
    of the closed mechanism linearised about time t and state y (default: its closed
    initial state): |Im λ|/2π of the eigenvalues of `reduced_jacobian`, which come in pairs
    ±iω (a free motion: a double zero), one value per pair."""
    J, _ = reduced_jacobian(loops, t, y)
    return np.sort(np.abs(np.linalg.eigvals(J).imag))[::2] / (2 * np.pi)
