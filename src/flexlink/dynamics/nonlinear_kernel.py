"""The nonlinear model as data for the compiled kernels: named records of the constant arrays
(`NonlinearData`, `NonlinearForwardData`) and of the per-stage input rows (`StageInputs`).

One formulation serves both nonlinear paths (docs/nonlinear.md §2, §7): every section angle
is α_j = Ay_j y + (prescribed part), y the unknowns. With every rigid coordinate prescribed
(`NonlinearSystem`) y = q and the prescribed joint angles are inputs; with free base
coordinates or driven joints (`NonlinearForwardData`) those join y. The compiled residual's
inertia and elastic part (`_nonlinear_numba.inertia_elastic`) is the same code for both;
the record's type decides which compiled residual, and so which applied forces, follow it
(`solvers/_gauss_numba.residual_model`): the given load rows on q, or the first-order
forward model's drive torques, servo laws and base loads.
"""

from __future__ import annotations

from collections import namedtuple

import numpy as np

from .forward_kernel import ForwardData

NonlinearData = namedtuple("NonlinearData", [
    "Ay", "G", "s", "m_tot", "translation", "rot_y", "rot_J", "Dq", "Kq", "n", "nu", "gravity",
    "cart", "rail", "line_node", "line_col", "line_u"])
NonlinearData.__doc__ = """Constant arrays of the nonlinear model for the compiled kernels (SI
units, global axes). Unknowns y: the n elastic coordinates q, then the nu free rigid
coordinates (none with every joint prescribed), then the servo integrals.

- Ay (nodes, n + nu): the node angles' coefficients on [q, p_free], rad per unit;
- G (nodes, nodes): the nodes' coupling weights Wᵀ diag(m) W, kg·m², exactly symmetric
  (`coupling_weights`);
- s (nodes,): Wᵀm, the mass each node's direction carries (kg·m);
- m_tot: the total point mass, kg (the translation rows only);
- translation: y[n], y[n + 1] are the base point's x, y (a free base);
- rot_y (n_rot, n + nu), rot_J (n_rot,): the rotary inertias' angles on [q, p_free] and
  their inertias, kg·m² (tip inertias; on a moving base the base's and the motors');
- Dq, Kq (n, n): modal damping and stiffness on q, N·m·s and N·m per unit of q;
- n, nu: the counts of elastic and free rigid coordinates;
- gravity (2,): the uniform field [gx, gy], m/s²;
- cart: 0 no cart (every model with prescribed joints), 1 a cart whose travel s along its
  rail is y[n], 2 a cart with a prescribed travel (s̈ from the forward input row);
- rail (2,): the cart's rail direction (zero without a cart);
- line_node, line_col (n_lines,) int: per slider inside the chain (dynamics/prismatic.py) the
  node of its line, whose length is the travel s, and the column of s in y (−1 when the
  travel is prescribed);
- line_u (n_lines, 3) int: a prescribed travel's columns s, ṡ, s̈ (m, m/s, m/s²) in the
  forward input rows (`forward_kernel.inputs`; unused when free)."""

NonlinearForwardData = namedtuple("NonlinearForwardData", NonlinearData._fields + tuple(
    name for name in ForwardData._fields if name not in NonlinearData._fields))
NonlinearForwardData.__doc__ = """`NonlinearData`'s fields for a nonlinear model with free rigid
coordinates (free or pinned base, a cart, driven joints), then those of the first-order forward
model's `forward_kernel.ForwardData` of the same chain and base (gravity, rail, n_rigid and
free mean the same in both): its `_forward_numba.applied` gives the drive torques, servo laws,
base loads and actuator forces at the solved rigid state, reading them from this record.
One flat record, not one nested in the other: the compiled kernels take a record's arrays
one by one at every call, and a nested one is taken again where it is read."""


def coupling_weights(W: np.ndarray, mass: np.ndarray) -> np.ndarray:
    """G = Wᵀ diag(m) W (nodes, nodes), kg·m², of the point masses m (p,), kg, at the weight
    rows W (p, nodes), m: symmetric to the bit, as the compiled residual reads its rows as
    its columns (`_nonlinear_numba.inertia_elastic`)."""
    R = np.sqrt(mass)[:, None] * W
    G = R.T @ R
    return 0.5 * (G + G.T)

def forward_data(core: dict, loads: ForwardData) -> NonlinearForwardData:
    """The NonlinearForwardData of a model's own arrays ``core`` (NonlinearData's fields) and
    the ForwardData of its applied loads."""
    extra = {name: getattr(loads, name) for name in NonlinearForwardData._fields
             if name not in NonlinearData._fields}
    return NonlinearForwardData(**core, **extra)


StageInputs = namedtuple("StageInputs", ["angle", "rate", "acceleration", "rot_acceleration",
                                         "u"])
StageInputs.__doc__ = """The prescribed parts of the motion and the applied inputs at a batch of
times (one row per time; C-contiguous float arrays for the compiled kernels):

- angle, rate, acceleration (b, nodes): the prescribed part of each node's angle (rad),
  rate (rad/s) and acceleration (rad/s²);
- rot_acceleration (b, n_rot): the prescribed part of each rotary inertia's angular
  acceleration, rad/s²;
- u (b, ·): with `NonlinearData`, the applied generalized forces on q (b, n: the actuators'
  B V, N·m); with `NonlinearForwardData`, the input rows of `forward_kernel.inputs`."""


def stage_rows(angle: np.ndarray, rate: np.ndarray, acceleration: np.ndarray,
               rot_acceleration: np.ndarray, u: np.ndarray) -> StageInputs:
    """A StageInputs of C-contiguous float arrays (one compiled signature)."""
    c = np.ascontiguousarray
    return StageInputs(c(angle, dtype=float), c(rate, dtype=float), c(acceleration, dtype=float),
                       c(rot_acceleration, dtype=float), c(u, dtype=float))
