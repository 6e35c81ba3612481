"""The controllers' runtime: every sampled controller as a discrete state-space system, and
the data the compiled integrators read at each sample (docs/closed_loop.md).

PPF and SRF are continuous filters turned discrete here; an LTI controller is discrete
already; a Python callable stays Python (the integrator returns to Python at its samples).
PPF is discretised by the bilinear (Tustin) map with the filter frequency pre-warped, so the
discrete filter peaks exactly at frequency_hz and is stable for every sample rate (ZOH
discretisation would assume the sensor signal held between samples, which it is not, and
shifts the peak by half a sample's phase). The output is held (ZOH) until the next sample.
"""

from __future__ import annotations

import functools
from collections import namedtuple
from collections.abc import Sequence

import numpy as np

from ..model import (
    Controller,
    DiscreteLTI,
    FunctionController,
    PiezoActuator,
    PositivePositionFeedback,
    StrainRateFeedback,
)

Discrete = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]  # Ad, Bd, Cd, Dd
# |controller state or output| beyond this (SI units, volts) is a loop that has gone unstable
CONTROL_BLOW_UP = 1e9


@functools.lru_cache(maxsize=64)
def discretize(controller: Controller) -> Discrete:
    """(Ad, Bd, Cd, Dd) of x_{k+1} = Ad x_k + Bd y_k, V_k = Cd x_k + Dd y_k at the
    controller's sample period (cached: controllers are immutable; do not modify the
    arrays)."""
    T = 1.0 / controller.sample_rate
    if isinstance(controller, PositivePositionFeedback):
        w = 2.0 * np.pi * controller.frequency_hz
        ww = 2.0 / T * np.tan(0.5 * w * T)  # pre-warped: the discrete peak lands on w
        z = controller.damping
        A = np.array([[0.0, 1.0], [-ww**2, -2.0 * z * ww]])
        B = np.array([[0.0], [ww**2]])
        C = np.array([[controller.gain, 0.0]])
        return _bilinear(A, B, C, np.zeros((1, 1)), T)
    if isinstance(controller, StrainRateFeedback):
        g = controller.gain / T  # V = −gain (y_k − y_{k−1}) / T, state x_k = y_{k−1}
        return (np.zeros((1, 1)), np.ones((1, 1)), np.array([[g]]), np.array([[-g]]))
    if isinstance(controller, DiscreteLTI):
        ni, no = len(controller.inputs), len(controller.outputs)
        n = len(controller.A)
        return (np.array(controller.A, dtype=float).reshape(n, n),
                np.array(controller.B, dtype=float).reshape(n, ni),
                np.array(controller.C, dtype=float).reshape(no, n),
                np.array(controller.D, dtype=float).reshape(no, ni))
    raise TypeError(f"controller {controller.name!r} has no state-space form")


def _bilinear(A: np.ndarray, B: np.ndarray, C: np.ndarray, D: np.ndarray, T: float) -> Discrete:
    from scipy.signal import cont2discrete

    Ad, Bd, Cd, Dd, _ = cont2discrete((A, B, C, D), T, method="bilinear")
    return Ad, Bd, Cd, Dd


def controller_inputs(controller: Controller) -> tuple[str, ...]:
    return ((controller.sensor,) if isinstance(controller, PositivePositionFeedback
                                               | StrainRateFeedback) else controller.inputs)


def controller_outputs(controller: Controller) -> tuple[str, ...]:
    return ((controller.actuator,) if isinstance(controller, PositivePositionFeedback
                                                 | StrainRateFeedback) else controller.outputs)


def state_count(controller: Controller) -> int:
    """Number of states the controller reports as channels (a callable has none)."""
    if isinstance(controller, PositivePositionFeedback):
        return 2
    if isinstance(controller, StrainRateFeedback):
        return 1
    return len(controller.A) if isinstance(controller, DiscreteLTI) else 0


ControlData = namedtuple("ControlData", [
    "Ad", "Bd", "Cd", "Dd", "n_x", "n_in", "n_out", "in_row", "out_act", "S", "mask",
    "update", "noise", "quant", "v_open", "limit", "state_at"])
ControlData.__doc__ = ("Compiled controllers (padded over controllers), sensor rows S over z, "
                       "sample masks over the grid, pre-drawn noise, open-loop voltages at the "
                       "grid points and the actuators' limits; state_at: first voltage entry "
                       "of the integrator's state.")
ControlWork = namedtuple("ControlWork", ["x", "held", "py_held", "count", "yin", "xn",
                                         "x_rec", "held_rec", "v_rec"])


def sample_times(controller: Controller, t_end: float) -> np.ndarray:
    """0, T, 2T, … < t_end (s): the controller's sample instants."""
    T = 1.0 / controller.sample_rate
    return np.arange(max(1, int(np.ceil(t_end / T - 1e-9)))) * T


def readings(controller: Controller, S_rows: np.ndarray, z: np.ndarray, k: int,
             noise: np.ndarray) -> np.ndarray:
    """A Python controller's inputs at its k-th sample: S z + noise, quantised."""
    y = S_rows @ z + noise[k]
    q = np.asarray(controller.quantization or np.zeros(len(S_rows)), dtype=float)
    return np.where(q > 0, np.round(y / np.where(q > 0, q, 1.0)) * q, y)


def draw_noise(controller: Controller, samples: int) -> np.ndarray:
    """(samples, inputs) sensor noise of the controller, reproducible from its seed."""
    ni = len(controller_inputs(controller))
    std = np.asarray(controller.noise_std or np.zeros(ni), dtype=float)
    if not np.any(std > 0):
        return np.zeros((samples, ni))
    return np.random.default_rng(controller.noise_seed).standard_normal((samples, ni)) * std


def pack_controllers(controllers: Sequence[Controller], actuators: Sequence[PiezoActuator],
                     sensor_rows: dict[str, np.ndarray], grid: np.ndarray, state_at: int,
                     v_open: np.ndarray) -> tuple[ControlData, list[int]]:
    """The compiled controllers' data over the integrator's ``grid`` (every sample instant
    is a grid point) and the indices of the Python callables among ``controllers``."""
    compiled = [c for c in controllers if not isinstance(c, FunctionController)]
    python = [i for i, c in enumerate(controllers) if isinstance(c, FunctionController)]
    act = {a.name: j for j, a in enumerate(actuators)}
    names = list(sensor_rows)
    S = np.array([sensor_rows[s] for s in names]).reshape(len(names), -1)
    systems = [discretize(c) for c in compiled]
    nc = len(compiled)
    nx = max([s[0].shape[0] for s in systems], default=0)
    ni = max([s[1].shape[1] for s in systems], default=0)
    no = max([s[2].shape[0] for s in systems], default=0)
    Ad, Bd = np.zeros((nc, nx, nx)), np.zeros((nc, nx, ni))
    Cd, Dd = np.zeros((nc, no, nx)), np.zeros((nc, no, ni))
    n_x, n_in, n_out = (np.zeros(nc, dtype=np.int64) for _ in range(3))
    in_row, out_act = np.zeros((nc, ni), dtype=np.int64), np.zeros((nc, no), dtype=np.int64)
    mask = np.zeros((nc, grid.size), dtype=np.bool_)
    update = np.zeros(grid.size, dtype=np.bool_)
    samples = [sample_times(c, grid[-1]) for c in controllers]
    for c, times in zip(controllers, samples):
        update[_grid_index(grid, times)] = True
    most = max([t.size for t in samples], default=0)
    noise = np.zeros((nc, most, ni))
    quant = np.zeros((nc, ni))
    for i, (c, (A, B, C, D)) in enumerate(zip(compiled, systems)):
        x, k, o = A.shape[0], B.shape[1], C.shape[0]
        Ad[i, :x, :x], Bd[i, :x, :k], Cd[i, :o, :x], Dd[i, :o, :k] = A, B, C, D
        n_x[i], n_in[i], n_out[i] = x, k, o
        in_row[i, :k] = [names.index(s) for s in controller_inputs(c)]
        out_act[i, :o] = [act[a] for a in controller_outputs(c)]
        times = sample_times(c, grid[-1])
        mask[i, _grid_index(grid, times)] = True
        noise[i, :times.size, :k] = draw_noise(c, times.size)
        quant[i, :k] = c.quantization or np.zeros(k)
    limit = np.array([a.limit for a in actuators], dtype=float)
    data = ControlData(Ad, Bd, Cd, Dd, n_x, n_in, n_out, in_row, out_act,
                       np.ascontiguousarray(S), mask, update, noise, quant,
                       np.ascontiguousarray(v_open, dtype=float), limit, state_at)
    return data, python


def control_work(data: ControlData) -> ControlWork:
    """Fresh controller states (zero), held outputs and the records over the grid."""
    nc, no, nx = data.Cd.shape
    ng, na = data.v_open.shape
    return ControlWork(np.zeros((nc, nx)), np.zeros((nc, no)), np.zeros(na),
                       np.zeros(nc, dtype=np.int64), np.zeros(max(data.Bd.shape[2], 1)),
                       np.zeros(max(nx, 1)), np.zeros((ng, nc, nx)), np.zeros((ng, nc, no)),
                       np.zeros((ng, na)))


def _grid_index(grid: np.ndarray, times: np.ndarray) -> np.ndarray:
    i = np.searchsorted(grid, times - 1e-12 * max(1.0, grid[-1]))
    i = np.minimum(i, grid.size - 1)
    assert np.allclose(grid[i], times, rtol=0, atol=1e-9 * max(1.0, grid[-1])), "off-grid sample"
    return i
