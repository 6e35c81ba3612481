"""Sampled controllers with zero-order hold outside the first-order prescribed path
(docs/closed_loop.md): a Python loop over the sample intervals that, at each sample instant,
reads the sensors from the elastic coordinates, updates the controllers (the compiled update
of `dynamics/_controllers_numba.py` on the discretisation of `dynamics/controllers.py`, the
Python callables as in `closed_loop.py`), and integrates one interval with the held voltages
constant. Here the integrator is the nonlinear model's Gauss collocation (`gauss.py`): its
error-controlled steps end at every sample instant, where `gauss.integrate_adaptive` updates
the loop, or, with a fixed step, `integrate_gauss_sampled` below.
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Sequence

import numpy as np

from ..dynamics.controllers import control_work, pack_controllers, readings, sample_times
from ..dynamics.nonlinear import NonlinearSystem
from ..dynamics.nonlinear_kernel import StageInputs
from ..errors import SimulationError, UnstableLoop
from ..model import Controller, FunctionController, PiezoActuator
from .closed_loop import call_controller
from .gauss import NEWTON_MAX, NEWTON_TOL, NODES, ROUND_OFF
from .gauss_steps import GAUSS2, newton_settings

# |node angle| (rad) beyond which the response of a closed loop counts as unbounded: the link
# curled more than a full turn
BOUND = 2.0 * np.pi


def sample_grid(controllers: Sequence[Controller], t_end: float,
                times: np.ndarray | Sequence[float] = ()) -> np.ndarray:
    """Every controller's sample instants, ``times`` (s) and t_end, sorted, distinct (s)."""
    grid = np.union1d(np.concatenate([sample_times(c, t_end) for c in controllers]),
                      np.union1d(times, [t_end]))
    keep = np.concatenate([[True], np.diff(grid) > 1e-9 * max(1.0, t_end)])
    grid = grid[keep]
    grid[-1] = t_end
    return grid


class SampledLoop:
    """The controllers of a run on the sample grid: ``update(i, z)`` → held voltages (V)."""

    def __init__(self, controllers: Sequence[Controller], actuators: Sequence[PiezoActuator],
                 sensor_rows: dict[str, np.ndarray], grid: np.ndarray,
                 v_open: np.ndarray) -> None:
        self.grid = grid
        self.n = next(iter(sensor_rows.values())).size if sensor_rows else 0
        self.n_act = len(actuators)
        self.data, index = pack_controllers(controllers, actuators, sensor_rows, grid, self.n,
                                            v_open)
        self.python_index = index
        self.python: list[FunctionController] = [controllers[i] for i in index]  # type: ignore
        act = {a.name: j for j, a in enumerate(actuators)}
        self.rows = [np.array([sensor_rows[s] for s in c.inputs]) for c in self.python]
        self.points = [np.searchsorted(grid, sample_times(c, grid[-1]) - 1e-9
                                       * max(1.0, grid[-1])) for c in self.python]
        from ..dynamics.controllers import draw_noise

        self.noise = [draw_noise(c, p.size) for c, p in zip(self.python, self.points)]
        self.outputs = [np.array([act[a] for a in c.outputs], dtype=np.int64)
                        for c in self.python]
        self.start()

    def start(self) -> None:
        """Fresh controller states (each integration pass starts from them)."""
        self.work = control_work(self.data)
        self.functions = [copy.deepcopy(c.function) for c in self.python]
        self.held = [np.zeros(len(c.outputs)) for c in self.python]
        self.commands = [np.zeros((self.grid.size, len(c.outputs))) for c in self.python]
        self.counts = [0] * len(self.python)
        self.buffer = np.zeros(self.n + self.n_act)

    def integrate(self, system: NonlinearSystem, step: float,
                  on_progress: Callable[[float], None] | None = None
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """integrate_gauss_sampled with this loop (what gauss.solve_nonlinear calls)."""
        return integrate_gauss_sampled(system, self, step, on_progress)

    def check_bounded(self, system: NonlinearSystem, t: float, q: np.ndarray) -> None:
        """UnstableLoop at t (s) if the links curled beyond BOUND at q."""
        if np.abs(system.A @ q).max() > BOUND:
            raise UnstableLoop(t, "the links curled beyond a full turn")

    def held_voltages(self, t: np.ndarray, before: bool = False) -> np.ndarray:
        """The voltages (nt, n_act) held at times t (s) of the last integration pass (at a
        sample instant: the new value, or the one held until then if ``before``)."""
        shift = (-1e-9 if before else 1e-9) * max(1.0, self.grid[-1])
        i = np.searchsorted(self.grid, t + shift, side="right") - 1
        return self.work.v_rec[np.clip(i, 0, self.grid.size - 1)]

    def update(self, i: int, z: np.ndarray) -> np.ndarray:
        """The voltages (n_act,) held from grid point i on, given z there."""
        from ..dynamics._controllers_numba import record, sample

        t = float(self.grid[i])
        for j, c in enumerate(self.python):
            if self.counts[j] < self.points[j].size and self.points[j][self.counts[j]] == i:
                y = readings(c, self.rows[j], z, self.counts[j], self.noise[j])
                self.held[j] = call_controller(c, self.functions[j], t, y)
                self.counts[j] += 1
        self.work.py_held[:] = 0.0
        for j in range(len(self.python)):
            np.add.at(self.work.py_held, self.outputs[j], self.held[j])
            self.commands[j][i:] = self.held[j]
        self.buffer[:self.n] = z
        ok = sample(self.data, self.work, i, self.buffer)
        record(self.data, self.work, i, self.buffer)
        if not ok:
            raise UnstableLoop(t, "a controller state or output passed its bound")
        return self.buffer[self.n:].copy()


def integrate_gauss_sampled(system: NonlinearSystem, loop: SampledLoop, step: float,
                            on_progress: Callable[[float], None] | None = None
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Step ends t, q and q̇ there from rest: each sample interval of ``loop.grid`` cut into
    equal steps ≤ ``step`` (s), the actuators' forces B V held over it."""
    from ._gauss_numba import gauss_loop, residual_model

    grid = loop.grid
    counts = np.maximum(1, np.ceil(np.diff(grid) / step - 1e-9).astype(np.int64))
    first = np.concatenate([[0], np.cumsum(counts)])
    h_of = np.diff(grid) / counts
    offsets = np.concatenate([np.arange(c) * h for c, h in zip(counts, h_of)])
    t_ends = np.append(np.repeat(grid[:-1], counts) + offsets, grid[-1])
    h_step = np.diff(t_ends)
    stage_t = (t_ends[:-1, None] + NODES[None, :] * h_step[:, None]).ravel()
    inputs = system.node_inputs(stage_t)
    n = system.n
    q = np.zeros((t_ends.size, n))
    q[0] = system.initial_coordinates()
    v = np.zeros_like(q)
    load = np.zeros((stage_t.size, n))
    data = system.kernel_data()
    model = residual_model(data)
    rows = inputs.stage_inputs(load)
    B = system.actuator_B
    newton = newton_settings(NEWTON_TOL, NEWTON_MAX, ROUND_OFF * system.max_frequency**2,
                             False)
    peak = np.zeros(1)
    loop.start()
    X = np.zeros((2, n))
    for i in range(grid.size - 1):
        a, b = int(first[i]), int(first[i + 1])
        V = loop.update(i, q[a])
        rows.u[2 * a:2 * b] = B @ V
        if i == 0:
            X[:] = system.accelerations(np.zeros(1), q[:1], v[:1])  # (open-loop load: V(0))
        failed, _, _ = gauss_loop(model, StageInputs(*(r[2 * a:2 * b] for r in rows)),
                                  q[a:b + 1], v[a:b + 1], X, float(h_of[i]), GAUSS2, newton,
                                  i > 0, peak)
        if failed >= 0 or not np.all(np.isfinite(q[b])):
            raise SimulationError(f"the nonlinear step at t = {t_ends[a + max(failed, 0)]:.4g} s "
                                  f"did not converge in {NEWTON_MAX} Newton iterations "
                                  f"(h = {h_of[i]:.3g} s): reduce the step")
        if np.abs(system.A @ q[b]).max() > BOUND:
            raise UnstableLoop(float(grid[i + 1]), "the links curled beyond a full turn")
        if on_progress is not None and i % 50 == 0:
            on_progress(float(grid[i + 1]))
    loop.update(grid.size - 1, q[-1])  # the records at t_end
    return t_ends, q, v
