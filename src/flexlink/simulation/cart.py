"""A driven cart that leaves its travel ends the run with an error (never clipped)."""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from ..model import Base

SAMPLE = "the first output sample outside it"
LAST = "the last state before the run stopped"
STEP = "the end of the integrator's first step outside it: the run stopped there"


def check_travel(base: Base | None, t: np.ndarray, s: np.ndarray, where: str = SAMPLE,
                 then: str = "") -> None:
    """SimulationError if the cart's travel s (m) at the output times t (s) leaves the
    allowed range (`model.Cart.travel`), naming the first time and travel outside it
    (``where``: what that time is; ``then``: what followed, for a run that stopped)."""
    if base is None or base.cart is None:
        return
    exit_ = base.cart.first_exit(t, s)
    if exit_ is not None:
        lo, hi = base.cart.travel
        raise SimulationError(
            f"the cart left its travel [{lo:g}, {hi:g}] m (base.cart.travel): "
            f"s = {exit_[1]:.6g} m at t = {exit_[0]:.6g} s ({where}){then}. Widen "
            "base.cart.travel or change the cart's drive")
