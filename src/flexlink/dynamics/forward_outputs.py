"""What a forward run's channels need at its output times, in one compiled pass over the
solved states (`_forward_outputs_numba.outputs`): the rates (accelerations), the frames
about the solved rigid motion (as `ForwardSystem.frames`), the joint torques (as
`ForwardSystem.joint_torques`) and, base not fixed, the momentum (as
`dynamics.forward.momentum`). Each is the compiled kernel's, tested against the numpy
equations to round-off (tests/unit/test_forward_kernel.py, test_momentum_projection.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .forward import ForwardSystem
from .forward_kernel import ForwardData
from .kinematics import FrameMotion
from .momentum_projection import Projection, projection


@dataclass(frozen=True)
class ForwardOutputs:
    """rates (nt, len(y)): dy/dt of the states; frames: the zero-order frames and maps at
    the solved rigid states; torques (nt, N) of the joints' motors, N·m; momenta: linear
    (nt, 2) N·s and angular about the origin (nt,) N·m·s, None on a fixed base."""

    rates: np.ndarray
    frames: FrameMotion
    torques: np.ndarray
    momenta: tuple[np.ndarray, np.ndarray] | None


def forward_outputs(system: ForwardSystem, data: ForwardData, work: tuple, u: np.ndarray,
                    states: np.ndarray, scratch: Projection | None = None,
                    accelerations: np.ndarray | None = None) -> ForwardOutputs:
    """The outputs at states (nt, len(y)) with input rows u (nt, columns); ``scratch``: a
    projection record of the system (`momentum_projection.projection`) to work in;
    ``accelerations``: (p̈_free, z̈) (nt, ·) to take instead of solving for them."""
    from ._forward_numba import FIXED
    from ._forward_outputs_numba import outputs

    nt = states.shape[0]
    N, nx = len(system.chain.links), system.n_x
    rates = np.empty_like(states)
    theta, omega, alpha = (np.empty((nt, N)) for _ in range(3))
    origin, oacc = np.empty((nt, N, 2)), np.empty((nt, N, 2))
    T, Td, Tdd = (np.empty((nt, N, 3, nx)) for _ in range(3))
    torques = np.empty((nt, N))
    moving = data.base_kind != FIXED
    momenta = np.empty((nt, 3) if moving else (0, 3))
    if scratch is None:
        scratch = projection(system, data, 0.0, u.shape[1])
    outputs(data, work, np.ascontiguousarray(u, dtype=float),
            np.ascontiguousarray(states, dtype=float), rates, theta, omega, alpha, origin,
            oacc, T, Td, Tdd, torques, momenta, scratch,
            np.ascontiguousarray(accelerations, dtype=float) if accelerations is not None
            else np.empty((0, len(system.free) + system.n)),
            tuple(np.empty((1, c)) for c in (system.n_rigid,) * 3 + (system.n,) * 3))
    frames = FrameMotion(theta, omega, alpha, origin, oacc, [T[:, k] for k in range(N)],
                         [Td[:, k] for k in range(N)], [Tdd[:, k] for k in range(N)])
    return ForwardOutputs(rates, frames, torques,
                          (momenta[:, :2], momenta[:, 2]) if moving else None)
