"""Sensitivities through sampled controllers on a forward run (`driven_sensitivities`): the
derivative of the voltages the controllers hold between samples.

At each sample instant t_i the run reads the sensors from the elastic coordinates z(t_i),
advances every controller that samples there (x ← A_d x + B_d y, output C_d x + D_d y,
plus the pre-drawn noise) and holds the actuators' voltages V_i (open loop plus outputs,
clipped to the limits) until the next sample (`dynamics/_controllers_numba.sample`). The
held values are a function of z(t_i), the controllers' states before the sample and the
model; their derivative is the same update of the moved model (`sampled_loop` of the moved
scenario: moved gains, filters, sensor rows, open-loop commands) applied to z and the
states moved along their sensitivities (central differences over the field's stencil: the
update is affine in them, so this is exact to round-off away from a limit). Between
samples the held voltages are constant, so their derivative enters the tangent as an
input held over each step (`radau_sensitivity.radau_tangent`'s ``held``).
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any

import numpy as np

from ..dynamics.forward_kernel import voltage_columns
from ..model import FunctionController, Scenario


def refused(scenario: Scenario) -> str | None:
    """What keeps the scenario's controllers from sensitivities, or None."""
    for i, c in enumerate(scenario.controllers):
        if isinstance(c, FunctionController):
            return (f"controllers[{i}] ({c.name!r}), a Python function controller (its "
                    "update is not differentiated)")
        if any(q > 0.0 for q in (getattr(c, "quantization", ()) or ())):
            return (f"controllers[{i}] ({c.name!r}) with quantization (a staircase: its "
                    "derivative is zero or undefined; set quantization = 0 for the "
                    "sensitivities)")
    if scenario.closures:
        return "sampled controllers on closed kinematic loops"
    return None


class HeldVoltages:
    """The nominal held voltages of a run with sampled controllers (replayed from its
    accepted steps) and, sample by sample during the tangent, their derivatives in the
    fields; ``moved[k]``: the moved models (`driven_sensitivities._Model`) of field k."""

    def __init__(self, nominal: Any, moved: list, fields: list, steps: Any, t: np.ndarray
                 ) -> None:
        from .forward import sampled_loop

        self.fields, self.steps = fields, steps
        self.columns = voltage_columns(nominal.system)
        nu = len(nominal.system.free)
        self.z = slice(2 * nu, 2 * nu + nominal.system.n)
        loop = sampled_loop(nominal.scenario, nominal.system, t)
        self.grid = loop.grid
        self.data = [[sampled_loop(md.scenario, md.system, t).data if md is not nominal
                      else loop.data for md in group] for group in moved]
        for k, group in enumerate(self.data):
            if any(d.mask.shape != loop.data.mask.shape for d in group):
                raise ValueError("moves the controllers' sample instants")
        self.tol = 1e-9 * max(1.0, float(self.grid[-1]))
        # the step that starts at each sample instant (the run stops at every one)
        first = np.searchsorted(steps.t, self.grid[:-1] - self.tol)
        if not np.allclose(steps.t[np.minimum(first, steps.t.size - 1)], self.grid[:-1],
                           rtol=0.0, atol=self.tol):
            raise ValueError("has a sample instant where no step starts")
        self.first = first
        self.of_step = np.searchsorted(self.grid, steps.t + self.tol, side="right") - 1
        # the nominal records, replaying the run's samples from its states there
        ng = self.grid.size
        for i in range(ng):
            y = steps.y0[first[i]] if i < ng - 1 else steps.y1[-1]
            loop.update(i, y[self.z])
        self.loop = loop
        work = loop.work
        self.v = work.v_rec.copy()  # (ng, a): the voltages held from grid point i on
        self.x, self.out = work.x_rec.copy(), work.held_rec.copy()
        self.counts = np.cumsum(loop.data.mask, axis=1) - loop.data.mask  # before sample i
        K = len(fields)
        self.dv = np.zeros((ng, *self.v.shape[1:], K))
        self.dx = np.zeros((ng, *self.x.shape[1:], K))
        self.dout = np.zeros((ng, *self.out.shape[1:], K))
        self.done = -1

    def voltages_at(self, times: np.ndarray) -> np.ndarray:
        """The held voltages (n, a) over the steps' stages at ``times`` (s) (a stage at a
        step's end, on the next sample instant, still holds its step's value)."""
        i = np.searchsorted(self.grid, times - self.tol, side="left") - 1
        return self.v[np.clip(i, 0, self.grid.size - 1)]

    def __call__(self, step: int, dy: np.ndarray) -> np.ndarray:
        """`radau_sensitivity.Held`: the voltages' derivative (a, K) over ``step``, whose
        start state's derivative is dy (m, K) (the samples up to its start taken)."""
        i = int(self.of_step[step])
        while self.done < i:
            self._sample(self.done + 1, self.steps.y0[self.first[self.done + 1]], dy)
        return self.dv[i]

    def finish(self, dy_end: np.ndarray) -> None:
        """The last sample (at t_end: the records there), from the end state's derivative."""
        self._sample(self.grid.size - 1, self.steps.y1[-1], dy_end)

    def _sample(self, i: int, y: np.ndarray, dy: np.ndarray) -> None:
        from ..dynamics._controllers_numba import sample
        from ..dynamics.controllers import control_work

        z, dz = y[self.z], dy[self.z]
        before = self.x[i - 1] if i > 0 else np.zeros_like(self.x[0])
        dbefore = self.dx[i - 1] if i > 0 else np.zeros_like(self.dx[0])
        v_before = self.v[i - 1] if i > 0 else np.zeros_like(self.v[0])
        dv_before = self.dv[i - 1] if i > 0 else np.zeros_like(self.dv[0])
        n = z.size
        for k, f in enumerate(self.fields):
            for j, w, d in zip(f.offsets, f.weights, self.data[k], strict=True):
                work = control_work(d)
                work.x[:] = before + j * f.step * dbefore[..., k]
                if i > 0:  # a controller that does not sample here keeps its output
                    work.held[:] = self.out[i - 1] + j * f.step * self.dout[i - 1, ..., k]
                work.count[:] = self.counts[:, i]
                buffer = np.concatenate([z + j * f.step * dz[:, k],
                                         v_before + j * f.step * dv_before[:, k]])
                sample(d, work, i, buffer)
                self.dv[i, ..., k] += (w / f.step) * buffer[n:]
                self.dx[i, ..., k] += (w / f.step) * work.x
                self.dout[i, ..., k] += (w / f.step) * work.held
        self.done = i

    def shifted(self, k: int, amount: float) -> Any:
        """A stand-in for the run's `SampledLoop` (what `forward_solution` and
        `forward.loop_values` read) with its records moved by ``amount`` × field k's
        derivatives."""
        loop = self.loop
        work = SimpleNamespace(v_rec=self.v + amount * self.dv[..., k],
                               x_rec=self.x + amount * self.dx[..., k],
                               held_rec=self.out + amount * self.dout[..., k])
        shim = SimpleNamespace(grid=loop.grid, work=work, commands=loop.commands,
                               python_index=loop.python_index)
        shim.held_voltages = lambda t, before=False: type(loop).held_voltages(shim, t, before)
        return shim
