"""Which assumed-mode basis `mode_shapes = "auto"` stands for, per link (docs/modes.md, "The
default basis"). A rule on the description only: the modes themselves are built in
``modes/`` and ``dynamics.first_order.chain_modal_data``."""

from __future__ import annotations

import math
from collections.abc import Sequence

from .base import Base
from .chain import Chain
from .histories import ZERO
from .joints import TorqueDrive, initial_angle, is_driven
from .loops import Closure


def default_mode_shapes(tip_body: bool, carries_links: bool, free_hub: bool) -> str:
    """The basis "auto" stands for: the exact modes of the link with what it carries.
    ``free_hub``: the link turns on a free joint or pinned hub (`free_hub`); ``carries_links``:
    the next link's joint sits on its tip; ``tip_body``: it has a tip mass or tip inertia.
    Clamped–free modes converge like N⁻³ on a tip mass and only like N⁻¹ on a tip inertia
    (the moment EI φ''(L) = J_t ω² φ'(L) they cannot carry); on a light free hub the n-th
    frequency needs the (n+1)-th clamped mode."""
    if free_hub:
        return "hub_loaded"
    if carries_links:
        return "outboard_loaded"
    return "tip_loaded" if tip_body else "clamped_free"


def carries_links(chain: Chain, k: int, base: Base | None = None) -> bool:
    """Whether link k's tip carries the next link (its joint does not start a branch)."""
    return k + 1 < len(chain.links) and (base is None or base.attachment(k + 1) is None)


def free_hub(chain: Chain, k: int, base: Base | None = None) -> tuple[float, float] | None:
    """(hub inertia kg·m², radius m) where link k turns on a free hub, else None: a
    torque-driven joint (its motor inertia, radius 0), or a prescribed joint on a pinned
    base that carries no other link, the link pointing radially away from the base's centre
    (the base's inertia, the attachment's distance)."""
    joint = chain.joints[k]
    if isinstance(joint, TorqueDrive):
        return joint.motor_inertia, 0.0
    if base is None or base.kind != "pinned" or is_driven(joint):
        return None
    point = base.attachment(k)
    if point is None or any(base.attachment(j) is not None
                            for j in range(len(chain.links)) if j != k):
        return None
    angle = initial_angle(joint)
    radius = math.hypot(*point)
    along = point[0] * math.cos(angle) + point[1] * math.sin(angle)
    if radius > 0 and not along >= radius * (1 - 1e-12):
        return None
    return base.inertia, radius


def held_by_loop(chain: Chain, k: int, closures: Sequence[Closure]) -> bool:
    """Whether link k turns on a free joint (no torque) and a closure holds its tip: its
    modes are then those of a member pinned at both ends."""
    joint, length = chain.joints[k], chain.links[k].length
    if not (isinstance(joint, TorqueDrive) and joint.torque == ZERO):
        return False
    return any((c.link == k and c.x >= length * (1 - 1e-12))
               or (c.to_link == k and c.x_to >= length * (1 - 1e-12)) for c in closures)


def chosen_mode_shapes(chain: Chain, base: Base | None = None,
                       closures: Sequence[Closure] = ()) -> tuple[str, ...]:
    """Each link's basis: its own ``mode_shapes``, or for "auto" where a closed loop holds it
    (`held_by_loop`) "pinned_pinned", "pinned_loaded" when its tip body has a rotary inertia
    (which the sines, without curvature at the ends, converge on like N⁻¹), else
    `default_mode_shapes`."""
    return tuple(
        link.mode_shapes if link.mode_shapes != "auto" else
        ("pinned_loaded" if link.tip_body()[1] > 0 else "pinned_pinned")
        if held_by_loop(chain, k, closures) else
        default_mode_shapes(any(link.tip_body()[:2]),
                            carries_links(chain, k, base), free_hub(chain, k, base) is not None)
        for k, link in enumerate(chain.links))
