"""Kinematical synthesis of a chain: zero-order frame motion and first-order frame perturbations.

Frame k is link k's clamped frame. Zero order (rigid, prescribed): angle θ_k = β_1 + … + β_k,
origin at the rigid tip of link k−1. First order: the frame is displaced by ρ_k (components in the
zero-order frame k) and rotated by θ1_k, both linear in the elastic coordinates z:

    [ρx, ρy, θ1]_k = T_k(t) z,   T_1 = 0 (hub at the fixed origin).

Link k's tip in its own frame is displaced by P̃_k ξ_k, ξ_k = [ρx, ρy, θ1, q_k], with
P̃_k = [[1,0,0,0],[0,1,L,Φ(L)],[0,0,1,Φ'(L)]]; frame k+1 is frame k's tip turned by β_{k+1}:
T_{k+1} = blockdiag(A(−β_{k+1}), 1) P̃_k T̂_k. Time derivatives follow analytically
(docs/derivation.md, section "Kinematical synthesis"). Arrays carry a leading time axis.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..model import JointMotion
from ..modes import ModalData


@dataclass(frozen=True)
class JointHistory:
    """Prescribed joint angles, rates and accelerations, shape (nt, N), rad, rad/s, rad/s²."""

    angle: np.ndarray
    rate: np.ndarray
    acceleration: np.ndarray

    @cached_property
    def distinct(self) -> tuple[JointHistory, np.ndarray]:
        """Runs of equal consecutive joint states: the first state of each run and, per time,
        the index of its run. Linear in the number of times (no sort); a state revisited
        after a different one counts as a new run, which costs only one more assembly.
        Computed once per history (histories are shared: `joint_history`)."""
        new = np.ones(self.angle.shape[0], dtype=bool)
        change = new[1:]
        change[:] = False
        # Column by column: numpy's any over axis 1 of an (nt, 3N) array is slower.
        for values in (self.angle, self.rate, self.acceleration):
            for k in range(values.shape[1]):
                column = values[:, k]
                change |= column[1:] != column[:-1]
        kept = np.flatnonzero(new)
        index = np.cumsum(new) - 1
        index.flags.writeable = False
        return JointHistory(self.angle[kept], self.rate[kept], self.acceleration[kept]), index


def joint_history(joints: Sequence[JointMotion], t: np.ndarray,
                  even: JointHistory | None = None) -> JointHistory:
    """Every joint's prescribed angle, rate and acceleration at times t (s), (nt, N) each,
    read-only. Remembered per process for the last few (joints, t): the cases of a sweep over
    link properties share their motions' histories on the output grid and the table's
    first samples. ``even``: the history at t[0::2] if known (t the output times and their
    midpoints, what a coefficient table's rest phases are found on): only t[1::2] is
    evaluated then. A motion evaluates time by time, so the numbers are those of the whole t."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    try:
        key = (tuple(joints), t.shape, t.tobytes())
        cached = _HISTORIES.get(key)
    except TypeError:  # a motion that is not hashable (holds arrays): not remembered
        key, cached = None, None
    if cached is not None:
        _HISTORIES.move_to_end(key)
        return cached
    out = np.empty((3, *t.shape, len(joints)))
    evaluated = t
    if even is not None and t.ndim == 1 and even.angle.shape == ((t.size + 1) // 2, len(joints)):
        for i, known in enumerate((even.angle, even.rate, even.acceleration)):
            for j in range(len(joints)):  # one long strided copy each, not nt short ones
                out[i, 0::2, j] = known[:, j]
        evaluated = t[1::2]
    for j, joint in enumerate(joints):
        for i, values in enumerate(joint.evaluate(evaluated)):
            if evaluated is t:
                out[i, ..., j] = values
            else:
                out[i, 1::2, j] = values
    out.flags.writeable = False  # shared between runs
    history = JointHistory(out[0], out[1], out[2])
    if key is not None and out.nbytes <= _HISTORY_BYTES_KEPT:
        _HISTORIES[key] = history
        held = _held_bytes() + out.nbytes
        while len(_HISTORIES) > _HISTORIES_KEPT or held > _HISTORY_BYTES_KEPT:
            held -= _HISTORIES.popitem(last=False)[1].angle.base.nbytes
        _HELD[:] = [len(_HISTORIES), held]
    return history


def _held_bytes() -> int:
    """The bytes of the remembered histories before the last one added: the running count,
    or their sum when the cache changed otherwise (cleared): a sum over every entry at each
    new history costs a sweep's case tens of µs."""
    if _HELD[0] == len(_HISTORIES) - 1:
        return _HELD[1]
    return sum(h.angle.base.nbytes for h in list(_HISTORIES.values())[:-1])


_HISTORIES: OrderedDict[tuple[object, ...], JointHistory] = OrderedDict()
# a run asks for ~6 time grids, and its coefficient table ~8 more (one per refinement level),
# the same ones in every run of a fit (its runs differ in link properties only)
_HISTORIES_KEPT = 32
# What the remembered histories may hold together: a paper run's grids take ~1 MB; a long run's
# histories (10⁶ samples × 10 joints: 240 MB) are not kept beyond their run.
_HISTORY_BYTES_KEPT = 32_000_000
_HELD = [0, 0]  # entries of _HISTORIES and their bytes after the last addition


def _per_time(maps: np.ndarray, v: np.ndarray) -> np.ndarray:
    """maps[t] @ v[t] for every t: maps (nt, a, i), v (nt, i) → (nt, a)."""
    return np.einsum("tai,ti->ta", maps, v)


@dataclass(frozen=True)
class RowIndex:
    """Which distinct joint state each time has, for maps stored once per distinct state.

    Long runs of one state (rest phases) are applied by one matrix product each, the rest by a
    gather of the few maps they need: gathering every map for every time cost more than the
    whole kinematical synthesis."""

    size: int  # number of times
    runs: tuple[tuple[int, int, int], ...]  # (first time, end time, state) of long runs
    singles: np.ndarray  # times outside long runs
    single_rows: np.ndarray  # their states

    @classmethod
    def from_rows(cls, rows: np.ndarray, long_run: int = 16) -> RowIndex:
        starts = np.flatnonzero(np.diff(rows, prepend=-1) != 0)
        ends = np.append(starts[1:], rows.size)
        long = ends - starts >= long_run
        runs = tuple((int(a), int(b), int(rows[a])) for a, b in zip(starts[long], ends[long]))
        covered = np.zeros(rows.size, dtype=bool)
        for a, b, _ in runs:
            covered[a:b] = True
        singles = np.flatnonzero(~covered)
        return cls(rows.size, runs, singles, rows[singles])

    def apply(self, maps: np.ndarray, v: np.ndarray) -> np.ndarray:
        """maps[state of t] @ v[t] for every time t: maps (states, a, i), v (nt, i) → (nt, a)."""
        out = np.empty((self.size, maps.shape[1]))
        for a, b, row in self.runs:
            out[a:b] = v[a:b] @ maps[row].T
        out[self.singles] = _per_time(maps[self.single_rows], v[self.singles])
        return out


@dataclass(frozen=True)
class FrameMotion:
    """Zero-order motion of every link frame and its first-order perturbation maps.

    theta, omega, alpha: (nt, N) absolute angle (rad), rate, acceleration of frame k.
    origin: (nt, N, 2) global position of frame origins (m).
    origin_accel: (nt, N, 2) origin acceleration in the frame's own axes (m/s²).
    T, T_dot, T_ddot: per link (nt, 3, n_total) maps z → [ρx, ρy, θ1] and their time derivatives;
    with ``rows`` set, one map per distinct joint state instead (apply them with ``apply``).
    """

    theta: np.ndarray
    omega: np.ndarray
    alpha: np.ndarray
    origin: np.ndarray
    origin_accel: np.ndarray
    T: list[np.ndarray]
    T_dot: list[np.ndarray]
    T_ddot: list[np.ndarray]
    rows: RowIndex | None = None

    def apply(self, maps: list[np.ndarray], k: int, v: np.ndarray) -> np.ndarray:
        """maps[k](t) · v(t) at every time, (nt, 3): maps is T, T_dot or T_ddot, v (nt, n)."""
        if self.rows is None:
            return _per_time(maps[k], v)
        return self.rows.apply(maps[k], v)

    def head(self, k: int, z: np.ndarray) -> np.ndarray:
        """[ρx, ρy, θ1] of frame k, T_k z, (nt, 3), for the elastic coordinates z (nt, n)."""
        return self.apply(self.T, k, z)

    def heads(self, k: int, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """T z, Ṫ z + T ż, T̈ z + 2Ṫ ż + T z̈ of frame k, (nt, 3) each: the first three entries
        of ξ_k, ξ̇_k, ξ̈_k (the rows of T̂'s derivatives under q_k are zero)."""
        T, T_d, T_dd = self.T, self.T_dot, self.T_ddot
        return (self.apply(T, k, z), self.apply(T, k, zd) + self.apply(T_d, k, z),
                self.apply(T, k, zdd) + 2 * self.apply(T_d, k, zd) + self.apply(T_dd, k, z))

    def cos_sin(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """cos θ_k, sin θ_k at every time, (nt,) each."""
        return np.cos(self.theta[:, k]), np.sin(self.theta[:, k])

    def at_rows(self, rows: np.ndarray) -> FrameMotion:
        """This motion, computed once per distinct joint state, at times whose state indices
        are ``rows``: the small arrays are expanded, the maps stay per state (``apply``)."""
        return FrameMotion(self.theta[rows], self.omega[rows], self.alpha[rows],
                           self.origin[rows], self.origin_accel[rows],
                           self.T, self.T_dot, self.T_ddot, RowIndex.from_rows(rows))


@dataclass(frozen=True)
class SolvedFrames(FrameMotion):
    """The frame motion along one solved run: instead of the maps T, Ṫ, T̈ (left empty) their
    products with that run's z, ż, z̈, computed at each output time by a compiled kernel
    (dynamics/prescribed_kernel.py). ``head``/``heads`` answer for those very arrays only.

    solution: the (z, ż, z̈) arrays the products belong to; heads: T z, Ṫ z + T ż,
    T̈ z + 2Ṫ ż + T z̈, each (nt, N, 3); torques: the joint torques along the solution,
    computed with the frames (dynamics/prescribed_kernel.py); turns: cos θ, sin θ (nt, N, 2),
    if known (the kernel computes them once per joint state: per time in numpy they cost
    more than the tip paths' arithmetic)."""

    solution: tuple[np.ndarray, np.ndarray, np.ndarray] = field(kw_only=True)
    heads_: tuple[np.ndarray, np.ndarray, np.ndarray] = field(kw_only=True)
    torques: np.ndarray | None = field(default=None, kw_only=True)  # (nt, N), N·m, if known
    turns: np.ndarray | None = field(default=None, kw_only=True)  # (nt, N, 2), if known

    def cos_sin(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        if self.turns is None:
            return super().cos_sin(k)
        return self.turns[:, k, 0], self.turns[:, k, 1]

    def head(self, k: int, z: np.ndarray) -> np.ndarray:
        if z is not self.solution[0]:
            raise ValueError("SolvedFrames know T z only for the solution they were built for")
        return self.heads_[0][:, k]

    def heads(self, k: int, z: np.ndarray, zd: np.ndarray, zdd: np.ndarray
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if any(a is not b for a, b in zip((z, zd, zdd), self.solution)):
            raise ValueError("SolvedFrames know ξ only for the solution they were built for")
        return self.heads_[0][:, k], self.heads_[1][:, k], self.heads_[2][:, k]

    def apply(self, maps: list[np.ndarray], k: int, v: np.ndarray) -> np.ndarray:
        raise ValueError("SolvedFrames keep no maps: use head or heads")


def rotation(angle: np.ndarray) -> np.ndarray:
    """Planar rotation matrices A(angle), shape (..., 2, 2)."""
    # Filled in place: np.stack costs more than the arithmetic at the single-time calls of
    # the forward dynamics' right-hand side.
    c, s = np.cos(angle), np.sin(angle)
    out = np.empty(np.shape(angle) + (2, 2))
    out[..., 0, 0] = c
    out[..., 0, 1] = -s
    out[..., 1, 0] = s
    out[..., 1, 1] = c
    return out


TURN = np.array([[0.0, -1.0], [1.0, 0.0]])  # 90° turn: S v = ẑ × v


def tip_map(data: ModalData) -> np.ndarray:
    """P̃: ξ = [ρx, ρy, θ1, q] → tip displacement (frame axes) and tip rotation, (3, 3+n)."""
    return section_map(data.length, data.tip_value, data.tip_slope)


def section_map(x: float, value: np.ndarray, slope: np.ndarray) -> np.ndarray:
    """P̃(x): ξ = [ρx, ρy, θ1, q] → displacement (frame axes) and rotation of the section at
    x (m) along the link, whose mode shapes there are ``value`` (n,) and their slopes
    ``slope`` (n,, 1/m); (3, 3 + n)."""
    n = value.size
    P = np.zeros((3, 3 + n))
    P[0, 0] = 1.0
    P[1, 1] = 1.0
    P[1, 2] = x
    P[1, 3:] = value
    P[2, 2] = 1.0
    P[2, 3:] = slope
    return P


def inertial_acceleration(acceleration: np.ndarray, gravity: Sequence[float]) -> np.ndarray:
    """The base's linear acceleration as the kinematical synthesis takes it: a − g, global
    axes (m/s²), for its acceleration a (…, 2) and the uniform field g = [gx, gy].

    This is where gravity enters the first-order model (numpy; `_forward_numba.
    base_acceleration` compiled). By the equivalence principle a uniform field g acts on
    every mass element as an acceleration −g of the reference frame: every inertia term —
    link, tip body, outboard load, second-order (geometric) stiffness, joint torque, the free
    base's own m p̈ — is built from the synthesised frame accelerations, so giving the base
    a − g in place of a adds every gravity load once (docs/derivation.md §11)."""
    return np.asarray(acceleration, dtype=float) - np.asarray(gravity, dtype=float)


def frame_motion(
    joints: JointHistory, modal: list[ModalData], offsets: list[int], n_total: int,
    gravity: Sequence[float] = (0.0, 0.0),
) -> FrameMotion:
    """Zero-order frame kinematics and first-order perturbation maps for all links; the hub
    is fixed at the origin in a uniform field ``gravity`` (m/s², global axes)."""
    beta, beta_d, beta_dd = joints.angle, joints.rate, joints.acceleration
    nt, n_links = beta.shape
    theta = np.cumsum(beta, axis=1)
    omega = np.cumsum(beta_d, axis=1)
    alpha = np.cumsum(beta_dd, axis=1)

    origin = np.zeros((nt, n_links, 2))
    origin_accel = np.zeros((nt, n_links, 2))
    if any(gravity):  # the fixed hub's acceleration −g, in frame 1's axes
        base = inertial_acceleration(np.zeros(2), gravity)
        origin_accel[:, 0] = np.einsum("tji,j->ti", rotation(theta[:, 0]), base)
    T = [np.zeros((nt, 3, n_total))]
    T_dot = [np.zeros((nt, 3, n_total))]
    T_ddot = [np.zeros((nt, 3, n_total))]
    for k in range(n_links - 1):
        data = modal[k]
        L = data.length
        e_k = rotation(theta[:, k])
        origin[:, k + 1] = origin[:, k] + L * e_k[:, :, 0]
        # Acceleration of frame k's rigid tip, frame-k axes, then turned into frame k+1.
        tip_acc = origin_accel[:, k] + L * np.stack([-omega[:, k] ** 2, alpha[:, k]], -1)
        back = rotation(-beta[:, k + 1])
        origin_accel[:, k + 1] = np.einsum("tij,tj->ti", back, tip_acc)

        P = tip_map(data)
        sl = slice(offsets[k], offsets[k] + data.n)
        U, U_d, U_dd = (_tip_displacement_map(P, Tk, sl) for Tk in (T[k], T_dot[k], T_ddot[k]))
        # The elastic part of T̂ is constant: only U (not U_d, U_dd) carries it.
        U_d -= _elastic_part(P, sl, n_total)
        U_dd -= _elastic_part(P, sl, n_total)

        bd, bdd = beta_d[:, k + 1], beta_dd[:, k + 1]
        R = block_map(back)
        R_d = block_map(-bd[:, None, None] * (TURN @ back), corner=0.0)
        R_dd = block_map((-bdd[:, None, None] * TURN - (bd**2)[:, None, None] * np.eye(2)) @ back, 0.0)
        T.append(R @ U)
        T_dot.append(R_d @ U + R @ U_d)
        T_ddot.append(R_dd @ U + 2.0 * R_d @ U_d + R @ U_dd)
    return FrameMotion(theta, omega, alpha, origin, origin_accel, T, T_dot, T_ddot)


def _elastic_part(P: np.ndarray, sl: slice, n_total: int) -> np.ndarray:
    out = np.zeros((3, n_total))
    out[:, sl] = P[:, 3:]
    return out


def _tip_displacement_map(P: np.ndarray, T_k: np.ndarray, sl: slice) -> np.ndarray:
    """P̃ T̂_k for T̂_k = [T_k; E_k] without forming E_k: (nt, 3, n_total)."""
    out = np.einsum("ij,tjn->tin", P[:, :3], T_k)
    out[:, :, sl] += P[:, 3:]
    return out


def block_map(A2: np.ndarray, corner: float = 1.0) -> np.ndarray:
    """blockdiag(A2, corner) for a stack of 2×2 matrices, (nt, 3, 3)."""
    out = np.zeros(A2.shape[:-2] + (3, 3))
    out[..., :2, :2] = A2
    out[..., 2, 2] = corner
    return out
