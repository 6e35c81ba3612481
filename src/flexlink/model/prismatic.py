"""What a slider inside a chain (`joints.PrismaticJoint`) may be combined with, and its
travel at load: every refusal names the field and the fix (description only, no physics)."""

from __future__ import annotations

from typing import Any

from .base import Cart
from .joints import PrismaticJoint


def guide(joint: PrismaticJoint) -> Cart:
    """A slider's drive and travel as a `base.Cart` on a rail at 0 rad: one copy of the
    travel's start and checks."""
    return Cart(joint.drive, 0.0, joint.travel)  # type: ignore[arg-type]


def check_slider(scenario: Any, k: int) -> None:
    """ValueError if slider k of ``scenario`` (a `Scenario`) is not modelled where it sits,
    or if its start, prescribed travel or servo reference leaves its travel in [0, t_end]."""
    joint = scenario.chain.joints[k]
    assert isinstance(joint, PrismaticJoint)
    where = f"joints[{k}]"
    if k == 0 or (scenario.base is not None and scenario.base.attachment(k) is not None):
        raise ValueError(f"{where}: a slider rides on the tip of the link before it; the "
                         "first joint of a branch cannot be one (a slider on the ground is a "
                         "cart: base.type = \"cart\")")
    length = scenario.chain.links[k - 1].length
    if joint.at is not None and joint.at > length:
        raise ValueError(f"{where}.line_at: {joint.at:g} m is beyond the parent link's length "
                         f"{length:g} m; give a point in [0, {length:g}] m")
    try:
        guide(joint).check_travel(scenario.settings.t_end)
    except ValueError as exc:
        raise ValueError(slider_message(str(exc), where)) from None


def slider_message(message: str, where: str) -> str:
    """A cart's travel message (`base.Cart.check_travel`) said of slider ``where``."""
    message = message.replace("(base.travel)", f"({where}.travel)")
    for key in ("motion", "reference"):
        message = message.replace(f"base.{key}:", f"{where}.{key}:")
    message = message.replace("base: the cart", f"{where}: the slider")
    return message.replace("cart travel", "slider travel").replace("cart servo", "slider servo")
