"""Lawson (integrating-factor) fourth-order Runge–Kutta on a tabulated state matrix.

The fast integrator of the first-order model, ``method = "lawson"``. For ẏ = Ã(t) y with the
augmented state y = [z, ż, 1], each block of the coefficient table (``coefficient_table.py``)
splits Ã(t) = Ã_ref + ΔÃ(t), Ã_ref its value mid-block. The stiff, oscillatory part Ã_ref is
integrated exactly through E = exp(h/2 Ã_ref) (one exponential per block, not per step), the
slow remainder ΔÃ(t) y by classical RK4 in the interaction picture (Lawson 1967; Hochbruck &
Ostermann, Acta Numerica 19, 2010, §2.1):

    a = E(y + h/2 k₁),  b = E y + h/2 k₂,  c = E(E y + h k₃),
    y⁺ = E(E(y + h/6 k₁) + h/3 (k₂ + k₃)) + h/6 k₄,   k_i = ΔÃ(t_i)·(stage i).

Its error is fourth order in h·‖ΔÃ‖, which a slow manoeuvre keeps small: unlike an explicit
method its step is not bounded by the highest modal frequency, and unlike Magnus it needs no
exponential per step. On resting blocks ΔÃ = 0 and a step is one product with exp(h Ã).

Error control as for Magnus: the solution with steps h is compared with the one with steps 2h
(Richardson, error ≈ difference / 15), h halved until that is within atol + rtol · peak. The
number of steps per output interval is even, at least two.
The table itself is accurate to rtol of each coefficient's range (checked when it is built).
Coefficients too rough to tabulate cheaply (a measured motion's spline has a knot at every
sample) are integrated by Magnus instead, which assembles them where it needs them.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, replace

import numpy as np

from ..errors import SimulationError
from .batched_expm import expm_balanced
from .coefficient_table import (
    CoefficientTable,
    RoughCoefficients,
    TableLayout,
    layout,
    tabulate,
    tabulate_on,
)
from .magnus import (
    agree,
    agree_maxima,
    augmented,
    initial_step,
    integrate_magnus,
    richardson_error,
    richardson_error_maxima,
    state_rows,
)
from .solution import (
    FIXED_STEP,
    RICHARDSON,
    Accuracy,
    LinearSystem,
    Progress,
    Solution,
    StepReach,
    tip_bounds,
    unreached,
)
from .threads import single_threaded

_MAX_HALVINGS = 10
_ASSEMBLIES_PER_STEP = 4
_BLOCKS_PER_CALL = 64  # progress is reported between calls of the compiled loop


@dataclass(frozen=True)
class Discretisation:
    """What an adaptive Lawson run settled on: its table's layout, the steps per output
    interval, and each block's reference Ã_ref with its propagators exp(h/2 Ã_ref)ᵀ (static
    blocks: exp(Δt Ã)ᵀ). `integrate_lawson_on` runs another system on it: the split
    Ã = Ã_ref + ΔÃ(t) of a nearby system about the same Ã_ref is as accurate, and keeps
    its exponentials."""

    layout: TableLayout
    substeps: int
    rtol: float  # what the adaptive run was asked for
    reference: np.ndarray  # (blocks, n, 2n+1)
    propagators: np.ndarray  # (blocks, 2n+1, 2n+1), transposed as the compiled loop takes them
    # the settling run's own table (what `tabulate_on` of its system on the layout gives),
    # where its caller asked to keep it (`integrate_lawson_discretised`)
    table: CoefficientTable | None = None
    # and where asked for, the run's steps (what a reverse pass of them reads)
    steps: RunSteps | None = None


@dataclass(frozen=True)
class RunSteps:
    """The augmented states of a Lawson run: at the output times (nt, 2n+1) and at the start
    of every fine step on its moving blocks but an output interval's first (its state at the
    output time), in order (moving intervals × (substeps − 1), 2n+1)."""

    states: np.ndarray
    starts: np.ndarray


def integrate_lawson(system: LinearSystem, t_out: np.ndarray, rtol: float, atol: float,
                     on_progress: Progress | None = None) -> Solution:
    """The system's q, q̇, q̈ at t_out from rest at t_out[0]. Its method is "lawson", or
    "magnus" when the coefficients are too rough to tabulate (RoughCoefficients).

    The system's max_frequency (rad/s) sets the first step, as for Magnus; its
    coefficient_keys label instants with equal coefficients (rest phases), its breakpoints
    are times where they are not smooth (see coefficient_table)."""
    return integrate_lawson_discretised(system, t_out, rtol, atol, on_progress)[0]


def integrate_lawson_on(system: LinearSystem, t_out: np.ndarray,
                        discretisation: Discretisation) -> Solution:
    """The system's q, q̇, q̈ at t_out from rest at t_out[0] on a given discretisation (the
    table's layout and steps of an adaptive run of a nearby system), without error control:
    the runs of finite differences, which then differentiate what the integrator computes
    (no step or refinement decision changes between them)."""
    n = system.n
    rows = getattr(system, "state_rows", None) or (
        lambda times: state_rows(system.matrices, times))
    with single_threaded():
        table = tabulate_on(rows, t_out, discretisation.layout)
        # a static block's A is this system's own (joints at rest; its exact propagator
        # anew), a moving one's split about the settled reference
        static = table.static[:, None, None]
        table = replace(table, reference=np.ascontiguousarray(
            np.where(static, table.reference, discretisation.reference)))
        ET = discretisation.propagators.copy()
        # static blocks whose A all equal the settled ones keep their exponentials (the same
        # arguments): the joints rest at the same angles in the runs around one point
        if table.static.any() and not np.array_equal(table.reference,
                                                     discretisation.reference):
            ET[table.static] = _block_propagators(table, n, t_out, discretisation.substeps,
                                                  table.static)
        states, acc = _solve(table, n, t_out, discretisation.substeps, None, ET)
    if not np.all(np.isfinite(states)):
        raise SimulationError("the state became non-finite")
    stats = {"steps_per_output_interval": discretisation.substeps, "table_blocks": len(table)}
    return Solution(t_out, states[:, :n], states[:, n: 2 * n], acc, "lawson", stats,
                    accuracy=Accuracy(discretisation.rtol, None, FIXED_STEP))


def integrate_lawson_discretised(system: LinearSystem, t_out: np.ndarray, rtol: float,
                                 atol: float, on_progress: Progress | None = None,
                                 keep_table: bool = False, keep_steps: bool = False
                                 ) -> tuple[Solution, Discretisation | None]:
    """`integrate_lawson`, and the discretisation it settled on (None when it handed the
    run to Magnus); ``keep_table``: with the run's table (`Discretisation.table`, for the
    same system's sensitivities; not for discretisations handed to other processes);
    ``keep_steps``: with its steps too (`Discretisation.steps`, for its reverse pass)."""
    with single_threaded():
        try:
            start = prepare(system, t_out, rtol, atol)
        except RoughCoefficients:
            # Magnus assembles A where it needs it, which then costs less than a table.
            return integrate_magnus(system, t_out, rtol, atol, on_progress), None
        trail = _trail(start.table, start.n, start.substeps) if keep_steps else None
        solution, discretisation = finish(start, *first_pass(start, on_progress, trail),
                                          on_progress, trail=trail)
    return solution, replace(discretisation, table=start.table) if keep_table else discretisation


def _trail(table: CoefficientTable, n: int, substeps: int) -> np.ndarray:
    """Room for the start state of every fine step on the table's moving blocks but the
    first of each output interval (`RunSteps.starts`)."""
    intervals = int(np.sum((table.last - table.first)[~table.static]))
    return np.empty((intervals * (substeps - 1), 2 * n + 1))


@dataclass(frozen=True)
class Start:
    """An adaptive Lawson run up to its first pass: the table, the steps per output interval
    it starts with (even) and their block propagators (`_block_propagators`)."""

    n: int
    t_out: np.ndarray
    rtol: float
    atol: float
    table: CoefficientTable
    substeps: int
    ET: np.ndarray | None
    bounds: np.ndarray | None = None  # the system's `solution.tip_bounds`, read at every step


def prepare(system: LinearSystem, t_out: np.ndarray, rtol: float, atol: float,
            propagators: bool = True) -> Start:
    """The table and first steps of an adaptive run (RoughCoefficients: the coefficients are
    too rough to tabulate; Magnus then runs instead), with their block propagators unless
    ``propagators`` is false (ET None: `with_propagators` adds them)."""
    n, matrices = system.n, system.matrices
    first_step = initial_step(system.max_frequency)
    # A fourth-order error goes as h⁴: tighter tolerances start with shorter steps (the paper
    # arm meets rtol 1e-4 with the first step above, 1 ms).
    first_step *= min(1.0, (rtol / 1e-4) ** 0.25)
    # An even number of steps per output interval, so that the first error estimate can
    # compare with half as many on every interval, a block of one interval included.
    substeps = 2 * max(1, int(np.ceil(np.diff(t_out).max() / (2 * first_step))))
    # more than Magnus' 2 assemblies per step and pass would not pay
    # A system may bring its own (compiled) state rows M⁻¹[−K, −C, f].
    rows = getattr(system, "state_rows", None) or (
        lambda times: state_rows(matrices, times))
    # A system may tell its resting intervals itself (cheaper than keys on every middle).
    table = tabulate(rows, t_out,
                     system.coefficient_keys, tolerance=rtol,
                     budget=_ASSEMBLIES_PER_STEP * substeps,
                     breaks=system.breakpoints(),
                     resting=getattr(system, "resting_intervals", None))
    # The coarse pass (h doubled) runs alongside the fine one in the compiled loop: its
    # exp(h Ã_ref) = E² is what the fine steps use for E(E y) too, its E⁴ the square of
    # that; a static block's exp(Δt Ã) does not depend on h. One Padé exponential per
    # block and pass with a new h.
    start = Start(n, t_out, rtol, atol, table, substeps, None, tip_bounds(system))
    return with_propagators(start) if propagators else start


def with_propagators(start: Start) -> Start:
    """The start with its block propagators (`_block_propagators`)."""
    return replace(start, ET=_block_propagators(start.table, start.n, start.t_out,
                                                start.substeps))


def first_pass(start: Start, on_progress: Progress | None = None,
               trail: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, StepReach | None]:
    """States, z̈, the running maxima of the run's first pass (fine and coarse steps) and
    its fine steps' reach of the start's bounds: what `finish` takes; ``trail`` (`_trail`):
    filled with its fine steps' start states."""
    # The first comparison from the loop's running maxima (no coarse states kept).
    reach = unreached(start.bounds)
    states, acc, _, peak, spread = _run(start.table, start.n, start.t_out, start.substeps,
                                        on_progress, start.ET, coarse=True, keep_coarse=False,
                                        trail=trail, bounds=start.bounds, reach=reach)
    return states, acc, peak, spread, reach


def finish(start: Start, states: np.ndarray, acc: np.ndarray, peak: np.ndarray,
           spread: np.ndarray, reach: StepReach | None = None,
           on_progress: Progress | None = None,
           trail: np.ndarray | None = None) -> tuple[Solution, Discretisation]:
    """The adaptive run from its first pass (states, z̈, the running maxima of `_run`
    with the coarse pass and its steps' reach of the start's bounds, None if not read):
    accepted, or steps halved until the Richardson check passes.
    ``trail``: the first pass's step states (`first_pass`); then the discretisation keeps
    the accepted pass's (`Discretisation.steps`)."""
    n, t_out, rtol, atol, table = start.n, start.t_out, start.rtol, start.atol, start.table
    substeps, ET = start.substeps, start.ET
    moving = ~table.static
    accepted = agree_maxima(peak[:-1], spread[:-1], n, rtol, atol)
    estimate = richardson_error_maxima(peak[:-1], spread[:-1], n)
    for _ in range(_MAX_HALVINGS):
        if accepted:
            stats = {"steps_per_output_interval": substeps, "table_blocks": len(table)}
            return (Solution(t_out, states[:, :n], states[:, n: 2 * n], acc, "lawson",
                             stats, accuracy=Accuracy(rtol, estimate, RICHARDSON),
                             reach=reach),
                    Discretisation(layout(table, t_out.size), substeps, rtol,
                                   table.reference, ET, steps=None if trail is None
                                   else RunSteps(states, trail)))
        coarse = states
        substeps *= 2
        ET = ET.copy()
        ET[moving] = _block_propagators(table, n, t_out, substeps, moving)
        trail = None if trail is None else _trail(table, n, substeps)
        reach = unreached(start.bounds)
        states, acc, *_ = _run(table, n, t_out, substeps, on_progress, ET, coarse=False,
                               trail=trail, bounds=start.bounds, reach=reach)
        accepted = agree(states[:, :-1], states[:, :-1], coarse[:, :-1], n, rtol, atol)
        estimate = richardson_error(states[:, :-1], coarse[:, :-1], n)
    raise SimulationError(
        f"the integration did not reach rtol = {rtol:g}, atol = {atol:g} with {substeps} steps "
        "per output interval; loosen the tolerances or check the model"
    )


def load_compiled_loop() -> None:
    """Load (or, on a first run, compile) the compiled step loop and the prescribed path's
    kernels (dynamics/prescribed_kernel.py) now, for a process about to run prescribed
    Lawson runs (a sweep's worker)."""
    from ._lawson_numba import load as load_loop

    load_loop()
    # The prescribed path's compiled assembly and channels (a table, then frames).
    from ..dynamics.prescribed_kernel import load as load_kernels

    load_kernels()


def preload_compiled_loop() -> threading.Thread:
    """`load_compiled_loop` in a background thread, for a caller that knows a Lawson run is
    coming: numba's import, its cache and LLVM's code generation (which releases the
    interpreter lock) then overlap the caller's other start-up work. An error here is left
    for the run to raise.

    Join the returned thread before calling compiled code: numba registers argument types
    while it loads, and a call that types its arguments meanwhile can fail ("dictionary
    changed size during iteration" in its type dispatch)."""

    def load() -> None:
        try:
            load_compiled_loop()
        except Exception:  # noqa: BLE001, S110 — the run reports it
            pass

    thread = threading.Thread(target=load, name="flexlink-preload-lawson", daemon=True)
    thread.start()
    return thread


def _solve(
    table: CoefficientTable, n: int, t_out: np.ndarray, substeps: int,
    on_progress: Progress | None, ET: np.ndarray | None = None,
    trail: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Augmented states (nt, 2n+1) and z̈ (nt, n) with `substeps` steps per output interval;
    ET: the block propagators for these substeps if known (_block_propagators); ``trail``
    (`_trail`): filled with the fine steps' start states."""
    states, acc, *_ = _run(table, n, t_out, substeps, on_progress, ET, coarse=False,
                           trail=trail)
    return states, acc


def _run(
    table: CoefficientTable, n: int, t_out: np.ndarray, substeps: int,
    on_progress: Progress | None, ET: np.ndarray | None, coarse: bool,
    keep_coarse: bool = True, trail: np.ndarray | None = None,
    bounds: np.ndarray | None = None, reach: StepReach | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """States, z̈, (coarse and keep_coarse) the states of the pass with half the steps, and
    per state component the largest |fine state| and (coarse) |fine − coarse state| over
    the output times (what agree_maxima reads); ``trail`` (`_trail`), if given, filled with
    the fine steps' start states; ``reach`` (`unreached` of ``bounds``, the system's
    `solution.tip_bounds`), if given, filled with the fine steps' reach of them."""
    from ._lawson_numba import lawson_blocks  # numba's import is slow: only when used

    if coarse and substeps % 2:
        raise ValueError(f"the coarse pass needs an even number of steps, got {substeps}")
    if ET is None:
        ET = _block_propagators(table, n, t_out, substeps)
    E2T, E4T, polyT, referenceT = loop_matrices(table, ET, coarse)
    m = 2 * n + 1
    states = np.empty((t_out.size, m))
    coarse_states = np.empty((t_out.size if coarse and keep_coarse else 0, m))
    acc = np.empty((t_out.size, n))
    y = np.zeros(m)
    y[-1] = 1.0
    yc = y.copy()
    states[0] = y
    if coarse_states.shape[0]:
        coarse_states[0] = y
    peak = np.abs(y)  # running maxima over the output times, kept by the loop
    spread = np.zeros(m)
    acc[0] = table.poly[0, 0] @ y  # A at τ = 0 of the first block
    rows = np.zeros((0, m)) if trail is None else trail
    limits = np.zeros((0, m)) if bounds is None or reach is None else bounds
    far = reach.peak if reach is not None else np.zeros(0)
    beyond = reach.beyond if reach is not None else np.zeros(0)
    # each call's first row of the trail: the fine steps of the moving blocks before it
    steps = np.where(table.static, 0, (table.last - table.first) * (substeps - 1))
    for lo in range(0, len(table), _BLOCKS_PER_CALL):
        sl = slice(lo, lo + _BLOCKS_PER_CALL)
        lawson_blocks(y, yc, t_out, table.first[sl], table.last[sl], table.static[sl],
                      table.pieces[lo:], table.lower, table.upper, polyT,
                      referenceT[sl], ET[sl], E2T[sl], E4T[sl], substeps, coarse, states,
                      acc, coarse_states, peak, spread,
                      rows[int(steps[:lo].sum()):] if rows.shape[0] else rows, limits, far,
                      beyond)
        if not (np.all(np.isfinite(y)) and np.all(np.isfinite(yc))):
            raise SimulationError(
                f"the state became non-finite near t = {t_out[table.last[sl][-1]]:.4g} s")
        if on_progress is not None:
            on_progress(float(t_out[table.last[sl][-1]]))
    static_accelerations(table, states, acc)
    return states, acc, coarse_states, peak, spread


def loop_matrices(table: CoefficientTable, ET: np.ndarray, coarse: bool
                  ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """What the compiled loop reads besides ET, transposed: (E²)ᵀ, (coarse) (E⁴)ᵀ (else
    (E²)ᵀ again), the table's polynomials and references."""
    moving = ~table.static
    # exp(h Ã_ref) = E² and (coarse) E⁴, transposed: (E²)ᵀ = (Eᵀ)².
    E2T = ET.copy()
    E2T[moving] = ET[moving] @ ET[moving]
    E4T = E2T  # read by the coarse steps only
    if coarse:
        E4T = E2T.copy()
        E4T[moving] = E2T[moving] @ E2T[moving]
    polyT = np.ascontiguousarray(np.swapaxes(table.poly, 2, 3))  # the loop takes transposes
    referenceT = np.ascontiguousarray(np.swapaxes(table.reference, 1, 2))
    return E2T, E4T, polyT, referenceT


def static_accelerations(table: CoefficientTable, states: np.ndarray, acc: np.ndarray) -> None:
    """z̈ on the static blocks (the loop writes the moving ones'), in place."""
    for a, b, A in zip(table.first[table.static], table.last[table.static],
                       table.reference[table.static]):
        acc[a + 1: b + 1] = states[a + 1: b + 1] @ A.T  # resting: z̈ = A y, A constant


def _block_propagators(
    table: CoefficientTable, n: int, t_out: np.ndarray, substeps: int,
    blocks: np.ndarray | None = None,
) -> np.ndarray:
    """Per block (or per selected block: ``blocks``, a mask), transposed for the compiled
    loop, (blocks, 2n+1, 2n+1): exp(Δt Ã)ᵀ of one output interval Δt for a static block,
    exp(h/2 Ã_ref)ᵀ for a moving one, h = Δt / substeps."""
    stacks = propagator_stacks(table, n, t_out, substeps, blocks)
    return assemble_propagators(stacks, [expm_balanced(*stack) if where.any() else None
                                         for where, stack in stacks])


def propagator_stacks(
    table: CoefficientTable, n: int, t_out: np.ndarray, substeps: int,
    blocks: np.ndarray | None = None,
) -> list[tuple[np.ndarray, tuple[np.ndarray, int, float]]]:
    """What `_block_propagators` exponentiates: per stack, where its blocks go among the
    selected ones (a mask) and `expm_balanced`'s arguments (Ω, n, scale)."""
    dt = (t_out[table.last] - t_out[table.first]) / (table.last - table.first)
    factor = np.where(table.static, dt, 0.5 * dt / substeps)
    A = augmented(table.reference)
    # The balancing scale from every block, selected or not: the same exponentials either way.
    scale = np.sqrt(max(np.abs(table.reference[:, :, :n]).max(), 1.0))
    selected = np.ones(len(table), dtype=bool) if blocks is None else blocks
    stacks = []
    # Static and moving blocks apart: the Padé degree and squarings are chosen per stack, and
    # a static block's full output interval (4 × h/2 at two steps) would raise them for all.
    for group in (selected & table.static, selected & ~table.static):
        where = group[selected]
        stacks.append((where, (A[group] * factor[group, None, None], n, scale)))
    return stacks


def assemble_propagators(stacks: list[tuple[np.ndarray, tuple[np.ndarray, int, float]]],
                         exponentials: list[np.ndarray | None]) -> np.ndarray:
    """`_block_propagators` from its stacks (`propagator_stacks`) and their exponentials
    (None for a stack without blocks)."""
    E = np.empty((stacks[0][0].size, *stacks[0][1][0].shape[1:]))
    for (where, _), exponential in zip(stacks, exponentials):
        if exponential is not None:
            E[where] = exponential
    return np.ascontiguousarray(np.swapaxes(E, 1, 2))
