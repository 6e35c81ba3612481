"""The measures of residual vibration (one copy, used by the optimiser, the figures, the
benchmark and the tests).

* `elastic_energy` — kinetic plus strain energy of the elastic coordinates,
  ½ żᵀ M ż + ½ zᵀ K z (J), with M and K of the arm at rest in its final configuration. Once
  the joints stop, the first-order model is linear and time-invariant, so this energy at the
  move's end fixes the whole residual vibration (it then only decays by damping): the
  optimiser's objective, cheap because a run need only reach the move's end.
* `residual_peak` — the peak |value| of a channel (a tip deflection, m) over a window after
  the move: what an observer of the arm sees, and what the judged comparisons use, in the
  first-order and the nonlinear model alike.
"""

from __future__ import annotations

import numpy as np

from ..results import Results

DEFAULT_WINDOW_S = 2.0  # s, the window after the move where the residual peak is taken


def elastic_energy(M: np.ndarray, K: np.ndarray, z: np.ndarray, z_dot: np.ndarray) -> float:
    """½ żᵀ M ż + ½ zᵀ K z (J) of one state (z, ż: (n,); M, K: (n, n))."""
    return 0.5 * float(z_dot @ M @ z_dot) + 0.5 * float(z @ K @ z)


def residual_peak(results: Results, channel: str, after: float,
                  window: float = DEFAULT_WINDOW_S) -> float:
    """Peak |results[channel]| for after ≤ t ≤ after + window (s); ValueError if the run
    does not cover the window."""
    t = results.time
    if t[-1] < after + window - 1e-9:
        raise ValueError(f"the run ends at {t[-1]:g} s; the residual window needs it to reach "
                         f"{after + window:g} s (move end {after:g} s + {window:g} s)")
    inside = (t >= after - 1e-12) & (t <= after + window + 1e-12)
    return float(np.abs(results[channel][inside]).max())


__all__ = ["DEFAULT_WINDOW_S", "elastic_energy", "residual_peak"]
