"""`links[i].initial_modal_rates`: a link that starts vibrating (docs/scenario.md). Read and
checked here: one finite rate per mode, and only where the run integrates the equations of
motion from a state (a forward run: a driven or free joint, a slider, a moving base; the
closed loops' free joints are driven ones)."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from .errors import Problems, describe

KEY = "initial_modal_rates"


def read_modal_rates(table: Mapping[str, Any], path: str, modes: int | None,
                     p: Problems) -> list[float] | None:
    """The link's initial modal rates (m/s, one per mode) or None when not given."""
    value = table.get(KEY)
    if value is None:
        return None
    if not isinstance(value, list) or not all(
            isinstance(x, int | float) and not isinstance(x, bool) for x in value):
        p.add(f"{path}.{KEY}: expected an array of numbers (m/s, one per mode), got "
              f"{describe(value)}")
        return None
    bad = [i for i, x in enumerate(value) if not math.isfinite(x)]
    if bad:
        p.add(f"{path}.{KEY}[{bad[0]}] = {value[bad[0]]!r} is not a finite number; give m/s")
        return None
    if modes is not None and len(value) != modes:
        p.add(f"{path}.{KEY}: {len(value)} values for {modes} modes ({path}.modes); give one "
              "rate per mode (0 for a mode at rest)")
        return None
    return [float(x) for x in value]


def _forward(joints: list[dict[str, Any]], base: Mapping[str, Any] | None) -> bool:
    """What `Scenario.is_forward` says, on the read tables."""
    return base is not None or any(
        "drive" in j or "spring_stiffness" in j or j.get("type") == "prismatic"
        or "base_point" in j for j in joints)


def check_rates_on_forward_runs(links: list[dict[str, Any]], joints: list[dict[str, Any]],
                                base: Mapping[str, Any] | None, p: Problems) -> None:
    """Initial modal rates need a forward run: a run of prescribed joints starts its links
    at rest (its solvers integrate from rest)."""
    if _forward(joints, base):
        return
    for i, link in enumerate(links):
        if link.get(KEY) is not None:
            p.add(f"links[{i}].{KEY}: every joint is prescribed, and such a run starts its "
                  "links at rest; drive a joint (drive = \"free\", \"torque\", a servo) or "
                  f"leave out {KEY}")
