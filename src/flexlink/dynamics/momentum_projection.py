"""Which momentum of a forward system is known, and its record for the compiled
projection (`_momentum_numba.project`, called by the Radau IIA loop after every accepted
step and at every output).

Radau IIA does not conserve momentum; the projection puts the state back onto it. Only
components whose change is known exactly from the inputs are projected:

- free base, linear momentum L: changed by gravity (m g per second) and by the base loads'
  forces in inertial axes (their integrals over time, from the input table); projected
  unless a load has a non-zero force in body axes (its direction follows the solved
  attitude);
- free base, angular momentum about the origin: changed by the loads' moments only when
  there is no gravity; with gravity, about the centre of mass (gravity acts there; about the
  origin its moment follows the solved position); projected unless a load has a non-zero
  force (its arm follows the solved motion). About the origin, not the centre of mass, when
  both are known: the centre of mass moves by the integrated positions, whose error
  (~rtol) would otherwise show in the angular momentum about the origin;
- pinned base, angular momentum about the pin (the origin): as above, and only without
  gravity (its arm about the pin follows the motion); the pin's force changes L;
- cart driven by a force history or free, momentum along its rail L·e: changed by the
  drive's force (its integral from the input table), the loads' components along the rail
  (the cart's attitude is constant, so body-axis forces too) and gravity's (M g·e per
  second); the rail takes the rest. Not for a servo (its force follows the solved travel)
  or a prescribed travel;
- fixed base: nothing.

Joint torques, servos, prescribed joint motions and actuators are internal. The start
values are those of the initial state.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from ..model import TorqueDrive
from ..model.histories import BangBang, History, Step, Sum, Table
from .forward import ForwardSystem
from .forward_kernel import ForwardData

Projection = namedtuple("Projection", [
    "active", "start", "rate", "impulse", "t0", "about_cm", "total_mass", "size",
    "zero_rigid", "origin", "velocity", "c0", "c1", "A", "lam", "dirs", "pd1"])
Projection.__doc__ = (
    "Known momentum of a forward run: ``active`` the projected components (0: L_x, or on a "
    "cart L along its rail, 1: L_y in N·s, 2: H in N·m·s, about the centre of mass if "
    "``about_cm``, else the origin); "
    "their values start (3,) at t0 (s) plus rate (3,) · (t − t0) plus impulse (3, columns) "
    "@ the inputs' integrals; size (3,) their scale; the rest scratch arrays.")


def is_zero(history: History) -> bool:
    """True if ``history`` is zero at every time, as far as its type tells."""
    if isinstance(history, Sum):
        return all(is_zero(part) for part in history.parts)
    if isinstance(history, BangBang | Step):
        return history.amplitude == 0.0
    if isinstance(history, Table):
        return not any(history.u)
    return False


def projection(system: ForwardSystem, data: ForwardData, t0: float, columns: int
               ) -> Projection:
    """The record of ``system``'s known momentum for input rows of ``columns`` columns, its
    start values not yet filled (`start_values`)."""
    from ._forward_numba import CART, FREE, PINNED

    base = system.base
    loads = base.loads if base.kind != "fixed" else ()
    N = len(system.chain.links)
    nl = len(loads)
    total = float(np.sum(data.mass)) + (float(base.mass) if base.kind in ("free", "cart")
                                        else 0.0)
    gravity = np.asarray(system.gravity, dtype=float)
    no_force = all(is_zero(ld.force_x) and is_zero(ld.force_y) for ld in loads)
    no_body_force = all(is_zero(ld.force_x) and is_zero(ld.force_y)
                        for ld in loads if ld.frame == "body")
    impulse = np.zeros((3, columns))
    rate = np.zeros(3)
    active: list[int] = []
    if data.base_kind == FREE and no_body_force:
        active += [0, 1]
        rate[:2] = total * gravity
        for j, ld in enumerate(loads):
            if ld.frame != "body":
                impulse[0, 4 * N + j] = impulse[1, 4 * N + nl + j] = 1.0
    if no_force and (data.base_kind == FREE
                     or (data.base_kind == PINNED and not np.any(gravity))):
        active.append(2)
        impulse[2, 4 * N + 2 * nl:4 * N + 3 * nl] = 1.0
    cart = base.cart
    if data.base_kind == CART and cart is not None and isinstance(cart.drive, TorqueDrive):
        e = np.asarray(cart.direction, dtype=float)
        active.append(0)
        rate[0] = total * float(gravity @ e)
        impulse[0, columns - 1] = 1.0  # the drive's force: the input row's last column
        c, s = np.cos(base.attitude), np.sin(base.attitude)
        for j, ld in enumerate(loads):  # body axes: F·e = F_body·(Rᵀ e)
            ex, ey = (c * e[0] + s * e[1], -s * e[0] + c * e[1]) if ld.frame == "body" else e
            impulse[0, 4 * N + j], impulse[0, 4 * N + nl + j] = ex, ey
    nr = data.n_rigid
    return Projection(
        active=np.array(active, dtype=np.int64), start=np.zeros(3), rate=rate,
        impulse=impulse, t0=float(t0),
        about_cm=bool(data.base_kind == FREE and np.any(gravity)),
        total_mass=max(total, 1e-300), size=np.zeros(3), zero_rigid=np.zeros(nr),
        origin=np.zeros((N, 2)), velocity=np.zeros((N, 2)), c0=np.zeros(5), c1=np.zeros(5),
        A=np.zeros((3, 3)), lam=np.zeros(3), dirs=np.zeros((3, nr)), pd1=np.zeros(nr))


def start_values(pj: Projection, data: ForwardData, work: tuple, u0: np.ndarray,
                 y0: np.ndarray, t_end: float) -> None:
    """Fill pj.start with the momentum of the initial state y0 (input row u0) and pj.size
    with each component's scale (its start value, the change gravity and the inputs could
    bring, the total mass times 1 m/s or 1 m²/s: whichever is largest)."""
    from ._momentum_numba import invariants

    out = np.zeros(3)
    invariants(data, work, pj, np.ascontiguousarray(u0, dtype=float), y0, out)
    pj.start[:] = out
    span = max(t_end - pj.t0, 0.0)
    pj.size[:] = np.maximum(np.abs(out), np.abs(pj.rate) * span) + pj.total_mass
