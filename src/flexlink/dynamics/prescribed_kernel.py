"""The prescribed-joint model as data for the compiled kernels of the forward dynamics.

With a fixed base and every joint prescribed, the forward equations (`dynamics/forward.py`,
compiled in `_forward_numba.py`) are the first-order model of `FirstOrderSystem` in their
elastic rows and the inverse-dynamics joint torques of `dynamics/torques.py` in their joint
rows (tests/validation/test_forward.py), and their kinematical synthesis is
`kinematics.frame_motion`. The prescribed path reuses those kernels instead of keeping another
copy of the equations: `forward_data` packs a `FirstOrderSystem` (its modal basis,
outboard-loaded modes included) as `ForwardData` of a fixed base.
"""

from __future__ import annotations

import functools
import os
from collections import OrderedDict
from dataclasses import fields, replace
from typing import Any

import numpy as np

from ..model import Base, Link
from ..model.joints import PrismaticJoint, is_driven
from .first_order import FirstOrderSystem
from .forward import ForwardSystem
from .forward_kernel import ForwardData, pack, with_stiffness
from .kinematics import SolvedFrames


def forward_view(system: FirstOrderSystem) -> ForwardSystem:
    """A ForwardSystem of a fixed base with the chain and modal data of ``system``
    (coordinates x = [δβ; z]), without recomputing the modes (and with the first-order
    model's basis, which may be outboard-loaded). Actuator forces are not part of the
    prescribed kernels (CompiledFirstOrderSystem adds them in numpy)."""
    return ForwardSystem(system.chain, Base(), system.geometric_stiffening,
                         modal=system.modal, gravity=system.gravity)


def forward_data(system: FirstOrderSystem) -> ForwardData:
    """ForwardData of ``system`` (see forward_view), made once per system, and remembered
    per process for the last few chains (`_packed_key`): repeated runs of a scenario build a
    new system each, and packing is a noticeable part of a short run. A system whose modal
    data are those remembered gets the remembered data; one whose modal data differ from
    them in stiffness, damping and frequencies alone (links that differ in EI and damping
    ratio: a sweep over E, EI or damping) gets them with its own stiffness and damping
    matrices (`forward_kernel.with_stiffness`), which equal its data packed whole; any other
    is packed whole."""
    data = getattr(system, "_forward_data", None)
    if data is not None:
        return data
    try:
        key: tuple[object, ...] | None = _packed_key(system)
        kept = _PACKED.get(key)
    except TypeError:  # a motion that is not hashable (holds arrays): not remembered
        key, kept = None, None
    if kept is not None and len(kept[0]) == len(system.modal) \
            and all(a is b for a, b in zip(kept[0], system.modal)):
        data = kept[1]
    elif kept is not None and len(kept[0]) == len(system.modal) \
            and all(_same_but_stiffness(a, b) for a, b in zip(kept[0], system.modal)):
        data = with_stiffness(kept[1], system.modal)
    else:
        data = pack(forward_view(system))
    if key is not None:  # the modal data kept alive with it: compared by identity
        _PACKED[key] = (list(system.modal), data)
        _PACKED.move_to_end(key)
        while len(_PACKED) > _PACKED_KEPT:
            _PACKED.popitem(last=False)
    system._forward_data = data  # type: ignore[attr-defined]
    return data


def _packed_key(system: FirstOrderSystem) -> tuple[object, ...]:
    """What `pack` reads of a system besides its modal data: its links but for their names,
    EI and damping ratios (which enter through the modal data alone), its joints, a rotary
    joint's prescribed motion only as being one (the kernels take the joint states as
    inputs, so that systems that differ in their motions alone share their data), its
    stiffening and gravity, and its links' mode counts."""
    chain = system.chain
    links = tuple(_unstiffened_link(link) for link in chain.links)
    joints = tuple(None if not (is_driven(j) or isinstance(j, PrismaticJoint)) else j
                   for j in chain.joints)
    return (links, joints, system.geometric_stiffening, system.gravity,
            tuple(m.n for m in system.modal))


_PACKED: OrderedDict[tuple[object, ...], tuple[list[object], ForwardData]] = OrderedDict()
_PACKED_KEPT = 8


def _unstiffened_link(link: Link) -> Link:
    """The link without its name, EI and damping ratio (those set to "", 1 and 0);
    remembered for the last links asked for (a hashable link's: equal links give equal
    results, and `replace` costs more than the look-up)."""
    try:
        return _unstiffened(link)
    except TypeError:  # a value that does not hash
        return replace(link, name="", EI=1.0, damping_ratio=0.0)


@functools.lru_cache(maxsize=64)
def _unstiffened(link: Link) -> Link:
    return replace(link, name="", EI=1.0, damping_ratio=0.0)


def stiffness_alone(a: FirstOrderSystem, b: FirstOrderSystem) -> bool:
    """Whether the state rows of ``a`` and ``b`` differ through their links' stiffness and
    damping matrices alone: the same joints (motions included) and settings, links that
    differ in EI and damping ratio only, modal data sharing every other array
    (`modes.integrals.modal_data_for_stiffness`), and neither with actuators or a start
    offset. M⁻¹ is then the same, and the rows affine in those matrices."""
    if a.actuators or b.actuators or a.z_start is not None or b.z_start is not None \
            or len(a.modal) != len(b.modal) or a.gravity != b.gravity \
            or a.geometric_stiffening != b.geometric_stiffening \
            or not all(_same_but_stiffness(x, y) for x, y in zip(a.modal, b.modal)):
        return False
    try:
        return bool(a.chain.joints == b.chain.joints and all(
            x == y or _unstiffened_link(x) == _unstiffened_link(y)
            for x, y in zip(a.chain.links, b.chain.links, strict=True)))
    except (TypeError, ValueError):  # values holding arrays (a measured motion)
        return False


def mass_inverse(system: FirstOrderSystem, t: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """M⁻¹ (nt, n, n) at times t (s), from ``rows`` = `state_rows` (M⁻¹[−K, −C, f]) there
    and the rows of the same system with c·I added to its stiffness: their K blocks differ
    by c M⁻¹. c is the largest modal stiffness, so that the difference keeps M⁻¹ to a few
    round-offs of its own size."""
    data = forward_data(system)
    c = float(np.abs(data.stiffness).max()) or 1.0
    probe = data._replace(stiffness=data.stiffness + c * np.eye(data.stiffness.shape[1]))
    n = system.n
    return (rows[:, :, :n] - state_rows(system, t, probe)[:, :, :n]) / c


_STIFFNESS_FIELDS = frozenset({"stiffness_matrix", "damping_matrix", "natural_frequencies_hz"})


def _same_but_stiffness(a: object, b: object) -> bool:
    """Whether modal data ``a`` and ``b`` hold the same objects in every field but their
    stiffness, damping and frequencies."""
    return a is b or (type(a) is type(b) and all(
        getattr(a, name) is getattr(b, name) for name in _compared_fields(type(a))))


@functools.lru_cache(maxsize=8)
def _compared_fields(kind: type) -> tuple[str, ...]:
    """`_same_but_stiffness`' fields of a modal data class."""
    return tuple(f.name for f in fields(kind) if f.name not in _STIFFNESS_FIELDS)


def solved_frames(system: FirstOrderSystem, t: np.ndarray, z: np.ndarray, zd: np.ndarray,
                  zdd: np.ndarray) -> SolvedFrames:
    """The frame motion at times t (s) along the solution z, ż, z̈ (nt, n), with the products
    of its maps with the solution (ξ-heads) instead of the maps: what the joint torques,
    sensors and tip paths of a run read (kinematics.SolvedFrames). The joint torques come
    along (``torques``: solved_frames(…).torques, see joint_torques)."""
    from ._prescribed_numba import channels

    data = forward_data(system)
    h = system.joint_history(t)
    nt, N = h.angle.shape
    c = np.ascontiguousarray
    given = (z, zd, zdd)  # the heads are for these arrays (SolvedFrames compares identity)
    z, zd, zdd = (c(v, dtype=float) for v in given)
    theta, omega, alpha = np.empty((nt, N)), np.empty((nt, N)), np.empty((nt, N))
    origin, oacc = np.empty((nt, N, 2)), np.empty((nt, N, 2))
    heads = tuple(np.empty((nt, N, 3)) for _ in range(3))
    torques = np.empty((nt, N))
    turn = np.empty((nt, N, 2))
    channels(data, c(h.angle, dtype=float), c(h.rate, dtype=float),
             c(h.acceleration, dtype=float), z, zd, zdd, theta, omega, alpha, origin, oacc,
             *heads, torques, turn)
    return SolvedFrames(theta, omega, alpha, origin, oacc, [], [], [],
                        solution=given, heads_=heads, torques=torques, turns=turn)


class CompiledFirstOrderSystem(FirstOrderSystem):
    """FirstOrderSystem whose state rows M⁻¹[−K, −C, f] (what the Lawson table samples) come
    from the compiled kernel; ``matrices`` stays the numpy reference."""

    _kept: list[tuple[np.ndarray, np.ndarray]] | None = None  # `keep_rows`

    def state_rows(self, t: np.ndarray) -> np.ndarray:
        """M⁻¹[−K, −C, f + B V] (nt, n, 2n+1) at times t (s)."""
        if self.actuators:  # their forces: the numpy route (open-loop actuators are rare)
            M, C, K, f = self.matrices(t)
            rows = np.linalg.solve(M, np.concatenate([-K, -C, f[:, :, None]], axis=2))
        else:
            rows = state_rows(self, t)
            if self.z_start is not None:  # in w = z − z_start: M⁻¹(f − K z_start)
                rows[:, :, -1] += rows[:, :, :self.n] @ self.z_start
        kept = self._kept
        if self._keeping and kept is not None and (
                rows.nbytes <= _KEPT_BYTES - sum(r.nbytes for _, r in kept)):
            kept.append((np.array(t, dtype=float), rows.copy()))
        return rows

    _keeping = False

    def keep_rows(self, keep: bool = True) -> None:
        """From now on (``keep``) remember the rows of the `state_rows` calls (up to
        _KEPT_BYTES), for `kept_rows`: a run's table samples them, its sensitivities read
        them again (the same numbers: each row depends on its instant's joint state alone);
        or (not ``keep``) remember no more, keeping those remembered."""
        if keep:
            self._kept = []
        self._keeping = keep

    def kept_rows(self, t: np.ndarray) -> np.ndarray | None:
        """The rows of `state_rows` at times t (s) as an earlier call since `keep_rows`
        computed them, or None where one of the times was not among its."""
        if not self._kept:
            return None
        times = np.concatenate([k[0] for k in self._kept])
        order = np.argsort(times, kind="stable")
        times = times[order]
        where = np.minimum(np.searchsorted(times, t), times.size - 1)
        if not np.array_equal(times[where], t):
            return None
        return np.concatenate([k[1] for k in self._kept])[order[where]]


_KEPT_BYTES = 1 << 26  # `CompiledFirstOrderSystem.keep_rows`' rows: 64 MB at most


def state_rows(system: FirstOrderSystem, t: np.ndarray, data: ForwardData | None = None
               ) -> np.ndarray:
    """M⁻¹[−K, −C, f] (nt, n, 2n+1) of ``system`` (its packed ``data``, or other data of
    the same layout) at times t (s), compiled (`_prescribed_numba.state_rows`; equal to
    magnus.state_rows of the numpy FirstOrderSystem.matrices to round-off), once per
    distinct joint state."""
    from ._prescribed_numba import state_rows as kernel

    if system.actuators:
        raise ValueError("the compiled state rows leave out actuator forces")
    if data is None:
        data = forward_data(system)
    unique, inverse = system.joint_history(t).distinct
    c = np.ascontiguousarray
    out = np.empty((unique.angle.shape[0], system.n, 2 * system.n + 1))
    states = (c(unique.angle, dtype=float), c(unique.rate, dtype=float),
              c(unique.acceleration, dtype=float))
    if _second_thread and out.shape[0] >= _SPLIT_ROWS:  # each row as on one thread
        half = out.shape[0] // 2
        other = _second_thread[0].submit(kernel, data, *(a[half:] for a in states), out[half:])
        kernel(data, *(a[:half] for a in states), out[:half])
        other.result()
    else:
        kernel(data, *states, out)
    return out if out.shape[0] == inverse.size else out[inverse]


# Distinct joint states above which `split_state_rows` splits a call (a thread's hand-over
# costs about as much as a few dozen rows).
_SPLIT_ROWS = 1024
_second_thread: list[Any] = []  # the executor, once `split_state_rows` asked for it


def split_state_rows() -> None:
    """From now on in this process, compute `state_rows` of many joint states on two
    threads (the compiled kernel releases the interpreter lock): for a command's own
    process whose other core is idle while it runs (`flexlink fit`, `flexlink compare`,
    whose figures are drawn after). Each row is computed as on one thread: the same
    numbers. Nothing on a machine with one core; not for a process pool's workers, which
    already keep every core busy."""
    if _second_thread or (os.cpu_count() or 1) < 2:
        return
    from concurrent.futures import ThreadPoolExecutor

    _second_thread.append(ThreadPoolExecutor(max_workers=1,
                                             thread_name_prefix="flexlink-state-rows"))


def end_split_state_rows() -> None:
    """Back to one thread: the second one ended (the command's end; a process whose other
    threads have ended exits without tearing its modules down, `cli._exit`)."""
    while _second_thread:
        _second_thread.pop().shutdown(wait=True)


def joint_torques(system: FirstOrderSystem, frames: SolvedFrames) -> np.ndarray:
    """Motor torque of every joint (nt, N), N·m, along the solution ``frames`` were built for:
    dynamics/torques.joint_torques compiled (`_prescribed_numba.joint_torques`), computed
    with the frames by solved_frames."""
    return frames.torques


def load() -> None:
    """Load (or, on a first run, compile) the kernels of this module for every chain: their
    types do not depend on the chain's size, so a one-link chain at two instants does it
    (`solvers.lawson.preload_compiled_loop` runs this in a background thread)."""
    from ..model import Chain, Link
    from ..motion import Hold

    system = FirstOrderSystem(Chain((Link("preload", 1.0, 1.0, 1.0, modes=1),), (Hold(0.0),)))
    t = np.array([0.0, 1.0])
    z = np.zeros((2, system.n))
    state_rows(system, t)
    solved_frames(system, t, z, z, z)
