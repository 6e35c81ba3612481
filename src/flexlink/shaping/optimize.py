"""Joint trajectories that leave no residual vibration: `optimize_move`.

Parametrisation. Every joint that makes a rest-to-rest move keeps its start, end angles and
the move's duration D; its normalised profile is the cycloid plus ``harmonics`` cosine and
``harmonics`` sine terms (`flexlink.motion.Harmonic`), each of which keeps zero rate and
acceleration at both ends. The coefficients of all joints are the unknowns x; x = 0 is the
cycloidal move.

Objective. The elastic energy ½ żᵀMż + ½ zᵀKz at the end of the move (`residual.py`): once
the joints stop, the first-order model is linear and time-invariant, so that energy fixes the
whole residual vibration, and a run need only reach the move's end. Each plant's energy is
divided by the cycloidal move's, so J(0) = number of plants. Robust designs (the default,
``robust`` = 0.1) add plants whose every frequency is scaled by 1 ± robust (every EI by
(1 ± robust)²). With ``stiffening = "both"`` (the default) every plant is taken with and
without geometric stiffening: the paper's model (without) and the consistent one (with),
which is the first-order approximation of the nonlinear model — on a fast move the two leave
visibly different residuals, and a move optimised on one alone leaves the other vibrating.
A plant other than the scenario's own nominal one that diverges on the cycloidal move is left
out (``OptimizedMove.notes`` says so).

Constraints. The normalised rate and acceleration are trigonometric polynomials of degree
n = harmonics + 1 in 2πτ, linear in x. They are constrained on N = 75 n equally spaced
instants of each move to the limit times (1 − n²π²/(2N²)): at a maximum of |T| the
derivative vanishes, so with Bernstein's inequality ‖T″‖ ≤ n²‖T‖ the maximum lies at most
n²δ²/8 ‖T‖ (δ = 2π/N) above the nearest instant's value, and the limits hold in continuous
time. Joint torques come from the run's joint-torque channel (inverse dynamics of the nominal
plant, every ``torque_dt``), |τ| ≤ limit.

Solver. The weighted energy residual vector r(x) (|r|² = J) is nearly linear in x, so a
Gauss–Newton step on a trust region converges in a few iterations: each solves the quadratic
model min |r + J_r d|² + μ s under the linear rate and acceleration constraints, the
linearised torque constraints relaxed by s ≥ 0 (the largest relative torque excess, weighted
by μ = 1000 per plant), and |d|∞ ≤ Δ — exactly: s from a linear programme, then d by least
squares with inequality constraints (`_lsi`); a trial whose merit J + μ·excess does not fall,
or whose run fails (the model diverges), is a rejected step and shrinks Δ.

Gradient. Forward differences of r and the torques, one run per coordinate (step
``fd_step``; a backward difference where the forward point fails), the runs spread over every
core by a process pool. A point is evaluated with error control (the Lawson integrator at
rtol 1e-5, `RUN_RTOL`); the runs of its differences reuse that run's discretisation — its
coefficient table's layout and its steps (`solvers.lawson.integrate_lawson_on`) — so that no
refinement or step decision changes between them, and the differences are those of one
smooth map, the one the integrator computes, at any step: its error (rtol of the peaks,
far below the residual left at the optimum) does not enter them as noise. `fd_gradient` is
checked in the tests against central differences with a different step.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import Future, ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..channels.catalogue import joint_name
from ..dynamics.first_order import FirstOrderSystem
from ..errors import SimulationError
from ..model import PrismaticJoint, Scenario, is_driven
from ..motion import Harmonic, Shaped
from ..simulation.common import output_times
from ..simulation.prescribed import run_prescribed
from ..solvers import Solution
from ..solvers.lawson import Discretisation, integrate_lawson_discretised, integrate_lawson_on
from ..solvers.threads import single_threaded
from .plants import scale_frequencies

STIFFENING = ("both", "scenario")  # plants with and without geometric stiffening, or as given
GRID_PER_DEGREE = 75  # check instants per move, per unit of the profile's trigonometric degree
DEFAULT_HARMONICS = 4
DEFAULT_ROBUST = 0.10  # relative frequency error the default design tolerates
DEFAULT_MAX_ITERATIONS = 30
RUN_RTOL = 1e-5  # integration tolerance of the optimiser's runs (module docstring, Gradient)
_SETTLED_KEPT = 4  # points whose discretisations Problem keeps
COEFFICIENT_BOUND = 1.0  # |coefficient| ≤ this: keeps the first steps on sensible moves
MAX_SAMPLES = 100_000  # torque instants per optimiser run (a longer move is refused)
PENALTY = 1e3  # μ per plant: weight of the relative torque excess against J (J(0) = plants)
TORQUE_TOLERANCE = 1e-3  # relative torque excess accepted in the answer
TRUST_RADIUS = 0.5  # first trust region, coefficient units
RESOLVED = 1e-10  # J per plant below which the residual is no longer worth lowering
CONVERGED = 2e-2  # stop when the model predicts a merit decrease below this fraction


class InfeasibleMove(ValueError):
    """The request cannot be met: a limit ≤ 0, or a duration the limits do not allow."""


# the command-line option of each limit, named with the field in messages
LIMIT_OPTIONS = {"rate_deg_s": "--rate-limit", "acceleration_deg_s2": "--acceleration-limit",
                 "torque_Nm": "--torque-limit"}


@dataclass(frozen=True)
class Limits:
    """Joint limits, one value for all joints or one per joint; None: no limit.

    rate in deg/s, acceleration in deg/s², torque in N·m (absolute values)."""

    rate_deg_s: float | Sequence[float] | None = None
    acceleration_deg_s2: float | Sequence[float] | None = None
    torque_Nm: float | Sequence[float] | None = None

    def per_joint(self, name: str, joints: int) -> np.ndarray | None:
        """The limit ``name`` as an array of ``joints`` values, or None; InfeasibleMove for
        a value ≤ 0 or a count that does not match."""
        value = getattr(self, name)
        if value is None:
            return None
        values = np.atleast_1d(np.asarray(value, dtype=float))
        if values.size == 1:
            values = np.full(joints, values[0])
        option = f" ({LIMIT_OPTIONS[name]} on the command line)"
        if values.size != joints:
            raise InfeasibleMove(f"{name}: give one limit for all joints or one per joint "
                                 f"({joints}), got {values.size}{option}")
        for k, v in enumerate(values):
            if not (math.isfinite(v) and v > 0.0):
                raise InfeasibleMove(f"{name} of joint {k + 1} must be > 0, got {v:g}: a "
                                     f"limit ≤ 0 allows no move{option}")
        return values


@dataclass(frozen=True)
class Move:
    """One joint's rest-to-rest move: angles in deg, times in s."""

    joint: int
    from_deg: float
    to_deg: float
    start: float
    duration: float

    @property
    def end(self) -> float:
        return self.start + self.duration


@dataclass
class OptimizedMove:
    """The result of `optimize_move`.

    ``scenario``: the input scenario with the optimised joints as `Harmonic` profiles;
    ``coefficients[k]``: (cosine, sine) of joint k (absent: joint not moved);
    ``energy``/``energy_cycloidal``: residual elastic energy (J) per plant;
    ``peaks``: peak |rate| (deg/s), |acceleration| (deg/s²) in continuous time, |torque|
    (N·m) at the torque instants, per joint; ``stopped_at_limit``: the iteration limit ended
    the search (the answer is the best point found, not a converged one); ``notes``: plants
    left out and why."""

    scenario: Scenario
    moves: list[Move]
    coefficients: dict[int, tuple[tuple[float, ...], tuple[float, ...]]]
    energy: np.ndarray
    energy_cycloidal: np.ndarray
    plants: list[tuple[float, bool]]  # (frequency factor, geometric stiffening)
    peaks: dict[str, list[float]]
    iterations: int
    evaluations: int
    wall_time_s: float
    workers: int
    success: bool
    message: str
    stopped_at_limit: bool = False
    notes: list[str] = field(default_factory=list)
    info: dict[str, Any] = field(default_factory=dict)
    idle_results: list[Any] = field(default_factory=list)  # of `optimize_move`'s idle_work

    @property
    def move_end(self) -> float:
        """Time the last joint stops, s."""
        return max(m.end for m in self.moves)


def joint_moves(scenario: Scenario, duration: float | None = None) -> list[Move]:
    """The rest-to-rest move of every joint that makes one (cycloidal, quintic, harmonic, or
    shaped: its base move), with ``duration`` (s) replacing each move's own if given."""
    moves = []
    for k, joint in enumerate(scenario.chain.joints):
        base = joint.profile if isinstance(joint, Shaped) else joint
        if not all(hasattr(base, a) for a in ("from_deg", "to_deg", "start", "duration")):
            continue  # a hold, a spin-up or measured angles: not optimised
        d = base.duration if duration is None else duration
        moves.append(Move(k, base.from_deg, base.to_deg, base.start, float(d)))
    if not moves:
        raise InfeasibleMove("no joint makes a rest-to-rest move (profile cycloidal, quintic, "
                             "harmonic or shaped): nothing to optimise")
    return moves


def check_request(duration: float | None = None, harmonics: int = DEFAULT_HARMONICS,
                  robust: float = DEFAULT_ROBUST, workers: int | None = None,
                  max_iterations: int = DEFAULT_MAX_ITERATIONS) -> None:
    """InfeasibleMove naming the argument when one is out of range (before anything runs)."""
    if duration is not None and not (math.isfinite(duration) and duration > 0.0):
        raise InfeasibleMove(f"duration must be > 0 s, got {duration!r}")
    if not (isinstance(harmonics, int) and 1 <= harmonics <= 20):
        raise InfeasibleMove(f"harmonics must be an integer from 1 to 20, got {harmonics!r}")
    if not (math.isfinite(robust) and 0.0 <= robust < 0.5):
        raise InfeasibleMove(f"robust must be in [0, 0.5) (a relative frequency error), got "
                             f"{robust!r}")
    if workers is not None and not (isinstance(workers, int) and workers >= 1):
        raise InfeasibleMove(f"workers must be an integer ≥ 1 (processes), got {workers!r}")
    if not (isinstance(max_iterations, int) and max_iterations >= 1):
        raise InfeasibleMove(f"max_iterations must be an integer ≥ 1, got {max_iterations!r}")


def check_feasible(moves: Sequence[Move], limits: Limits, joints: int) -> None:
    """InfeasibleMove naming the limit when a move cannot be made within its duration: any
    profile's peak rate is at least |Δ|/D and its peak acceleration at least 4|Δ|/D²."""
    rate = limits.per_joint("rate_deg_s", joints)
    acc = limits.per_joint("acceleration_deg_s2", joints)
    limits.per_joint("torque_Nm", joints)
    for m in moves:
        if not (math.isfinite(m.duration) and m.duration > 0.0):
            raise InfeasibleMove(f"duration must be > 0 s, got {m.duration:g}")
        delta = abs(m.to_deg - m.from_deg)
        if rate is not None and delta / m.duration > rate[m.joint]:
            raise InfeasibleMove(
                f"joint {m.joint + 1}: duration {m.duration:g} s is shorter than its rate limit "
                f"allows: {delta:g}° at ≤ {rate[m.joint]:g}°/s takes at least "
                f"{delta / rate[m.joint]:.4g} s")
        if acc is not None and 4.0 * delta / m.duration**2 > acc[m.joint]:
            raise InfeasibleMove(
                f"joint {m.joint + 1}: duration {m.duration:g} s is shorter than its "
                f"acceleration limit allows: {delta:g}° at ≤ {acc[m.joint]:g}°/s² takes at "
                f"least {2.0 * math.sqrt(delta / acc[m.joint]):.4g} s (bang-bang)")


def grid_size(harmonics: int) -> int:
    """Instants per move where rate and acceleration are constrained."""
    return GRID_PER_DEGREE * (harmonics + 1)


def grid_margin(harmonics: int) -> float:
    """Relative amount by which a trigonometric polynomial of degree harmonics + 1 may exceed
    its largest value on `grid_size` equally spaced instants (module docstring)."""
    n, size = harmonics + 1, grid_size(harmonics)
    return (n * math.pi / size) ** 2 / 2.0


def unit_profiles(harmonics: int, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                              np.ndarray]:
    """(p′, p″ of the cycloid at τ; (len(τ), 2·harmonics) columns: p′, p″ of each coefficient's
    term): the normalised profile is affine in the coefficients."""
    base = Harmonic(0.0, 1.0, 0.0, 1.0)
    _, dp, ddp = base._shape(tau)
    D = np.zeros((tau.size, 2 * harmonics))
    DD = np.zeros_like(D)
    for j in range(2 * harmonics):
        unit = np.zeros(2 * harmonics)
        unit[j] = 1.0
        _, dpj, ddpj = Harmonic(0.0, 1.0, 0.0, 1.0, tuple(unit[:harmonics]),
                                tuple(unit[harmonics:]))._shape(tau)
        D[:, j], DD[:, j] = dpj - dp, ddpj - ddp
    return dp, ddp, D, DD


_FAILED = (SimulationError, ArithmeticError, np.linalg.LinAlgError)  # a trial's bad point
# one plant's run at a point: energy residual, joint torques (the nominal plant's, else
# None), the discretisation it ran on (None for an integrator other than Lawson's)
PlantValue = tuple[np.ndarray, "np.ndarray | None", "Discretisation | None"]


class Problem:
    """Everything one evaluation needs (picklable: sent once to each worker process)."""

    def __init__(self, scenario: Scenario, moves: list[Move], harmonics: int,
                 plants: list[tuple[float, bool]], torque_dt: float) -> None:
        self.scenario, self.moves, self.harmonics = scenario, moves, harmonics
        self.plants = plants
        self.t_end = max(m.end for m in moves)
        self.t = output_times(self.t_end, torque_dt)
        if abs(self.t[-1] - self.t_end) > 1e-12:
            self.t = np.append(self.t[self.t < self.t_end], self.t_end)
        self.plant_scenarios = [self._short(scale_frequencies(scenario, f), stiff)
                                for f, stiff in plants]
        # each plant's discretisation at the last few points evaluated with error control
        self._settled: dict[bytes, list[Discretisation | None]] = {}
        self.final = []  # Cholesky factors of M, K at rest in the final configuration
        for sc in self.plant_scenarios:
            chain = self.with_coefficients(sc, np.zeros(self.size)).chain
            system = FirstOrderSystem(chain, sc.settings.geometric_stiffening)
            M, _, K, _ = system.matrices(np.array([self.t_end + 1.0]))
            self.final.append((np.linalg.cholesky(M[0]), np.linalg.cholesky(K[0])))

    @property
    def size(self) -> int:
        return 2 * self.harmonics * len(self.moves)

    @property
    def torque_channels(self) -> tuple[str, ...]:
        """The joint-torque channels of the nominal plant's runs, in joint order."""
        return tuple(joint_name(k, "torque") for k in range(len(self.scenario.chain.joints)))

    def _short(self, scenario: Scenario, stiffening: bool) -> Scenario:
        settings = dataclasses.replace(scenario.settings, t_end=self.t_end,
                                       geometric_stiffening=stiffening,
                                       dt_out=float(self.t[1] - self.t[0]), model="first_order",
                                       rtol=RUN_RTOL)
        return dataclasses.replace(scenario, settings=settings, sensors=())

    def subset(self, keep: Sequence[int]) -> Problem:
        """The same problem with only the plants of index ``keep``."""
        out = object.__new__(Problem)
        out.__dict__.update(self.__dict__)
        out.plants = [self.plants[i] for i in keep]
        out.plant_scenarios = [self.plant_scenarios[i] for i in keep]
        out.final = [self.final[i] for i in keep]
        return out

    def profiles(self, x: np.ndarray) -> dict[int, Harmonic]:
        """The Harmonic profile of every optimised joint for coefficients x."""
        n, out = self.harmonics, {}
        for i, m in enumerate(self.moves):
            c = x[2 * n * i: 2 * n * (i + 1)]
            out[m.joint] = Harmonic(m.from_deg, m.to_deg, m.start, m.duration,
                                    tuple(c[:n]), tuple(c[n:]))
        return out

    def with_coefficients(self, scenario: Scenario, x: np.ndarray) -> Scenario:
        joints = list(scenario.chain.joints)
        for k, profile in self.profiles(x).items():
            joints[k] = profile
        return dataclasses.replace(scenario, chain=dataclasses.replace(scenario.chain,
                                                                       joints=tuple(joints)))

    def plant_rows(self, i: int, x: np.ndarray) -> tuple[np.ndarray, Any]:
        """(energy residual of plant i, its run) at coefficients x (module docstring)."""
        row, run, _ = self.plant_run(i, x)
        return row, run

    def plant_run(self, i: int, x: np.ndarray, on: Discretisation | None = None
                  ) -> tuple[np.ndarray, Any, Discretisation | None]:
        """`plant_rows`, and the discretisation of its run: the one given (``on``, a run
        without error control) or the one the adaptive Lawson run settled on (None for
        another integrator)."""
        sc = self.plant_scenarios[i]
        settled: list[Discretisation | None] = [on]

        def adaptive(system: Any, t: np.ndarray, rtol: float, atol: float,
                     progress: Any) -> Solution:
            solution, settled[0] = integrate_lawson_discretised(system, t, rtol, atol, progress)
            return solution

        def fixed(system: Any, t: np.ndarray, rtol: float, atol: float,
                  progress: Any) -> Solution:
            assert on is not None
            return integrate_lawson_on(system, t, on)

        integrate = (None if sc.settings.method != "lawson"
                     else adaptive if on is None else fixed)
        # the torques are the nominal plant's (plant 0), its only channels read: the others
        # need their state alone
        run = run_prescribed(self.with_coefficients(sc, x), self.t, _quiet, False, integrate,
                             channels=i == 0, kept=self.torque_channels)
        LM, LK = self.final[i]
        z, z_dot = run.solution.q[-1], run.solution.q_dot[-1]
        return np.concatenate([LM.T @ z_dot, LK.T @ z]) / np.sqrt(2.0), run, settled[0]

    def discretisations(self, x: np.ndarray) -> list[Discretisation | None] | None:
        """Every plant's discretisation of the last adaptive evaluations at x (None if x was
        not among them)."""
        return self._settled.get(np.asarray(x, dtype=float).tobytes())

    def evaluate(self, x: np.ndarray, on: Sequence[Discretisation | None] | None = None
                 ) -> tuple[np.ndarray, np.ndarray]:
        """(energy residuals (plants, 2n), joint torques of the nominal plant (nt, joints)).

        Row p holds r_p = [L_Mᵀ ż; L_Kᵀ z]/√2 at the move's end (M = L_M L_Mᵀ, K = L_K L_Kᵀ),
        so that |r_p|² is plant p's residual elastic energy (J). Nearly linear in x, so
        forward differences of r give an accurate gradient 2 Jᵀ r of the energy even where the
        energy itself is almost zero (its forward differences would be biased there).
        SimulationError when a run fails (the model diverged on this trajectory).

        ``on``: each plant's discretisation (`discretisations`) to run on without error
        control, for the finite differences around a point evaluated without it."""
        return self.combine(x, self.plant_values(x, range(len(self.plants)), on), on)

    def plant_values(self, x: np.ndarray, plants: Sequence[int],
                     on: Sequence[Discretisation | None] | None = None) -> list[PlantValue]:
        """The runs of ``plants`` (indices) at x for `combine`: (energy residual, joint
        torques (plant 0 only, else None), the run's discretisation). SimulationError when
        a run fails."""
        out = []
        with single_threaded():
            for i in plants:
                row, run, used = self.plant_run(i, x, None if on is None else on[i])
                torques = None
                if i == 0:
                    torques = np.stack([run.values[name] for name in self.torque_channels],
                                       axis=1)
                out.append((row, torques, used))
        return out

    def combine(self, x: np.ndarray, values: Sequence[PlantValue],
                on: Sequence[Discretisation | None] | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
        """`evaluate`'s answer from every plant's `plant_values`, in plant order; the
        discretisations kept for x when they were settled here (``on`` None)."""
        torques = values[0][1]
        assert torques is not None
        out = np.array([row for row, _, _ in values])
        if not (np.all(np.isfinite(out)) and np.all(np.isfinite(torques))):
            raise SimulationError("a trial trajectory gave a non-finite state")
        settled = [used for _, _, used in values]
        if on is None and all(d is not None for d in settled):
            self._settled[np.asarray(x, dtype=float).tobytes()] = settled
            while len(self._settled) > _SETTLED_KEPT:
                self._settled.pop(next(iter(self._settled)))
        return out, torques

    def trial(self, x: np.ndarray, on: Sequence[Discretisation | None] | None = None
              ) -> tuple[np.ndarray, np.ndarray] | None:
        """`evaluate`, or None where a run fails: a failed trial is a bad point."""
        try:
            return self.evaluate(x) if on is None else self.evaluate(x, on)
        except _FAILED:
            return None

    def energies(self, x: np.ndarray) -> np.ndarray:
        """Residual elastic energy (J) of every plant at coefficients x."""
        return np.sum(self.evaluate(x)[0] ** 2, axis=1)

    def kinematic_rows(self, points: int | None = None
                       ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rate and acceleration (deg/s, deg/s²) at ``points`` equally spaced instants of
        each move (default `grid_size`; τ = i/points, the profile's period) as affine
        functions of x: rate = R x + r0, acc = A x + a0, rows grouped per move."""
        n, size = self.harmonics, self.size
        points = points or grid_size(n)
        tau = np.arange(points) / points
        dp, ddp, D, DD = unit_profiles(n, tau)
        R = np.zeros((len(self.moves) * points, size))
        A = np.zeros_like(R)
        r0 = np.zeros(R.shape[0])
        a0 = np.zeros(R.shape[0])
        for i, m in enumerate(self.moves):
            rows, cols = slice(i * points, (i + 1) * points), slice(2 * n * i, 2 * n * (i + 1))
            delta, d = m.to_deg - m.from_deg, m.duration
            r0[rows], a0[rows] = delta / d * dp, delta / d**2 * ddp
            R[rows, cols], A[rows, cols] = delta / d * D, delta / d**2 * DD
        return R, r0, A, a0


def _quiet(_t: float) -> None:
    """No progress report from the optimiser's runs."""


_WORKER_PROBLEM: Problem | None = None


def _init_worker(problem: Problem) -> None:
    from ..batch.executors import init_pool_worker

    global _WORKER_PROBLEM
    _WORKER_PROBLEM = problem
    init_pool_worker()


def _trial_in_worker(x: np.ndarray, on: Sequence[Discretisation | None] | None
                     ) -> tuple[np.ndarray, np.ndarray] | None:
    assert _WORKER_PROBLEM is not None
    return _WORKER_PROBLEM.trial(x, on)


def _plants_in_worker(x: np.ndarray, plants: Sequence[int]) -> list[PlantValue] | None:
    assert _WORKER_PROBLEM is not None
    try:
        return _WORKER_PROBLEM.plant_values(x, plants)
    except _FAILED:
        return None


class Evaluator:
    """Evaluations of a Problem at many points: in a process pool over ``workers`` cores, or
    here when workers = 1. A point whose run fails gives None.

    ``idle_work``: picklable calls without arguments that the pool runs while this process
    works alone (`idle`): the caller's work that does not depend on the answer (the command's
    report runs of the cycloidal and shaped moves); `idle_results` has their results."""

    def __init__(self, problem: Problem, workers: int,
                 idle_work: Sequence[Callable[[], Any]] = ()) -> None:
        self.problem, self.workers, self.count = problem, workers, 0
        self._idle_work = list(idle_work)
        self._idle_futures: list[Future[Any]] = []
        self._pool: ProcessPoolExecutor | None = None
        if workers > 1:
            from ..batch.executors import start_context

            self._pool = ProcessPoolExecutor(max_workers=workers, mp_context=start_context(),
                                             initializer=_init_worker, initargs=(problem,))

    def many(self, points: Sequence[np.ndarray],
             on: Sequence[Discretisation | None] | None = None
             ) -> list[tuple[np.ndarray, np.ndarray] | None]:
        """`Problem.trial` at every point (on the discretisations ``on`` if given)."""
        self.count += len(points)
        if (self._pool is not None and len(points) == 1 and on is None
                and len(self.problem.plants) > 1):
            return [self._split(points[0])]
        if self._pool is None or len(points) == 1:
            return [self.problem.trial(x, on) for x in points]
        return list(self._pool.map(_trial_in_worker, points, [on] * len(points)))

    def _split(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """`Problem.trial` at one point, its plants run here and in the pool at once (every
        second plant there: a single point would leave the other cores idle); the
        discretisations of all of them kept here for the differences around x."""
        assert self._pool is not None
        plants = range(len(self.problem.plants))
        theirs = self._pool.submit(_plants_in_worker, x, plants[1::2])
        try:
            mine = self.problem.plant_values(x, plants[::2])
        except _FAILED:
            mine = None
        values = theirs.result()
        if mine is None or values is None:
            return None
        ordered: list[PlantValue] = [*mine, *values]
        ordered[::2], ordered[1::2] = mine, values
        try:
            return self.problem.combine(x, ordered)
        except _FAILED:
            return None

    def idle(self) -> None:
        """Hand the pool one item of idle work per worker: its workers would wait while this
        process works alone (a trust-region subproblem); what follows queues behind them."""
        if self._pool is None:
            return
        for work in self._idle_work[len(self._idle_futures):][:self.workers]:
            self._idle_futures.append(self._pool.submit(work))

    def idle_results(self) -> list[Any]:
        """The result of every item of idle work in order: None where it was not run (no
        pool, or the search ended first: cancelled) or raised (the caller runs it again)."""
        out: list[Any] = []
        for future in self._idle_futures:
            try:
                out.append(None if future.cancel() else future.result())
            except Exception:  # noqa: BLE001 — the caller runs it again and reports it
                out.append(None)
        return out + [None] * (len(self._idle_work) - len(self._idle_futures))

    def close(self, stop: bool = False) -> None:
        """End the pool: after its running trials, or (``stop``: Ctrl-C, a failure) at once."""
        if self._pool is not None:
            if stop:
                from ..batch.executors import stop_pool

                stop_pool(self._pool)
            else:
                self._pool.shutdown(cancel_futures=True)
            self._pool = None


def fd_gradient(evaluate_many: Callable[[Sequence[np.ndarray]], list[Any]], x: np.ndarray,
                step: float, central: bool = False) -> tuple[Any, list[Any], list[Any]]:
    """(value at x, values at x + h e_i, values at x − h e_i (central only)): the runs of a
    finite-difference gradient, all handed to ``evaluate_many`` at once (in parallel)."""
    size = x.size
    plus = [x + step * e for e in np.eye(size)]
    minus = [x - step * e for e in np.eye(size)] if central else []
    values = evaluate_many([x, *plus, *minus])
    return values[0], values[1:1 + size], values[1 + size:]


def _not_prescribed(scenario: Scenario) -> str:
    """Why ``scenario`` is not one `optimize_move` takes, naming the fields and the fix."""
    chain = list(enumerate(scenario.chain.joints))
    sliders = [f"joints[{k}]" for k, j in chain if isinstance(j, PrismaticJoint)]
    joints = [f"joints[{k}]" for k, j in chain
              if is_driven(j) and not isinstance(j, PrismaticJoint)]
    causes, fixes = [], []
    if scenario.base is not None and scenario.base.kind != "fixed":
        causes.append(f"the base moves (base.kind = {scenario.base.kind!r})")
        fixes.append("remove [base]")
    elif scenario.base is not None:
        causes.append("a chain starts on the base away from the hub (base_point)")
    if scenario.closures:
        causes.append("[[closures]] close a loop")
    if joints:
        causes.append(f"{', '.join(joints)} {'is' if len(joints) == 1 else 'are'} driven")
        fixes.append(f"give {', '.join(joints)} a `motion` instead of a `drive`")
    if sliders:
        causes.append(f"{', '.join(sliders)} "
                      f"{'is a slider' if len(sliders) == 1 else 'are sliders'}")
    fix = ("; " + " and ".join(fixes)) if fixes else ""
    return ("optimize needs an open chain of prescribed revolute joints on a fixed hub: "
            + "; ".join(causes) + fix)


def optimize_move(scenario: Scenario, duration: float | None = None, limits: Limits = Limits(),
                  harmonics: int = DEFAULT_HARMONICS, robust: float = DEFAULT_ROBUST,
                  seed: int = 0, workers: int | None = None, fd_step: float = 1e-5,
                  max_iterations: int = DEFAULT_MAX_ITERATIONS, torque_dt: float = 0.005,
                  stiffening: str = "both",
                  on_iteration: Callable[[int, float], None] | None = None,
                  idle_work: Sequence[Callable[[], Any]] = ()) -> OptimizedMove:
    """Optimise the joint trajectories of ``scenario`` (docstring of this module).

    ``duration`` (s): of every move (default: each move's own); ``robust``: relative
    frequency error (0.1 = ±10 %, the default; 0 = the nominal plant only) the move must
    tolerate; ``seed``: the random perturbation of the starting point (reproducible);
    ``workers``: processes for the gradient (default all cores); ``idle_work``: picklable
    calls without arguments run on those processes while the search works alone
    (`Evaluator`), their results in ``OptimizedMove.idle_results`` (None where not run, or
    where one raised: then run them again). InfeasibleMove, before
    anything runs, when a limit makes the move impossible (naming the limit and the shortest
    duration it allows), and after the search when no trajectory meets the torque limit."""
    if scenario.is_forward:
        raise InfeasibleMove(_not_prescribed(scenario))
    check_request(duration, harmonics, robust, workers, max_iterations)
    if stiffening not in STIFFENING:
        raise InfeasibleMove(f"stiffening must be one of {', '.join(map(repr, STIFFENING))}, "
                             f"got {stiffening!r}")
    joints = len(scenario.chain.joints)
    moves = joint_moves(scenario, duration)
    check_feasible(moves, limits, joints)
    samples = max(m.end for m in moves) / torque_dt
    if samples > MAX_SAMPLES:
        raise InfeasibleMove(
            f"duration: the moves end at {max(m.end for m in moves):g} s; the optimiser's runs "
            f"sample them every {torque_dt:g} s ({samples:.3g} instants, at most {MAX_SAMPLES}): "
            f"give a move that ends by {MAX_SAMPLES * torque_dt:g} s")
    rate, acc = (limits.per_joint("rate_deg_s", joints),
                 limits.per_joint("acceleration_deg_s2", joints))
    torque = limits.per_joint("torque_Nm", joints)
    own = scenario.settings.geometric_stiffening
    stiff = [own] if stiffening == "scenario" else [own, not own]
    factors = [1.0] + ([1.0 - robust, 1.0 + robust] if robust > 0.0 else [])
    plants = [(f, s) for f in factors for s in stiff]
    problem = Problem(scenario, moves, harmonics, plants, torque_dt)
    # small dense linear algebra throughout: BLAS threads only cost time here
    with single_threaded():
        kinematic = _kinematic_constraints(problem, rate, acc)
    workers = workers or _cores()
    started = time.perf_counter()
    problem, energy0, notes = _usable_plants(problem)
    evaluator = Evaluator(problem, max(1, min(workers, problem.size)), idle_work)
    try:
        with single_threaded():
            result = _solve(problem, evaluator, kinematic, torque, energy0, seed, fd_step,
                            max_iterations, on_iteration)
        idle_results = evaluator.idle_results()
    except BaseException:
        evaluator.close(stop=True)
        raise
    evaluator.close()
    wall = time.perf_counter() - started
    x = result["x"]
    energy = np.sum(result["rows"] ** 2, axis=1)
    peaks = _peaks(problem, x, result["torques"], joints)
    if torque is not None:
        _check_torques(peaks, torque, problem, x, kinematic, rate, acc)
    out_scenario = problem.with_coefficients(scenario, x)
    coefficients = {k: (p.cosine, p.sine) for k, p in problem.profiles(x).items()}
    return OptimizedMove(out_scenario, moves, coefficients, energy, energy0, problem.plants,
                         peaks, result["nit"], evaluator.count + 1, wall, evaluator.workers,
                         bool(result["success"]), str(result["message"]),
                         bool(result["stopped_at_limit"]), notes,
                         {"seed": seed, "harmonics": harmonics, "robust": robust,
                          "fd_step": fd_step, "stiffening": stiffening,
                          "max_iterations": max_iterations, "objective": float(result["fun"]),
                          "method": "Gauss-Newton trust region (subproblems: a linear "
                                    "programme, then least squares with inequality "
                                    "constraints by NNLS)",
                          "grid_points": grid_size(harmonics),
                          "grid_margin": grid_margin(harmonics)}, idle_results)


def _cores() -> int:
    from ..batch.executors import available_cores

    return available_cores()


def _plant_name(factor: float, stiffening: bool) -> str:
    what = "with" if stiffening else "without"
    scale = "" if factor == 1.0 else f", every frequency × {factor:g}"
    return f"first-order model {what} geometric stiffening{scale}"


def _usable_plants(problem: Problem) -> tuple[Problem, np.ndarray, list[str]]:
    """(the problem without the plants that diverge on the cycloidal move, their cycloidal
    energies (J), notes on the plants left out).
    InfeasibleMove when the scenario's own nominal plant diverges."""
    x = np.zeros(problem.size)
    keep, energies, notes = [], [], []
    with single_threaded():
        for i, (factor, stiff) in enumerate(problem.plants):
            try:
                row, _ = problem.plant_rows(i, x)
                if not np.all(np.isfinite(row)):
                    raise SimulationError("non-finite state")
            except (SimulationError, ArithmeticError, np.linalg.LinAlgError) as exc:
                if i == 0:
                    moves = ", ".join(f"joint {m.joint + 1} {m.to_deg - m.from_deg:g}° in "
                                      f"{m.duration:g} s" for m in problem.moves)
                    raise InfeasibleMove(
                        f"the cycloidal move ({moves}) already fails in the scenario's model "
                        f"({_plant_name(factor, stiff)}): {exc}. Lengthen the move "
                        "(--duration)" + ("" if stiff else " or set geometric_stiffening = "
                                          "true")) from None
                notes.append(f"left out the {_plant_name(factor, stiff)}: it diverges on the "
                             f"cycloidal move ({exc})")
                continue
            keep.append(i)
            energies.append(float(row @ row))
    return problem.subset(keep), np.array(energies), notes


@dataclass
class _Point:
    """One evaluated point: coefficients, weighted residual r (|r|² = J), raw rows, torques."""

    x: np.ndarray
    r: np.ndarray
    rows: np.ndarray
    torques: np.ndarray
    J: float
    excess: float  # largest relative torque excess (0 within the limits)
    merit: float
    jac: np.ndarray | None = None  # ∂r/∂x
    margins: np.ndarray | None = None  # 1 − |τ|/limit, two smooth rows per sample
    margins_jac: np.ndarray | None = None


def _kinematic_constraints(problem: Problem, rate: np.ndarray | None, acc: np.ndarray | None
                           ) -> tuple[np.ndarray, np.ndarray] | None:
    """(G, h) with G x ≤ h the continuous-time rate and acceleration limits (module
    docstring); None without such limits. InfeasibleMove when no coefficients meet them,
    naming the limit, the smallest peak the profiles reach and the shortest duration."""
    if rate is None and acc is None:
        return None
    n, margin = problem.harmonics, grid_margin(problem.harmonics)
    points = grid_size(n)
    R, r0, A, a0 = problem.kinematic_rows(points)
    G_all, h_all = [], []
    for i, m in enumerate(problem.moves):
        rows, cols = slice(i * points, (i + 1) * points), slice(2 * n * i, 2 * n * (i + 1))
        blocks = []
        for M, off, limit in ((R, r0, rate), (A, a0, acc)):
            if limit is not None:
                blocks.append((M[rows, cols], off[rows], limit[m.joint] * (1.0 - margin)))
        _check_kinematics(m, blocks, rate, acc, margin, n)
        for M_, off, lim in blocks:  # scaled by the limit: h − G x is a relative slack
            G = np.zeros((2 * points, problem.size))
            G[:points, cols], G[points:, cols] = M_ / lim, -M_ / lim
            G_all.append(G)
            h_all.append(np.concatenate([1.0 - off / lim, 1.0 + off / lim]))
    return np.vstack(G_all), np.concatenate(h_all)


def _minimax(M: np.ndarray, off: np.ndarray) -> float:
    """min over |c| ≤ COEFFICIENT_BOUND of max |M c + off| (a linear programme)."""
    from scipy.optimize import linprog

    size = M.shape[1]
    cost = np.zeros(size + 1)
    cost[-1] = 1.0
    ones = np.ones((M.shape[0], 1))
    A_ub = np.vstack([np.hstack([M, -ones]), np.hstack([-M, -ones])])
    b_ub = np.concatenate([-off, off])
    res = linprog(cost, A_ub=A_ub, b_ub=b_ub, method="highs",
                  bounds=[(-COEFFICIENT_BOUND, COEFFICIENT_BOUND)] * size + [(0, None)])
    return float(res.x[-1]) if res.status == 0 else math.inf


def _jointly_feasible(blocks: Sequence[tuple[np.ndarray, np.ndarray, float]],
                      scales: Sequence[float]) -> bool:
    """Whether some |c| ≤ COEFFICIENT_BOUND keeps every block |s (M c + off)| ≤ limit."""
    from scipy.optimize import linprog

    A_ub, b_ub = [], []
    for (M, off, lim), s in zip(blocks, scales, strict=True):
        A_ub += [s * M, -s * M]
        b_ub += [lim - s * off, lim + s * off]
    size = blocks[0][0].shape[1]
    res = linprog(np.zeros(size), A_ub=np.vstack(A_ub), b_ub=np.concatenate(b_ub),
                  bounds=[(-COEFFICIENT_BOUND, COEFFICIENT_BOUND)] * size, method="highs")
    return res.status == 0


def _check_kinematics(m: Move, blocks: list[tuple[np.ndarray, np.ndarray, float]],
                      rate: np.ndarray | None, acc: np.ndarray | None, margin: float,
                      n: int) -> None:
    """InfeasibleMove when the profiles cannot meet move m's rate or acceleration limit,
    alone or together (peaks scale as 1/D and 1/D² with the duration D)."""
    if not blocks or _jointly_feasible(blocks, [1.0] * len(blocks)):
        return
    delta, d = abs(m.to_deg - m.from_deg), m.duration
    what = (f"joint {m.joint + 1}: {delta:g}° in {d:g} s needs, with the optimiser's "
            f"profiles (cycloid plus {n} harmonics),")
    kinds = [("rate", rate, "°/s", 1), ("acceleration", acc, "°/s²", 2)]
    kinds = [k for k in kinds if k[1] is not None]
    shortest = []
    for (name, limit, unit, power), (M, off, lim) in zip(kinds, blocks, strict=True):
        peak = _minimax(M, off)  # on the check instants, against the limit less the margin
        need = d * (peak / lim) ** (1.0 / power)
        shortest.append(need)
        if peak > lim:
            raise InfeasibleMove(
                f"{what} a peak {name} of at least {peak:.4g}{unit} > {name} limit "
                f"{limit[m.joint]:g}{unit}: the {name} limit binds; the shortest such move "
                f"within it takes {need:.4g} s (--duration), or raise the limit")
    lo, hi = max(shortest), max(shortest)
    while not _jointly_feasible(blocks, [(d / hi) ** k[3] for k in kinds]):
        hi *= 1.25
    for _ in range(30):
        mid = 0.5 * (lo + hi)
        if _jointly_feasible(blocks, [(d / mid) ** k[3] for k in kinds]):
            hi = mid
        else:
            lo = mid
    limits = " and ".join(f"{name} ≤ {limit[m.joint]:g}{unit}"
                          for name, limit, unit, _ in kinds)
    raise InfeasibleMove(
        f"{what} more than {limits} allow together (each alone would allow it): the rate "
        f"and acceleration limits bind together; the shortest move within both takes "
        f"{hi:.4g} s (--duration), or raise a limit")


def _feasible_start(x0: np.ndarray, kinematic: tuple[np.ndarray, np.ndarray] | None
                    ) -> np.ndarray:
    """The point nearest x0 within the rate and acceleration constraints and the bounds."""
    x0 = np.clip(x0, -COEFFICIENT_BOUND, COEFFICIENT_BOUND)
    if kinematic is None:
        return x0
    G, h = kinematic
    if np.all(G @ x0 <= h - 1e-6):
        return x0
    size = x0.size
    rows = np.vstack([-G, np.eye(size), -np.eye(size)])
    bounds = np.concatenate([-(h - 1e-6), -np.full(2 * size, COEFFICIENT_BOUND)])
    y = _lsi(np.eye(size), x0, rows, bounds)
    if y is None:  # (the linear programmes before found these constraints feasible)
        raise InfeasibleMove("the rate and acceleration limits leave no profile")
    return y


def _solve(problem: Problem, evaluator: Evaluator,
           kinematic: tuple[np.ndarray, np.ndarray] | None, torque: np.ndarray | None,
           energy0: np.ndarray, seed: int,
           fd_step: float, max_iterations: int,
           on_iteration: Callable[[int, float], None] | None) -> dict[str, Any]:
    """Gauss–Newton on a trust region (module docstring); the best point found."""
    weight = 1.0 / np.sqrt(np.where(energy0 > 0.0, energy0, 1.0))[:, None]
    mu = PENALTY * len(problem.plants)
    # joint by joint, in time order: neighbouring rows are neighbouring instants
    limit_rows = None if torque is None else np.tile(np.repeat(torque, len(problem.t)), 2)

    def margins_of(torques: np.ndarray) -> np.ndarray:
        if torque is None:
            return np.zeros(0)
        return 1.0 - np.concatenate([torques.T.ravel(), -torques.T.ravel()]) / limit_rows

    def point(x: np.ndarray, value: tuple[np.ndarray, np.ndarray]) -> _Point:
        rows, torques = value
        r = (weight * rows).ravel()
        J = float(r @ r)
        margins = margins_of(torques)
        excess = float(max(0.0, -margins.min())) if margins.size else 0.0
        return _Point(x, r, rows, torques, J, excess, J + mu * excess, margins=margins)

    def linearise(p: _Point) -> None:
        """Forward differences of r and the torque margins at p (backward where a forward
        point fails; a zero column where both do), on p's discretisation."""
        steps = [fd_step] * p.x.size
        on = problem.discretisations(p.x)
        values = evaluator.many([p.x + fd_step * e for e in np.eye(p.x.size)], on)
        failed = [i for i, v in enumerate(values) if v is None]
        if failed:
            back = evaluator.many([p.x - fd_step * np.eye(p.x.size)[i] for i in failed], on)
            for i, v in zip(failed, back, strict=True):
                values[i], steps[i] = v, -fd_step
        jac = np.zeros((p.r.size, p.x.size))
        mjac = np.zeros((p.margins.size, p.x.size))
        for i, v in enumerate(values):
            if v is None:
                continue
            q = point(p.x + steps[i] * np.eye(p.x.size)[i], v)
            jac[:, i] = (q.r - p.r) / steps[i]
            mjac[:, i] = (q.margins - p.margins) / steps[i]
        p.jac, p.margins_jac = jac, mjac

    rng = np.random.default_rng(seed)
    x0 = _feasible_start(1e-3 * rng.standard_normal(problem.size), kinematic)
    value = evaluator.many([x0])[0]
    if value is None:  # the perturbation alone made a run fail: start from the cycloid
        x0 = _feasible_start(np.zeros(problem.size), kinematic)
        value = evaluator.many([x0])[0]
        if value is None:
            raise InfeasibleMove("no trajectory within the rate and acceleration limits could "
                                 "be simulated: every trial diverged")
    current = point(x0, value)
    linearise(current)
    radius, iteration, message, stopped_at_limit = TRUST_RADIUS, 0, "", False
    while True:
        if iteration >= max_iterations:
            stopped_at_limit = True
            message = (f"stopped at the iteration limit ({max_iterations}): the best point "
                       "found, not a converged optimum")
            break
        iteration += 1
        if current.merit <= RESOLVED * len(problem.plants):
            message = (f"converged: the residual energy is below {RESOLVED:g} of the "
                       "cycloid's in every plant")
            break
        evaluator.idle()  # the pool's workers would wait for this subproblem
        y, _, predicted = _subproblem(current, kinematic, radius, mu)
        if predicted <= CONVERGED * current.merit:
            message = (f"converged: the model predicts a decrease of less than "
                       f"{100 * CONVERGED:g} % of the merit from a further step")
            break
        value = evaluator.many([y])[0]
        step = float(np.abs(y - current.x).max())
        ratio = -1.0
        if value is not None:
            trial = point(y, value)
            ratio = (current.merit - trial.merit) / predicted
        if ratio > 0.1:
            linearise(trial)
            current = trial
            if ratio > 0.75 and step > 0.9 * radius:
                radius = min(2.0 * radius, 2.0 * COEFFICIENT_BOUND)
        else:
            radius = 0.25 * step
        if on_iteration is not None:
            on_iteration(iteration, current.J)
        if radius < 1e-8:
            message = "converged: no step within the trust region lowers the merit"
            break
    return {"x": current.x, "rows": current.rows, "torques": current.torques, "nit": iteration,
            "success": not stopped_at_limit and current.excess <= TORQUE_TOLERANCE,
            "message": message, "fun": current.J, "stopped_at_limit": stopped_at_limit,
            "excess": current.excess}


def _subproblem(p: _Point, kinematic: tuple[np.ndarray, np.ndarray] | None, radius: float,
                mu: float) -> tuple[np.ndarray, float, float]:
    """(y, s, predicted decrease of the merit): the minimum of the Gauss–Newton model
    |r + J_r (y − x)|² + μ s on the trust region, the rate and acceleration constraints and
    the linearised torque margins relaxed by s.

    In two stages, each exact: s = the smallest relaxation the linear constraints allow (a
    linear programme; 0 when they can be met), then the least-squares problem with linear
    inequality constraints at that s (`_lsi`)."""
    assert p.jac is not None and p.margins is not None and p.margins_jac is not None
    x, size = p.x, p.x.size
    lo = np.maximum(-COEFFICIENT_BOUND, x - radius)
    hi = np.minimum(COEFFICIENT_BOUND, x + radius)
    # every row: A y + a ≥ s·S (S = 1 on torque rows, 0 elsewhere)
    A_parts, a_parts, S_parts = [np.eye(size), -np.eye(size)], [-lo, hi], [np.zeros(2 * size)]
    if kinematic is not None:  # a relative slack of 1e-6 kept for round-off
        G, h = kinematic
        A_parts.append(-G)
        a_parts.append(h - 1e-6)
        S_parts.append(np.zeros(G.shape[0]))
    if p.margins.size:
        A_parts.append(p.margins_jac)
        a_parts.append(p.margins - p.margins_jac @ x)
        S_parts.append(-np.ones(p.margins.size))
    A, a, S = np.vstack(A_parts), np.concatenate(a_parts), np.concatenate(S_parts)
    s = 0.0
    # s = 0 where the point itself meets every row (the usual case): no linear programme
    if p.margins.size and not np.all(A @ x + a >= 0.0):
        s = _least_relaxation(A, a, S)
        if s is None:
            return x, p.excess, 0.0
        s = 0.0 if s <= 1e-9 else s * (1.0 + 1e-9)
    lam = 1e-10 * max(float(np.sum(p.jac**2)), 1e-300)  # full column rank, negligible pull
    E = np.vstack([p.jac, math.sqrt(lam) * np.eye(size)])
    f = np.concatenate([p.jac @ x - p.r, math.sqrt(lam) * x])
    y = _lsi(E, f, A, -(a + s * S))
    if y is None:
        return x, p.excess, 0.0
    if kinematic is not None:  # x meets the rate and acceleration limits: so must y
        G, h = kinematic
        at_x, at_y = h - G @ x, h - G @ y
        short = at_y < 0.0
        if short.any():
            t = 0.99 * float(np.min(at_x[short] / (at_x[short] - at_y[short])))
            y = x + max(t, 0.0) * (y - x)
    res = p.r + p.jac @ (y - x)
    return y, s, max(0.0, p.merit - (float(res @ res) + mu * s))


def _least_relaxation(A: np.ndarray, a: np.ndarray, S: np.ndarray) -> float | None:
    """min s ≥ 0 such that some y has A y + a ≥ s S (a linear programme); None if the rows
    without s cannot be met."""
    from scipy.optimize import linprog

    size = A.shape[1]
    cost = np.zeros(size + 1)
    cost[-1] = 1.0
    res = linprog(cost, A_ub=-np.hstack([A, -S[:, None]]), b_ub=a,
                  bounds=[(None, None)] * size + [(0.0, None)], method="highs")
    return float(res.x[-1]) if res.status == 0 else None


def _lsi(E: np.ndarray, f: np.ndarray, G: np.ndarray, h: np.ndarray) -> np.ndarray | None:
    """min |E y − f| subject to G y ≥ h (E of full column rank), or None if infeasible:
    Lawson & Hanson's reduction to a least-distance problem solved by NNLS (the method
    inside SLSQP, here without its outer iterations)."""
    from scipy.linalg import solve_triangular
    from scipy.optimize import nnls

    Q, R = np.linalg.qr(E)
    R_inv = solve_triangular(R, np.eye(R.shape[0]))
    qf = Q.T @ f
    G_hat = G @ R_inv
    h_hat = h - G_hat @ qf
    n = R.shape[0]
    E_ldp = np.vstack([G_hat.T, h_hat[None, :]])
    f_ldp = np.zeros(n + 1)
    f_ldp[-1] = 1.0
    w, _ = nnls(E_ldp, f_ldp, maxiter=50 * (n + 1) + 10 * G.shape[0])
    residual = E_ldp @ w - f_ldp
    if abs(residual[-1]) < 1e-12:
        return None
    u = -residual[:n] / residual[-1]
    return R_inv @ (u + qf)


def continuous_peaks(problem: Problem, x: np.ndarray, refine: int = 20
                     ) -> tuple[np.ndarray, np.ndarray]:
    """Peak |rate| (deg/s) and |acceleration| (deg/s²) of each move in continuous time: the
    largest value on ``refine`` × `grid_size` instants, within a relative n²π²/(2N²) of the
    true maximum (module docstring), per move."""
    R, r0, A, a0 = problem.kinematic_rows(refine * grid_size(problem.harmonics))
    points = refine * grid_size(problem.harmonics)
    rate, acc = np.abs(R @ x + r0), np.abs(A @ x + a0)
    return (np.array([rate[i * points:(i + 1) * points].max() for i in range(len(problem.moves))]),
            np.array([acc[i * points:(i + 1) * points].max() for i in range(len(problem.moves))]))


def _peaks(problem: Problem, x: np.ndarray, torques: np.ndarray,
           joints: int) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {"rate_deg_s": [0.0] * joints,
                                   "acceleration_deg_s2": [0.0] * joints,
                                   "torque_Nm": [float(v) for v in np.abs(torques).max(axis=0)]}
    rate, acc = continuous_peaks(problem, x)
    for i, m in enumerate(problem.moves):
        out["rate_deg_s"][m.joint] = float(rate[i])
        out["acceleration_deg_s2"][m.joint] = float(acc[i])
    return out


def _check_torques(peaks: dict[str, list[float]], torque: np.ndarray, problem: Problem,
                   x: np.ndarray, kinematic: tuple[np.ndarray, np.ndarray] | None,
                   rate: np.ndarray | None, acc: np.ndarray | None) -> None:
    """InfeasibleMove naming the torque limit (the binding one: rate and acceleration are met
    exactly) with the smallest peak reached, the kinematic limits active there, and the
    duration a rigid arm's torques (∝ 1/D²) would suggest."""
    over = [(k, peak, lim) for k, (peak, lim) in enumerate(zip(peaks["torque_Nm"], torque,
                                                               strict=True))
            if peak > lim * (1.0 + TORQUE_TOLERANCE)]
    if not over:
        return
    active = []
    if kinematic is not None:
        for i, m in enumerate(problem.moves):
            for name, limit, value in (("rate", rate, peaks["rate_deg_s"][m.joint]),
                                       ("acceleration", acc,
                                        peaks["acceleration_deg_s2"][m.joint])):
                if limit is not None and value >= limit[m.joint] * (1.0 - 1e-3):
                    active.append(f"joint {m.joint + 1}'s {name} limit")
    context = ("; " + " and ".join(active) + " at the bound too" if active
               else "; the rate and acceleration limits not at their bounds")
    d = max(m.duration for m in problem.moves)
    parts = [f"joint {k + 1} needs a torque of {peak:.4g} N·m > torque limit {lim:g} N·m "
             f"(the smallest peak the optimiser reached{context})"
             for k, peak, lim in over]
    worst = max(peak / lim for _, peak, lim in over)
    raise InfeasibleMove(
        "no trajectory found within the torque limit — the torque limit binds: "
        + "; ".join(parts) + f". Raise the limit or lengthen the move: a rigid arm's torques "
        f"scale as 1/duration², which suggests about {d * math.sqrt(worst):.3g} s (--duration)")


def cores_note() -> str:
    """How many cores the gradient runs use by default."""
    return f"{_cores()} of {os.cpu_count()} cores"


__all__ = ["DEFAULT_ROBUST", "InfeasibleMove", "Limits", "Move", "OptimizedMove",
           "check_feasible", "check_request", "continuous_peaks", "fd_gradient", "grid_margin",
           "grid_size", "joint_moves", "optimize_move"]
