"""Forward-dynamics runs (free or pinned base, driven joints): the compiled implicit
integrator (``method = "radau5"``, `radau.py`: Radau IIA of order 5, error-controlled
adaptive steps; a run's "lawson" or "magnus" maps to it) or scipy's ``solve_ivp`` (DOP853,
Radau, …: the tight-tolerance reference).

The state is [p_free, ṗ_free, z, ż, servo integrals]; the coupled equations of
`dynamics.forward.ForwardSystem` (nonlinear in the rigid coordinates, first order in z) give
its rate — through the compiled kernel (`dynamics/_forward_numba.py`, tested against the
numpy equations to round-off) unless ``compiled=False``. The `Solution`'s coordinates are
[p_free, z], its ``extra`` the servo integrals. Sampled controllers (docs/closed_loop.md)
run with the compiled integrator: their sample instants are nodes no step straddles, and
their held voltages overwrite the actuator voltage columns of the input rows
(`forward_kernel.voltage_columns`). The compiled integrator keeps the momentum that the
inputs determine (`dynamics.momentum_projection`); the outputs at t_out (accelerations,
frames, joint torques, momentum) come from one compiled pass (`dynamics.forward_outputs`).
"""

from __future__ import annotations

import numpy as np

from ..dynamics import forward_kernel
from ..dynamics.forward import ForwardSystem
from ..dynamics.forward_kernel import ForwardData, breakpoints, inputs, pack, voltage_columns
from ..dynamics.forward_outputs import ForwardOutputs, forward_outputs
from ..dynamics.momentum_projection import Projection, projection, start_values
from ..errors import SimulationError, StoppedRun, UnstableLoop
from .error_weights import displacement_weights
from .gauss_sampled import SampledLoop
from .ode import Stalled, integrate_ivp
from .radau import RadauStop, integrate_radau
from .solution import LOCAL_CONTROL, SCIPY, Accuracy, Progress, Solution

DEFAULT_METHOD = "DOP853"  # of integrate_forward: the reference
FAST_METHOD = "radau5"  # what a run's "lawson" or "magnus" maps to
EXPLICIT_METHODS = ("RK45", "DOP853")  # scipy's, of simulation.method
MAX_STEP_OUTPUTS = 10  # longest solve_ivp step, in output intervals (simulation.dt_out)


def integrate_forward(system: ForwardSystem, t_out: np.ndarray, rtol: float, atol: float,
                      method: str = DEFAULT_METHOD, on_progress: Progress | None = None,
                      compiled: bool = True, loop: SampledLoop | None = None,
                      with_outputs: bool = False, steps: list | None = None,
                      rate_weights: np.ndarray | None = None
                      ) -> Solution | tuple[Solution, ForwardOutputs]:
    """Coordinates [p_free, z], their rates and accelerations at t_out from the system's
    initial state; the servo integrals as ``extra``. ``method``: FAST_METHOD (the compiled
    Radau IIA integrator) or a solve_ivp method, whose right-hand side is the compiled
    kernel or (``compiled=False``) the numpy ForwardSystem. ``with_outputs``: also the
    frames, joint torques and momentum at t_out (`forward_outputs`), as (Solution,
    ForwardOutputs).

    solve_ivp's step is limited to MAX_STEP_OUTPUTS output intervals: while nothing moves
    the error estimate is zero and the step would otherwise grow past the start of an
    input (the compiled integrator ends steps on every breakpoint of the inputs instead).

    ``loop``: sampled controllers driving the actuators, compiled integrator only; a
    blow-up is then reported as an unstable closed loop. ``steps``: a list that receives
    the compiled integrator's accepted steps (`radau.integrate_radau`). ``rate_weights``
    (n,): the compiled integrator's error weights of the elastic rates
    (`error_weights.elastic_rate_weights`; None: 1); its elastic coordinates weigh ω_j/ω₁
    times their rate's (`state_weights`)."""
    if loop is not None and method != FAST_METHOD:
        raise ValueError(f"controllers on a forward run need the compiled integrator: method "
                         f"= {method!r} cannot hold sampled voltages; use \"lawson\"")
    max_step = MAX_STEP_OUTPUTS * float(np.min(np.diff(t_out))) if t_out.size > 1 else np.inf
    if method == FAST_METHOD:
        solution, outputs = _integrate_compiled(system, t_out, rtol, atol, np.inf, on_progress,
                                                loop, steps, rate_weights)
        return (solution, outputs) if with_outputs else solution
    nu, n = len(system.free), system.n
    if compiled:
        from ..dynamics._forward_numba import rates as kernel
        from ..dynamics._forward_numba import workspace

        data = forward_kernel.pack(system)
        work = workspace(data, len(system.servos))

    def rhs(t: float, y: np.ndarray) -> np.ndarray:
        if on_progress is not None:
            on_progress(t)
        if compiled:
            dy = np.empty_like(y)
            kernel(data, work, forward_kernel.inputs(system, np.array([t]))[0], y, dy)
            return dy
        parts = split_state(system, y[None])
        pdd, zdd, rates = system.accelerations(np.array([t]), *parts)
        return np.concatenate([y[nu:2 * nu], pdd[0], y[2 * nu + n:2 * nu + 2 * n], zdd[0],
                               rates[0]])

    try:
        y, evaluations = integrate_ivp(rhs, system.initial_state(), t_out, rtol, atol, method,
                                       max_step)
    except Stalled as exc:
        raise SimulationError(_stall_message(system, exc.t, "the time step collapsed",
                                             method)) from None
    p_free, pd_free, z, zd, integral = split_state(system, y)
    pdd_free, zdd, _ = system.accelerations(t_out, p_free, pd_free, z, zd, integral)
    solution = Solution(t_out, np.hstack([p_free, z]), np.hstack([pd_free, zd]),
                        np.hstack([pdd_free, zdd]), method, {"rhs_evaluations": evaluations},
                        extra=integral, accuracy=Accuracy(rtol, None, SCIPY))
    if not with_outputs:
        return solution
    data = forward_kernel.pack(system)
    from ..dynamics._forward_numba import workspace

    return solution, forward_outputs(system, data, workspace(data, len(system.servos)),
                                     inputs(system, t_out), y)


def _integrate_compiled(system: ForwardSystem, t_out: np.ndarray, rtol: float, atol: float,
                        max_step: float, on_progress: Progress | None,
                        loop: SampledLoop | None, steps: list | None = None,
                        rate_weights: np.ndarray | None = None
                        ) -> tuple[Solution, ForwardOutputs]:
    """integrate_forward with the compiled Radau IIA integrator."""
    from ..dynamics._forward_numba import workspace

    data = pack(system)
    work = workspace(data, len(system.servos))
    y0 = system.initial_state()
    nu, n = len(system.free), system.n
    groups = error_groups(system, y0.size)
    u0 = inputs(system, t_out[:1])[0]
    known = projection(system, data, float(t_out[0]), u0.size)  # every column is integrated
    if known.active.size:
        start_values(known, data, work, u0, y0, float(t_out[-1]))
    try:
        states, stats = integrate_radau(
            data, work, y0, t_out, lambda t: inputs(system, t), breakpoints(system), rtol,
            atol, groups, max_step, on_progress=on_progress, loop=loop,
            held=voltage_columns(system) if loop is not None else slice(0, 0),
            z=slice(2 * nu, 2 * nu + n), projection=known, steps=steps,
            weights=state_weights(system, y0.size, rate_weights), box=system.free_travels(),
            bounds=deflection_bounds(system, y0.size), second_order=rate_pairs(nu, n))
    except RadauStop as exc:
        why = stop_reason(exc)
        if loop is not None and exc.why != "box":
            raise UnstableLoop(exc.t, why) from None
        raise StoppedRun(_stall_message(system, exc.t, why, FAST_METHOD), exc.t, exc.states,
                         exc.y, exc.why == "box") from None
    return forward_solution(data, work, system, t_out, states, stats, loop,
                            Accuracy(rtol, None, LOCAL_CONTROL), known)


def forward_solution(data: ForwardData, work: tuple, system: ForwardSystem, t_out: np.ndarray,
                     states: np.ndarray, stats: dict, loop: SampledLoop | None = None,
                     accuracy: Accuracy | None = None, scratch: Projection | None = None,
                     accelerations: np.ndarray | None = None
                     ) -> tuple[Solution, ForwardOutputs]:
    """The Solution from the states at t_out, and the outputs there (accelerations, frames,
    joint torques, momentum: one compiled pass) with the inputs there (with a ``loop``: its
    held voltages); ``accuracy``: what the integrator was asked for; ``scratch``: the run's
    projection record (its scratch arrays), if there is one; ``accelerations``: (p̈_free,
    z̈) (nt, ·) to take instead of solving for them."""
    nu, n = len(system.free), system.n
    u = inputs(system, t_out)
    if loop is not None:
        u[:, voltage_columns(system)] = loop.held_voltages(t_out)
    outputs = forward_outputs(system, data, work, u, states, scratch, accelerations)
    rates = outputs.rates
    p, pd = states[:, :nu], states[:, nu:2 * nu]
    z, zd = states[:, 2 * nu:2 * nu + n], states[:, 2 * nu + n:2 * nu + 2 * n]
    return Solution(t_out, np.hstack([p, z]), np.hstack([pd, zd]),
                    np.hstack([rates[:, nu:2 * nu], rates[:, 2 * nu + n:2 * nu + 2 * n]]),
                    FAST_METHOD, stats, extra=states[:, 2 * nu + 2 * n:],
                    accuracy=accuracy), outputs


def rate_pairs(nu: int, n: int) -> np.ndarray:
    """(2, nu + n): the state's coordinates p_free, z and the components that are their
    rates ṗ_free, ż (the state [p_free, ṗ_free, z, ż, …]; `_forward_numba.state_rates`)."""
    return np.array([np.r_[np.arange(nu), 2 * nu + np.arange(n)],
                     np.r_[nu + np.arange(nu), 2 * nu + n + np.arange(n)]], dtype=np.int64)


def deflection_bounds(system: ForwardSystem, size: int) -> np.ndarray:
    """Each elastic link's tip deflection w(L) as a row over the ``size`` state components,
    then its length (m): the compiled integrator stops at the first accepted step that ends
    with a tip beyond its link's length (the first-order model has left its range there,
    whether or not an output sample falls near it)."""
    nu = len(system.free)
    rows = []
    for body in system.bodies:
        tip = body.data.tip_value
        if body.data.n == 0 or not np.any(tip):
            continue
        row = np.zeros(size + 1)
        start = 2 * nu + body.offset - system.n_rigid  # body.offset: its column in x = [δp; z]
        row[start:start + tip.size] = tip
        row[size] = body.data.length
        rows.append(row)
    return np.array(rows).reshape(len(rows), size + 1)


def error_groups(system: ForwardSystem, size: int) -> np.ndarray:
    """The error group of each of the ``size`` state components (Radau IIA weighs each error
    against its group's peak): each rigid coordinate and rate its own (metres and radians
    differ), the elastic coordinates and rates by link, each extra state (servo integrals)
    its own."""
    nu, n = len(system.free), system.n
    links = np.repeat(np.arange(len(system.modal)), [d.n for d in system.modal])
    return np.concatenate([np.arange(2 * nu), 2 * nu + links,
                           2 * nu + len(system.modal) + links,
                           2 * nu + 2 * len(system.modal) + np.arange(size - 2 * nu - 2 * n)])


def state_weights(system: ForwardSystem, size: int, rate_weights: np.ndarray | None
                  ) -> np.ndarray:
    """The error weight of each of the ``size`` state components: ``rate_weights`` (n,) on
    the elastic rates (`error_weights.elastic_rate_weights`; None: 1), ω_j/ω₁ times that on
    the elastic coordinates (`error_weights.displacement_weights`: an amplitude error counts
    the same at every phase), 1 elsewhere."""
    nu, n = len(system.free), system.n
    weights = np.ones(size)
    rates = np.ones(n) if rate_weights is None else np.asarray(rate_weights, dtype=float)
    weights[2 * nu:2 * nu + n] = displacement_weights(system.modal, rates)
    weights[2 * nu + n:2 * nu + 2 * n] = rates
    return weights


def split_state(system: ForwardSystem, y: np.ndarray) -> tuple[np.ndarray, ...]:
    """p_free, ṗ_free, z, ż, integrals from states (nt, ·)."""
    nu, n = len(system.free), system.n
    cuts = np.cumsum([nu, nu, n, n])
    return tuple(np.split(y, cuts, axis=1))


def stop_reason(stop: RadauStop) -> str:
    """Why the compiled integrator stopped, in words."""
    return {"blow-up": "the state grew without bound",
            "box": "a cart or a slider left its travel"}.get(stop.why, "the time step collapsed")


def _stall_message(system: ForwardSystem, t: float, why: str, method: str) -> str:
    """The stop's words and a hint that fits the integrator that stopped (``method``: the
    compiled Radau IIA's FAST_METHOD or a scipy method's name)."""
    if not system.geometric_stiffening:
        hint = ("the paper's model (geometric_stiffening = false) is not energy-consistent "
                "and can blow up when a light link swings fast: set geometric_stiffening = "
                "true")
    else:
        hint = ("the first-order model may be outside its range (large deflections), a "
                "servo loop very stiff, or a mass, stiffness or load far off (check their "
                "values and units)")
        if method in EXPLICIT_METHODS:
            hint += (f"; method = \"{method}\" is explicit and stalls on stiff runs: try the "
                     "default \"lawson\"")
    return f"the forward run stalled at t = {t:.6g} s ({why}); {hint}"
