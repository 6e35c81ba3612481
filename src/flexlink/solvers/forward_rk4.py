"""The fast forward-dynamics integrator: compiled classical RK4 on a fixed grid with
Richardson error control (ARCHITECTURE.md, "Why the solver looks like this").

The grid is the output times plus every breakpoint of the inputs (bang-bang switches, table
samples, ends of reference moves: `forward_kernel.breakpoints`), each interval cut into
``substeps`` equal steps, so no step straddles a jump of an input. All inputs are evaluated
before the loop, vectorised, at every stage time (`forward_kernel.inputs`); the loop
(`_forward_rk4_numba.rk4_steps`) then calls only the compiled right-hand side.

Error control as in the Lawson integrator of prescribed runs: the run with ``substeps`` is
compared at the outputs with the run with half as many (Richardson, error ≈ difference / 15
for a fourth-order method), doubling until each state group (p, ṗ, z, ż, integrals) agrees
within atol + rtol · its peak. A run whose state grows without bound at the same time for
every step size is a blow-up of the model, reported as such.
"""

from __future__ import annotations

import itertools

import numpy as np

from ..dynamics.forward import ForwardSystem
from ..dynamics.forward_kernel import ForwardData, breakpoints, inputs, pack, voltage_columns
from ..errors import SimulationError
from .forward_sampled import held_rows, inner_nodes, run_steps
from .gauss_sampled import SampledLoop
from .solution import RICHARDSON, Accuracy, Progress, Solution

_MAX_DOUBLINGS = 8
_RICHARDSON = 15.0  # (2⁴ − 1): the coarse-fine difference over the fine run's error
_STABLE_H_OMEGA = 2.0  # h·ω_max of the first coarse run (RK4 is stable up to 2.83)


class BlowUp(SimulationError):
    """The state grew without bound; ``t`` is when (s)."""

    def __init__(self, t: float) -> None:
        self.t = t
        super().__init__(f"the state grew without bound at t = {t:.6g} s")


def integrate_forward_rk4(system: ForwardSystem, t_out: np.ndarray, rtol: float, atol: float,
                          on_progress: Progress | None = None,
                          loop: SampledLoop | None = None) -> Solution:
    """Coordinates [p_free, z], their rates and accelerations at t_out from the system's
    initial state; the servo integrals as ``extra`` (the contract of solvers.forward).
    ``loop``: sampled controllers driving the actuators (`forward_sampled.py`); each pass
    of the error control runs them afresh."""
    from ..dynamics._forward_numba import workspace

    data = pack(system)
    work = workspace(data, len(system.servos))
    nodes, record = _nodes(system, t_out, loop)
    omega = _stiffest_rate(data, work, system)
    # The coarse run of the first comparison takes steps of ≲ 2/ω_max: inside RK4's
    # stability region for the stiffest mode of the coupled system at t = 0.
    widest = float(np.diff(nodes).max()) if nodes.size > 1 else 1.0
    substeps = 2 * max(1, int(np.ceil(widest * omega / (2 * _STABLE_H_OMEGA))))
    y0 = system.initial_state()
    coarse = _run(data, work, system, y0, nodes, record, t_out.size, substeps // 2, None,
                  loop)
    for _ in range(_MAX_DOUBLINGS):
        fine = _run(data, work, system, y0, nodes, record, t_out.size, substeps, on_progress,
                    loop)
        if isinstance(fine, BlowUp) and isinstance(coarse, BlowUp) \
                and abs(fine.t - coarse.t) <= 0.05 * fine.t:
            raise fine  # the same time at two step sizes: the model, not the steps
        if not isinstance(fine, BlowUp) and not isinstance(coarse, BlowUp) \
                and runs_agree(system, fine, coarse, rtol, atol):
            return forward_solution(
                data, work, system, t_out, fine, substeps, loop,
                accuracy=Accuracy(rtol, runs_error(system, fine, coarse), RICHARDSON))
        coarse = fine
        substeps *= 2
    if isinstance(coarse, BlowUp):
        raise coarse
    raise SimulationError(
        f"the forward run did not reach rtol = {rtol:g}, atol = {atol:g} with {substeps // 2} "
        "steps per output interval; loosen the tolerances or use method = \"Radau\"")


def _stiffest_rate(data: ForwardData, work: tuple, system: ForwardSystem) -> float:
    """Largest |eigenvalue| (1/s) of the Jacobian of the equations at the initial state: the
    stiffest mode of the coupled system (free rigid coordinates lower the mass a mode sees,
    so it can exceed the clamped links' frequencies), or a stiff servo loop."""
    from ._forward_rk4_numba import jacobian

    y0 = system.initial_state()
    J = np.empty((y0.size, y0.size))
    jacobian(data, work, inputs(system, np.array([0.0]))[0], y0, J)
    radius = float(np.abs(np.linalg.eigvals(J)).max()) if np.all(np.isfinite(J)) else 0.0
    clamped = max((float(2 * np.pi * d.natural_frequencies_hz.max()) for d in system.modal
                   if d.natural_frequencies_hz.size), default=0.0)  # rigid links have none
    return max(radius, clamped)


def _nodes(system: ForwardSystem, t_out: np.ndarray, loop: SampledLoop | None
           ) -> tuple[np.ndarray, np.ndarray]:
    """Grid nodes (outputs, inner breakpoints and controller samples) and, per node, its
    output index or −1."""
    inner = inner_nodes(loop, t_out, breakpoints(system))
    nodes = np.union1d(t_out, inner)
    record = np.full(nodes.size, -1, dtype=np.int64)
    record[np.searchsorted(nodes, t_out)] = np.arange(t_out.size)
    return nodes, record


def _run(data: ForwardData, work: tuple, system: ForwardSystem, y0: np.ndarray,
         nodes: np.ndarray, record: np.ndarray, n_out: int, substeps: int,
         on_progress: Progress | None, loop: SampledLoop | None = None) -> np.ndarray | BlowUp:
    """States at the outputs (n_out, len(y0)) with ``substeps`` steps per node interval, or
    the BlowUp."""
    from ._forward_rk4_numba import rk4_steps

    width = np.diff(nodes)
    h = np.repeat(width / substeps, substeps)
    starts = (nodes[:-1, None] + width[:, None] * (np.arange(substeps) / substeps)).ravel()
    # Stage inputs read just inside the step: a jump on a node is taken from the right side.
    inside = 1e-9 * h
    times = np.stack([starts + inside, starts + 0.5 * h, starts + h - inside], 1)
    u = inputs(system, times.ravel()).reshape(times.shape + (-1,))
    step_record = np.full(h.size, -1, dtype=np.int64)
    step_record[substeps - 1::substeps] = record[1:]
    states = np.empty((n_out, y0.size))
    states[0] = y0
    y = y0.copy()
    nu, n = len(system.free), system.n
    bad = run_steps(lambda a, b: rk4_steps(data, work, y, u, h, step_record, a, b, states),
                    y, starts, h, u, on_progress, loop, voltage_columns(system),
                    slice(2 * nu, 2 * nu + n))
    return BlowUp(float(starts[bad])) if bad >= 0 else states


def _group_errors(system: ForwardSystem, fine: np.ndarray, coarse: np.ndarray
                  ) -> list[tuple[float, float]]:
    """(estimated error |fine − coarse| / 15, peak |fine|) of each state group (p, ṗ, z, ż,
    integrals) that has columns."""
    nu, n = len(system.free), system.n
    cuts = np.cumsum([0, nu, nu, n, n, fine.shape[1] - 2 * nu - 2 * n])
    return [(float(np.abs(fine[:, a:b] - coarse[:, a:b]).max() / _RICHARDSON),
             float(np.abs(fine[:, a:b]).max())) for a, b in itertools.pairwise(cuts) if b > a]


def runs_agree(system: ForwardSystem, fine: np.ndarray, coarse: np.ndarray, rtol: float,
           atol: float) -> bool:
    """Whether the fine run's estimated error is within atol + rtol · peak of each group."""
    return all(error <= atol + rtol * peak
               for error, peak in _group_errors(system, fine, coarse))


def runs_error(system: ForwardSystem, fine: np.ndarray, coarse: np.ndarray) -> float:
    """The fine run's estimated error relative to its group's peak, the largest over the
    groups that move (an Accuracy's estimate)."""
    return max((error / peak for error, peak in _group_errors(system, fine, coarse)
                if peak > 0.0), default=0.0)


def forward_solution(data: ForwardData, work: tuple, system: ForwardSystem, t_out: np.ndarray,
                     states: np.ndarray, substeps: int, loop: SampledLoop | None = None,
                     method: str = "rk4", accuracy: Accuracy | None = None) -> Solution:
    """The Solution from the states at t_out; accelerations with the inputs there (with a
    ``loop``: its held voltages); ``method``: the loop that computed the states;
    ``accuracy``: what the error control reached."""
    from ._forward_rk4_numba import rates_at

    nu, n = len(system.free), system.n
    rates = np.empty_like(states)
    u = inputs(system, t_out)
    if loop is not None:
        u = held_rows(loop, t_out, u, voltage_columns(system))
    rates_at(data, work, u, states, rates)
    p, pd = states[:, :nu], states[:, nu:2 * nu]
    z, zd = states[:, 2 * nu:2 * nu + n], states[:, 2 * nu + n:2 * nu + 2 * n]
    return Solution(t_out, np.hstack([p, z]), np.hstack([pd, zd]),
                    np.hstack([rates[:, nu:2 * nu], rates[:, 2 * nu + n:2 * nu + 2 * n]]),
                    method, {"steps_per_output_interval": substeps},
                    extra=states[:, 2 * nu + 2 * n:], accuracy=accuracy)
