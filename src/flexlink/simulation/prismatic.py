"""A driven slider inside a chain that leaves its travel ends the run with an error (never
clipped), as a cart does (simulation/cart.py)."""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from ..model import PrismaticJoint
from ..model.prismatic import guide
from .cart import SAMPLE


def check_travel(joints: tuple, t: np.ndarray, p: np.ndarray, first: int,
                 where: str = SAMPLE, then: str = "") -> None:
    """SimulationError if a slider's travel (its column first + k of the rigid states p,
    m) at the output times t (s) leaves its allowed range, naming the joint's key, the
    first time and travel outside it (``where``, ``then``: as simulation/cart.py's)."""
    for k, joint in enumerate(joints):
        if not isinstance(joint, PrismaticJoint):
            continue
        exit_ = guide(joint).first_exit(t, p[:, first + k])
        if exit_ is not None:
            lo, hi = joint.travel
            raise SimulationError(
                f"the slider of joint {k + 1} left its travel [{lo:g}, {hi:g}] m "
                f"(joints[{k}].travel): s = {exit_[1]:.6g} m at t = {exit_[0]:.6g} s "
                f"({where}){then}. Widen joints[{k}].travel or change the slider's drive")
