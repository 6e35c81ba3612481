"""Joint trajectories that leave no residual vibration: `optimize_move`.

Parametrisation. Every joint that makes a rest-to-rest move keeps its start, end angles and
the move's duration D; its normalised profile is the cycloid plus ``harmonics`` cosine and
``harmonics`` sine terms (`flexlink.motion.Harmonic`), each of which keeps zero rate and
acceleration at both ends. The coefficients of all joints are the unknowns x; x = 0 is the
cycloidal move.

Objective. The elastic energy ½ żᵀMż + ½ zᵀKz at the end of the move (`residual.py`): once
the joints stop, the first-order model is linear and time-invariant, so that energy fixes the
whole residual vibration, and a run need only reach the move's end. Each plant's energy is
divided by the cycloidal move's, so J(0) = number of plants. Robust designs add plants whose
every frequency is scaled by 1 ± robust (every EI by (1 ± robust)²). With ``stiffening =
"both"`` (the default) every plant is taken with and without geometric stiffening: the
paper's model (without) and the consistent one (with), which is the first-order
approximation of the nonlinear model — on a fast move the two leave visibly different
residuals, and a move optimised on one alone leaves the other vibrating.

Constraints. Joint rate and acceleration are linear in x: |θ̇|, |θ̈| ≤ limit on a grid of 201
instants of each move, with exact Jacobians. Joint torques come from the run's joint-torque
channel (inverse dynamics of the nominal plant, every ``torque_dt``), |τ| ≤ limit.

Gradient. Forward differences of the objective and the torques, one run per coordinate
(step ``fd_step``, runs at rtol 1e-7 so that the integrator's error is far below the step's
effect), the runs spread over every core by a process pool; `fd_gradient` is checked in the
tests against central differences with a different step. SciPy's SLSQP does the rest.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..dynamics.first_order import FirstOrderSystem
from ..model import Scenario
from ..motion import Harmonic, Shaped
from ..simulation.common import output_times
from ..simulation.prescribed import run_prescribed
from ..solvers.threads import single_threaded
from .plants import scale_frequencies

STIFFENING = ("both", "scenario")  # plants with and without geometric stiffening, or as given
GRID_POINTS = 201  # instants per move where the rate and acceleration limits are checked
DEFAULT_HARMONICS = 4
RUN_RTOL = 1e-7  # integration tolerance of the optimiser's runs: finite differences with
# steps down to 1e-6 agree with central ones to 1e-4 at this tolerance
COEFFICIENT_BOUND = 1.0  # |coefficient| ≤ this: keeps SLSQP's first steps on sensible moves


class InfeasibleMove(ValueError):
    """The request cannot be met: a limit ≤ 0, or a duration the limits do not allow."""


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
        if values.size != joints:
            raise InfeasibleMove(f"{name}: give one limit for all joints or one per joint "
                                 f"({joints}), got {values.size}")
        for k, v in enumerate(values):
            if not (math.isfinite(v) and v > 0.0):
                raise InfeasibleMove(f"{name} of joint {k + 1} must be > 0, got {v:g}: a "
                                     "limit ≤ 0 allows no move")
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
    ``peaks``: peak |rate| (deg/s), |acceleration| (deg/s²), |torque| (N·m) per joint."""

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
    info: dict[str, Any] = field(default_factory=dict)

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
        self.final = []  # Cholesky factors of M, K at rest in the final configuration
        for sc in self.plant_scenarios:
            chain = self.with_coefficients(sc, np.zeros(self.size)).chain
            system = FirstOrderSystem(chain, sc.settings.geometric_stiffening)
            M, _, K, _ = system.matrices(np.array([self.t_end + 1.0]))
            self.final.append((np.linalg.cholesky(M[0]), np.linalg.cholesky(K[0])))

    @property
    def size(self) -> int:
        return 2 * self.harmonics * len(self.moves)

    def _short(self, scenario: Scenario, stiffening: bool) -> Scenario:
        settings = dataclasses.replace(scenario.settings, t_end=self.t_end,
                                       geometric_stiffening=stiffening,
                                       dt_out=float(self.t[1] - self.t[0]), model="first_order",
                                       rtol=RUN_RTOL)
        return dataclasses.replace(scenario, settings=settings, sensors=())

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

    def evaluate(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(energy residuals (plants, 2n), joint torques of the nominal plant (nt, joints)).

        Row p holds r_p = [L_Mᵀ ż; L_Kᵀ z]/√2 at the move's end (M = L_M L_Mᵀ, K = L_K L_Kᵀ),
        so that |r_p|² is plant p's residual elastic energy (J). Nearly linear in x, so
        forward differences of r give an accurate gradient 2 Jᵀ r of the energy even where the
        energy itself is almost zero (its forward differences would be biased there)."""
        rows, torques = [], None
        with single_threaded():
            for i, sc in enumerate(self.plant_scenarios):
                run = run_prescribed(self.with_coefficients(sc, x), self.t, _quiet, False)
                LM, LK = self.final[i]
                z, z_dot = run.solution.q[-1], run.solution.q_dot[-1]
                rows.append(np.concatenate([LM.T @ z_dot, LK.T @ z]) / np.sqrt(2.0))
                if i == 0:
                    torques = np.stack([run.values[f"joint{k + 1}_torque"]
                                        for k in range(len(sc.chain.joints))], axis=1)
        assert torques is not None
        return np.array(rows), torques

    def energies(self, x: np.ndarray) -> np.ndarray:
        """Residual elastic energy (J) of every plant at coefficients x."""
        return np.sum(self.evaluate(x)[0] ** 2, axis=1)

    def kinematic_rows(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rate and acceleration (deg/s, deg/s²) on the check grid as affine functions of x:
        rate = R x + r0, acc = A x + a0, rows grouped per move (GRID_POINTS each)."""
        n, size = self.harmonics, self.size
        tau = np.linspace(0.0, 1.0, GRID_POINTS)
        R = np.zeros((len(self.moves) * GRID_POINTS, size))
        A = np.zeros_like(R)
        r0 = np.zeros(R.shape[0])
        a0 = np.zeros(R.shape[0])
        for i, m in enumerate(self.moves):
            rows = slice(i * GRID_POINTS, (i + 1) * GRID_POINTS)
            delta, d = m.to_deg - m.from_deg, m.duration
            base = Harmonic(0.0, 1.0, 0.0, 1.0)
            _, dp, ddp = base._shape(tau)
            r0[rows], a0[rows] = delta / d * dp, delta / d**2 * ddp
            for j in range(2 * n):
                unit = np.zeros(2 * n)
                unit[j] = 1.0
                _, dpj, ddpj = Harmonic(0.0, 1.0, 0.0, 1.0, tuple(unit[:n]),
                                        tuple(unit[n:]))._shape(tau)
                R[rows, 2 * n * i + j] = delta / d * (dpj - dp)
                A[rows, 2 * n * i + j] = delta / d**2 * (ddpj - ddp)
        return R, r0, A, a0


def _quiet(_t: float) -> None:
    """No progress report from the optimiser's runs."""


_WORKER_PROBLEM: Problem | None = None


def _init_worker(problem: Problem) -> None:
    global _WORKER_PROBLEM
    _WORKER_PROBLEM = problem


def _evaluate_in_worker(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    assert _WORKER_PROBLEM is not None
    return _WORKER_PROBLEM.evaluate(x)


class Evaluator:
    """Evaluations of a Problem at many points: in a process pool over ``workers`` cores, or
    here when workers = 1. Remembers the last point's value (SLSQP asks twice)."""

    def __init__(self, problem: Problem, workers: int) -> None:
        self.problem, self.workers, self.count = problem, workers, 0
        self._pool: ProcessPoolExecutor | None = None
        if workers > 1:
            from ..batch.executors import start_context

            self._pool = ProcessPoolExecutor(max_workers=workers, mp_context=start_context(),
                                             initializer=_init_worker, initargs=(problem,))

    def many(self, points: Sequence[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
        self.count += len(points)
        if self._pool is None:
            return [self.problem.evaluate(x) for x in points]
        return list(self._pool.map(_evaluate_in_worker, points))

    def close(self) -> None:
        if self._pool is not None:
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


def optimize_move(scenario: Scenario, duration: float | None = None, limits: Limits = Limits(),
                  harmonics: int = DEFAULT_HARMONICS, robust: float = 0.0, seed: int = 0,
                  workers: int | None = None, fd_step: float = 1e-5, max_iterations: int = 60,
                  torque_dt: float = 0.005, stiffening: str = "both",
                  on_iteration: Callable[[int, float], None] | None = None) -> OptimizedMove:
    """Optimise the joint trajectories of ``scenario`` (docstring of this module).

    ``duration`` (s): of every move (default: each move's own); ``robust``: relative
    frequency error (0.1 = ±10 %) the move must tolerate; ``seed``: the random perturbation
    of the starting point (reproducible); ``workers``: processes for the gradient (default
    all cores). InfeasibleMove, before anything runs, when a limit makes it impossible."""
    from scipy.optimize import minimize

    if scenario.is_forward:
        raise InfeasibleMove("optimize needs prescribed joints on a fixed hub (no drive, no "
                             "moving base)")
    if not (isinstance(harmonics, int) and 1 <= harmonics <= 20):
        raise InfeasibleMove(f"harmonics must be an integer from 1 to 20, got {harmonics!r}")
    if not (math.isfinite(robust) and 0.0 <= robust < 0.5):
        raise InfeasibleMove(f"robust must be in [0, 0.5) (a relative frequency error), got "
                             f"{robust!r}")
    if duration is not None and not (math.isfinite(duration) and duration > 0.0):
        raise InfeasibleMove(f"duration must be > 0 s, got {duration!r}")
    joints = len(scenario.chain.joints)
    moves = joint_moves(scenario, duration)
    check_feasible(moves, limits, joints)
    rate, acc = (limits.per_joint("rate_deg_s", joints),
                 limits.per_joint("acceleration_deg_s2", joints))
    torque = limits.per_joint("torque_Nm", joints)
    if stiffening not in STIFFENING:
        raise InfeasibleMove(f"stiffening must be one of {', '.join(map(repr, STIFFENING))}, "
                             f"got {stiffening!r}")
    own = scenario.settings.geometric_stiffening
    stiff = [own] if stiffening == "scenario" else [own, not own]
    factors = [1.0] + ([1.0 - robust, 1.0 + robust] if robust > 0.0 else [])
    plants = [(f, s) for f in factors for s in stiff]
    problem = Problem(scenario, moves, harmonics, plants, torque_dt)
    workers = workers or _cores()
    started = time.perf_counter()
    evaluator = Evaluator(problem, max(1, min(workers, problem.size + 1)))
    try:
        result = _solve(problem, evaluator, rate, acc, torque, seed, fd_step, max_iterations,
                        on_iteration, minimize)
    finally:
        evaluator.close()
    wall = time.perf_counter() - started
    x, energy0, info = result["x"], result["energy0"], result
    residual_rows, torques = problem.evaluate(x)
    energy = np.sum(residual_rows**2, axis=1)
    R, r0, A, a0 = problem.kinematic_rows()
    peaks = _peaks(problem, R @ x + r0, A @ x + a0, torques, joints)
    violated = _violations(peaks, rate, acc, torque)
    if violated:
        raise InfeasibleMove("no trajectory found within the limits: " + "; ".join(violated))
    out_scenario = problem.with_coefficients(scenario, x)
    coefficients = {k: (p.cosine, p.sine) for k, p in problem.profiles(x).items()}
    return OptimizedMove(out_scenario, moves, coefficients, energy, energy0, plants, peaks,
                         info["nit"], evaluator.count, wall, evaluator.workers,
                         bool(info["success"]), str(info["message"]),
                         {"seed": seed, "harmonics": harmonics, "robust": robust,
                          "fd_step": fd_step, "stiffening": stiffening, "objective": float(info["fun"])})


def _cores() -> int:
    from ..batch.executors import available_cores

    return available_cores()


def _solve(problem: Problem, evaluator: Evaluator, rate: np.ndarray | None,
           acc: np.ndarray | None, torque: np.ndarray | None, seed: int, fd_step: float,
           max_iterations: int, on_iteration: Callable[[int, float], None] | None,
           minimize: Callable[..., Any]) -> dict[str, Any]:
    energy0 = problem.energies(np.zeros(problem.size))
    weight = 1.0 / np.sqrt(np.where(energy0 > 0.0, energy0, 1.0))[:, None]
    cache: dict[bytes, tuple[float, np.ndarray, np.ndarray, np.ndarray]] = {}

    def at(x: np.ndarray) -> tuple[float, np.ndarray, np.ndarray, np.ndarray]:
        """(J, ∇J, torque margins, their Jacobian) at x, from one parallel batch of runs."""
        key = np.asarray(x, float).tobytes()
        if key not in cache:
            cache.clear()
            (r0, t0), plus, _ = fd_gradient(evaluator.many, np.asarray(x, float), fd_step)
            r = (weight * r0).ravel()
            jac_r = np.stack([((weight * rp).ravel() - r) / fd_step for rp, _ in plus], axis=1)
            J, grad = float(r @ r), 2.0 * jac_r.T @ r
            if torque is not None:
                margins = _torque_margins(t0, torque)
                jac = np.stack([(_torque_margins(t, torque) - margins) / fd_step
                                for _, t in plus], axis=1)
            else:
                margins, jac = np.zeros(0), np.zeros((0, x.size))
            cache[key] = (J, grad, margins, jac)
        return cache[key]

    constraints = []
    R, r0, A, a0 = problem.kinematic_rows()
    for rows, offset, limit in ((R, r0, rate), (A, a0, acc)):
        if limit is None:
            continue
        bound = np.repeat([limit[m.joint] for m in problem.moves], GRID_POINTS)
        G = np.vstack([-rows, rows])
        h = np.concatenate([bound - offset, bound + offset])
        constraints.append({"type": "ineq", "fun": lambda x, G=G, h=h: h + G @ x,
                            "jac": lambda x, G=G: G})
    if torque is not None:
        constraints.append({"type": "ineq", "fun": lambda x: at(x)[2],
                            "jac": lambda x: at(x)[3]})
    rng = np.random.default_rng(seed)
    x0 = 1e-3 * rng.standard_normal(problem.size)  # off the symmetric cycloid, reproducibly
    iteration = [0]

    def callback(xk: np.ndarray) -> None:
        iteration[0] += 1
        if on_iteration is not None:
            on_iteration(iteration[0], at(xk)[0])

    bounds = [(-COEFFICIENT_BOUND, COEFFICIENT_BOUND)] * problem.size
    result = minimize(lambda x: at(x)[0], x0, jac=lambda x: at(x)[1], method="SLSQP",
                      bounds=bounds, constraints=constraints, callback=callback,
                      options={"maxiter": max_iterations, "ftol": 1e-8})
    return {"x": result.x, "energy0": energy0, "nit": result.nit, "success": result.success,
            "message": result.message, "fun": result.fun}


def _torque_margins(torques: np.ndarray, limit: np.ndarray) -> np.ndarray:
    """limit − |τ| as two smooth rows per sample: limit − τ and limit + τ (N·m)."""
    return np.concatenate([(limit - torques).ravel(), (limit + torques).ravel()])


def _peaks(problem: Problem, rate: np.ndarray, acc: np.ndarray, torques: np.ndarray,
           joints: int) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {"rate_deg_s": [0.0] * joints,
                                   "acceleration_deg_s2": [0.0] * joints,
                                   "torque_Nm": [float(v) for v in np.abs(torques).max(axis=0)]}
    for i, m in enumerate(problem.moves):
        rows = slice(i * GRID_POINTS, (i + 1) * GRID_POINTS)
        out["rate_deg_s"][m.joint] = float(np.abs(rate[rows]).max())
        out["acceleration_deg_s2"][m.joint] = float(np.abs(acc[rows]).max())
    return out


def _violations(peaks: dict[str, list[float]], rate: np.ndarray | None, acc: np.ndarray | None,
                torque: np.ndarray | None) -> list[str]:
    out = []
    for name, limit, unit in (("rate_deg_s", rate, "deg/s"),
                              ("acceleration_deg_s2", acc, "deg/s²"),
                              ("torque_Nm", torque, "N·m")):
        if limit is None:
            continue
        for k, (peak, lim) in enumerate(zip(peaks[name], limit, strict=True)):
            if peak > lim * (1.0 + 1e-3):
                out.append(f"joint {k + 1} needs {name} {peak:.4g} {unit} > limit {lim:g}")
    return out


def cores_note() -> str:
    """How many cores the gradient runs use by default."""
    return f"{_cores()} of {os.cpu_count()} cores"


__all__ = ["InfeasibleMove", "Limits", "Move", "OptimizedMove", "check_feasible", "fd_gradient",
           "joint_moves", "optimize_move"]
