"""Loop-closing joints: a revolute joint or a slider that closes a loop of the chain's tree
(SI units, radians). Description only: the closure equations are in ``dynamics/loops.py``.

The tree (links on their joints, branches started on the base) is cut at one joint per loop;
the cut joint is a `Closure`. Its point is on link ``link`` at ``x`` from that link's joint
(deformed position, link frame). A ``"revolute"`` closure pins that point to the point ``x_to``
of link ``to_link``, or (``to_link`` None) to the fixed point ``ground``: two equations. A
``"slider"`` closure keeps the point on the fixed line through ``ground`` at ``angle`` from
the global X axis: one equation (the classic slider-crank's piston; a piston mass is the
link's tip mass).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

ClosureKind = Literal["revolute", "slider"]
CLOSURE_KINDS: tuple[str, ...] = get_args(ClosureKind)


@dataclass(frozen=True)
class Closure:
    """A joint that closes a loop: see the module's docstring."""

    name: str
    kind: ClosureKind
    link: int  # index of the link that carries the point
    x: float  # m, from that link's joint
    to_link: int | None = None  # revolute: the other link (None: the ground point)
    x_to: float = 0.0  # m, on to_link
    ground: tuple[float, float] = (0.0, 0.0)  # m: revolute's fixed pivot, slider line's point
    angle: float = 0.0  # rad: the slider line's direction from the global X axis

    @property
    def equations(self) -> int:
        """The number of constraint equations: 2 (revolute) or 1 (slider)."""
        return 2 if self.kind == "revolute" else 1
