"""Identify scenario parameters from measured signals by bounded nonlinear least squares.

Objective ``modal`` (default): residuals are the differences of frequency and damping ratio of
the strongest free-vibration components of each fitted channel, simulated minus measured, in
units of the measured values' standard errors; gains, offsets and drifts then follow by linear
least squares over the whole run. Objective ``time``: residuals are
(gain·sim(t − delay) + offset + drift·t − meas) / std(meas) on the fit window. Why modal is the
default, and the tests behind it: docs/experiment.md, docs/validation.md.

Simulations are cached by the model parameters: calibration parameters cost none. A starting
point close to the answer keeps their number small: EI of link k is scaled by (f_meas/f_sim)² of
the dominant free-vibration frequency of the channels on link k (twice), its damping ratio by
ζ_meas/ζ_sim, and gains, offsets and drifts come from a linear fit.

Jacobians: exact where the runs take sensitivities (`simulation.sensitivities`: one run with
the derivatives of every channel gives the whole Jacobian; calibration columns analytic; the
modal features differentiated through their fit, `vibration.damped_mode_slopes`), else forward
differences.

Uncertainty: cov = s² (JᵀJ)⁻¹ in the scaled variables (modal: s² = max(1, χ²/dof); time:
s² = Σr²/(m − p) widened by the AR(1) factor (1 + ρ)/(1 − ρ) of the residuals); 95 % intervals
are ±1.96 σ (×exp(±1.96 σ) on log-scaled parameters).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..channels.catalogue import catalogue
from ..model import Scenario
from ..motion.measured import zero_phase_lowpass
from ..results import Results
from ..scenario import ScenarioError
from ..scenario.fields import ScenarioFile
from ..solvers.threads import single_threaded
from .comparison import (
    Comparison,
    evaluate,
    manoeuvre,
    measured_inputs,
    on_grid,
    simulate_driven,
)
from .files import MeasurementError
from .measurement import Measurement
from .parameters import Parameter, model_values
from .vibration import (
    Mode,
    damped_mode_slopes,
    damped_modes,
    dominant_mode,
    spectral_peaks,
    strongest,
)

Z95 = 1.959964
UNIDENTIFIABLE_RATIO = 10.0  # a 95 % interval wider than a decade says little


class FitWarning(UserWarning):
    """The fit finished but its answer is doubtful: the optimiser ran out of simulations, or
    a parameter's interval is too wide to identify it; the message says which."""


@dataclass(frozen=True)
class Estimate:
    """A fitted parameter with its 95 % confidence interval; every value in ``unit``
    (UDUNITS, "" where the schema spells none)."""

    path: str
    unit: str
    initial: float
    start: float  # after the initial-guess step
    value: float
    std: float
    ci_low: float
    ci_high: float
    lower: float
    upper: float
    at_bound: bool
    identifiable: bool = True  # False: 95 % interval over a decade (or ± its typical size)

    @property
    def decades(self) -> float:
        """Decades the 95 % interval spans (inf if it reaches 0 or changes sign)."""
        if self.ci_low <= 0.0 < self.ci_high or self.ci_low * self.ci_high <= 0.0:
            return math.inf
        return abs(math.log10(self.ci_high / self.ci_low))

    @property
    def doubt(self) -> str:
        """Why the parameter is not identifiable ("" if it is)."""
        if self.identifiable:
            return ""
        span = ("reaches zero" if math.isinf(self.decades)
                else f"spans {self.decades:.2g} decades")
        return f"its 95 % interval {self.ci_low:.3g} … {self.ci_high:.3g} {span}"

    def as_dict(self) -> dict[str, Any]:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}

    def row(self) -> dict[str, Any]:
        """The row of parameters.csv and fit.json (`PARAMETER_COLUMNS`)."""
        return {column: getattr(self, column) for column in PARAMETER_COLUMNS}


# The columns of parameters.csv (keys of fit.json's parameter rows): every value of a row,
# bounds and standard deviation included, in the row's `unit` (the field's, UDUNITS)
PARAMETER_COLUMNS = ("path", "unit", "initial", "start", "value", "std", "ci_low", "ci_high",
                     "lower", "upper", "at_bound", "identifiable")


@dataclass
class FitResult:
    estimates: list[Estimate]
    scenario: Scenario  # with the fitted model values (measured joint angles as inputs)
    comparison: Comparison  # calibrated simulation against the measurement
    channels: list[str]
    window: tuple[float, float]  # s
    cost: float  # ½ Σ r² at the estimate
    rms_residual: float  # RMS of the normalised residuals
    simulations: int
    status: str
    correlation: np.ndarray  # parameter correlation matrix
    info: dict[str, Any] = field(default_factory=dict)


NO_MODEL_PARAMETER = "no model parameter"  # nothing to differentiate through the runs


class _Model:
    """Simulations cached by model parameter values; calibration applied on top. Each
    simulation rebuilds the scenario from the file with the values set (so derived fields
    follow: EI from E, a sensor's default thickness) and drives it with the measured angles.
    A run asked ``with_slopes`` also computes every channel's exact derivatives in the model
    parameters (`simulation.sensitivities`), where the run's path takes them; where it does
    not (`exact_reason` says why), the fit's Jacobians come from differences."""

    def __init__(self, file: ScenarioFile, params: list[Parameter], measurement: Measurement,
                 progress: Callable[[str], None] | None) -> None:
        self.file = file
        self.measurement = measurement
        self.inputs = measured_inputs(file.build(), measurement)  # splines made once
        self.base = self.inputs.drive(file.build())
        self.params = params
        self.model_params = [p for p in params if p.is_model]
        self.cache: dict[tuple[float, ...], Results] = {}
        self.slopes: dict[tuple[float, ...], dict[str, np.ndarray]] = {}
        self.exact_reason = "" if self.model_params else NO_MODEL_PARAMETER
        self.simulations = 0
        self.progress = progress

    def _key(self, values: list[float]) -> tuple[float, ...]:
        model = [v for p, v in zip(self.params, values, strict=True) if p.is_model]
        return tuple(np.round(model, 14))

    def results(self, values: list[float], with_slopes: bool = False) -> Results:
        key = self._key(values)
        if with_slopes and not self.exact_reason and key not in self.slopes:
            run = self._run_with_slopes(values)
            if run is not None:
                self._store(key, values, run[0])
                self.slopes[key] = run[1]
        if key not in self.cache:
            results = simulate_driven(self.scenario(values), self.measurement)
            if results.metadata.get("method") != "lawson" and not self.exact_reason:
                # a measured motion too rough to tabulate: Magnus integrated it
                self.exact_reason = (f"the run was integrated by {results.metadata.get('method')}"
                                     ", which computes no sensitivities")
            self._store(key, values, results)
        return self.cache[key]

    def slopes_at(self, values: list[float]) -> dict[str, np.ndarray] | None:
        """{channel: ∂channel/∂(model parameters) (time, model parameter)} at ``values``,
        in the parameters' own units, or None where the path takes no sensitivities."""
        self.results(values, with_slopes=True)
        return self.slopes.get(self._key(values))

    def _store(self, key: tuple[float, ...], values: list[float], results: Results) -> None:
        if len(self.cache) > 64:
            old = next(iter(self.cache))
            self.cache.pop(old)
            self.slopes.pop(old, None)
        self.cache[key] = results
        self.simulations += 1
        if self.progress:
            self.progress(f"simulation {self.simulations}: "
                          f"{_shown(self.model_params, list(key))}")

    def _run_with_slopes(self, values: list[float]
                         ) -> tuple[Results, dict[str, np.ndarray]] | None:
        from ..simulation.sensitivities import SensitivityError, simulate_with_derivatives

        self.scenario(values)  # an invalid scenario: the error the plain run would give
        file = ScenarioFile(self.file.with_values(model_values(self.params, values)),
                            self.file.base_dir, self.file.name, self.file.source)
        paths = [p.path for p in self.model_params]
        slopes: dict[str, np.ndarray] = {}

        def run() -> Results:
            results, derivatives = simulate_with_derivatives(file, paths, shapes=False,
                                                             drive=self.inputs.drive)
            slopes.update(derivatives)
            return results

        try:
            return simulate_driven(None, self.measurement, run=run), slopes
        except SensitivityError as exc:
            self.exact_reason = str(exc)
            return None

    def scenario(self, values: list[float]) -> Scenario:
        """The driven scenario with the model values set."""
        try:
            return self.inputs.drive(self.file.build(model_values(self.params, values)))
        except ScenarioError as exc:
            model = [v for p, v in zip(self.params, values, strict=True) if p.is_model]
            raise MeasurementError(
                f"the fit reached an invalid scenario at {_shown(self.model_params, model)}: "
                f"{'; '.join(exc.problems)}; narrow the parameters' bounds") from None


def _shown(params: list[Parameter], values: list[float]) -> str:
    return ", ".join(f"{p.path} = {v:.5g}" for p, v in zip(params, values, strict=True))


def calibrated(results: Results, channel: str, params: list[Parameter],
               values: list[float]) -> np.ndarray:
    """gain · sim(t − delay) + offset + drift · t for one channel."""
    cal = {p.field: v for p, v in zip(params, values, strict=True)
           if not p.is_model and p.channel == channel}
    t = results.time
    sim = results[channel]
    delay = cal.get("delay", 0.0)
    if delay:
        sim = np.interp(t - delay, t, sim)
    return cal.get("gain", 1.0) * sim + cal.get("offset", 0.0) + cal.get("drift", 0.0) * t


OBJECTIVES = ("modal", "time")


def fit(scenario: ScenarioFile, measurement: Measurement, params: list[Parameter],
        channels: list[str] | None = None, window: tuple[float | None, float | None] = (None,
                                                                                     None),
        max_simulations: int = 60, progress: Callable[[str], None] | None = None,
        objective: str = "modal") -> FitResult:
    """Estimate ``params`` of the scenario file ``scenario`` from ``measurement`` (see module
    doc)."""
    # small dense least squares and short runs throughout: BLAS threads only contend
    with single_threaded():
        return _fit(scenario, measurement, params, channels, window, max_simulations, progress,
                    objective)


def _fit(scenario: ScenarioFile, measurement: Measurement, params: list[Parameter],
         channels: list[str] | None, window: tuple[float | None, float | None],
         max_simulations: int, progress: Callable[[str], None] | None,
         objective: str) -> FitResult:
    if objective not in OBJECTIVES:
        raise MeasurementError(f"objective must be one of {', '.join(OBJECTIVES)}, got "
                               f"{objective!r}")
    if not params:
        raise MeasurementError("no parameters to fit: give at least one (e.g. links[0].EI)")
    channels = list(channels or measurement.signals)
    for name in channels:
        if name not in measurement.signals:
            raise MeasurementError(f"fit channel {name!r} is not measured (measured: "
                                   f"{', '.join(measurement.signals) or 'none'})")
    if not channels:
        raise MeasurementError(f"{measurement.source}: no measured sensor channel to fit")
    if objective == "modal" and any(p.field == "delay" for p in params if not p.is_model):
        raise MeasurementError("a delay changes no frequency or damping: fit it with "
                               "objective = \"time\"")
    _check_measured_joints(params, measurement)
    model = _Model(scenario, params, measurement, progress)
    initial = [p.initial if p.initial is not None else
               (p.value if p.is_model else _neutral(p)) for p in params]
    first = model.results(initial)
    t = first.time
    measured = on_grid(measurement, t)
    t0, t1 = _window(window, measurement, first)
    mask = (t >= t0) & (t <= t1)
    if mask.sum() < 10 * len(params):
        raise MeasurementError(f"the fit window {t0:g} … {t1:g} s holds {int(mask.sum())} "
                               f"samples, too few for {len(params)} parameters")
    norm = {c: float(np.std(measured[c][mask])) or 1.0 for c in channels}
    # the measured free vibration's components, fitted once for the start and the features
    measured_modes = {c: damped_modes(t[mask], measured[c][mask]) for c in channels}
    start = _initial_guess(model, params, initial, channels, measured, mask, measured_modes)
    scales = [_scale(p, v, norm, t1) for p, v in zip(params, start, strict=True)]
    budget = max(3, max_simulations // (max(1, sum(p.is_model for p in params)) + 1))
    first_values = [p.initial if p.initial is not None else v
                    for p, v in zip(params, initial, strict=True)]
    if objective == "time":
        def residual(values: list[float], with_slopes: bool = False) -> np.ndarray:
            results = model.results(values, with_slopes)
            return np.concatenate([(calibrated(results, c, params, values)[mask]
                                    - measured[c][mask]) / norm[c] for c in channels])

        def jacobian(values: list[float]) -> np.ndarray | None:
            slopes = model.slopes_at(values) if model.model_params else {}
            if slopes is None:
                return None
            return _time_jacobian(model.results(values), slopes, params, values, channels,
                                  mask, norm)

        solved = list(range(len(params)))
        solution, values = _solve(residual, params, solved, start, scales, budget,
                                  jacobian=jacobian)
        r = solution.fun
        per = int(mask.sum())
        cov = _covariance(solution.jac, r, _ar1([r[i * per:(i + 1) * per]
                                                 for i in range(len(channels))]))
        rms = float(np.sqrt(np.mean(r**2)))
    else:
        features = _measured_features(measured_modes)
        if not features:
            raise MeasurementError("no free vibration found in the measured channels on the fit "
                                   f"window {t0:g} … {t1:g} s; try objective = \"time\"")

        modal: dict[tuple[float, ...], tuple[np.ndarray, np.ndarray]] = {}

        def residual(values: list[float], with_slopes: bool = False) -> np.ndarray:
            results = model.results(values, with_slopes)
            slopes = model.slopes.get(model._key(values)) if with_slopes else None
            r, jac = _modal_residual(t[mask], results, features, mask, slopes)
            if jac is not None:
                modal[model._key(values)] = (r, jac)
            return r

        def jacobian(values: list[float]) -> np.ndarray | None:
            key = model._key(values)
            if key not in modal:
                slopes = model.slopes_at(values)
                if slopes is None:
                    return None
                residual(values, True)
            return modal[key][1]

        solved = [i for i, p in enumerate(params) if p.is_model]
        if solved:
            solution, values = _solve(residual, params, solved, start, scales, budget,
                                      known_weights=True, jacobian=jacobian)
            r = solution.fun
            cov = _covariance(solution.jac, r, 0.0, known_weights=True)
        else:
            solution, values, r, cov = None, list(start), np.zeros(0), np.zeros((0, 0))
        # over the whole run, below the free vibration's frequencies: the manoeuvre's forced
        # (quasi-static) response pins the gain there; at the resonances the simulated
        # response also holds what the angles' noise drives and how sharply the filtered
        # input ends, content the measurement lacks and a regression would read as a low gain
        whole = np.ones_like(mask)
        bands = {c: BAND_FRACTION * min(m.frequency_hz for m in modes)
                 for c, modes in features.items()}
        values, cov = _linear_calibration(model.results(values), params, values, channels,
                                          measured, whole, solved, cov, scales, bands)
        rms = float(np.sqrt(np.mean(r**2))) if r.size else 0.0
    estimates, corr = _estimates(params, values, scales, cov, first_values, start,
                                 solution.active_mask if solution is not None else None,
                                 solved)
    _warn_doubts(estimates, solution, model.simulations)
    final = model.results(values)
    comparison = evaluate(_calibrated_results(final, channels, params, values), measurement)
    return FitResult(
        estimates=estimates, scenario=model.scenario(values), comparison=comparison,
        channels=channels, window=(t0, t1),
        cost=float(solution.cost) if solution is not None else 0.0,
        rms_residual=rms, simulations=model.simulations,
        status=(("converged" if solution.status > 0 else "stopped at the simulation budget")
                if solution is not None else "linear calibration only"),
        correlation=corr,
        info={"objective": objective,
              "nfev": int(solution.nfev) if solution is not None else 0,
              "success": bool(solution.success) if solution is not None else True,
              "converged": solution is None or solution.status > 0,
              "optimizer_message": solution.message if solution is not None else "",
              "jacobian": ("exact" if model.exact_reason in ("", NO_MODEL_PARAMETER) else
                           f"differences ({model.exact_reason})"),
              "residuals": int(r.size)})


def _solve(residual: Callable[..., np.ndarray], params: list[Parameter],
           chosen: list[int], start: list[float], scales: list[float],
           budget: int, known_weights: bool = False,
           jacobian: Callable[[list[float]], np.ndarray | None] | None = None
           ) -> tuple[Any, list[float]]:
    """Bounded least squares over params[chosen] in scaled variables (log or linear);
    ``known_weights``: the residuals are in units of their standard errors (`_covariance`).
    ``jacobian(values)``: the exact ∂residual/∂params[chosen] in the parameters' own units,
    or None where there is none (then differences); with it, ``residual(values, slopes)`` is
    told whether the point will likely need a Jacobian (a run then computes its
    sensitivities at once)."""
    from scipy.optimize import least_squares

    # u = 1 + log(v/scale) or 1 + (v − start)/scale: a relative finite-difference
    # step (DIFF_STEP·max(1, |u|)) then changes every parameter by about 0.1 %, far above the
    # integrator's error, and never degenerates at u = 0.
    def physical(u: np.ndarray) -> list[float]:
        values = list(start)
        for i, x in zip(chosen, u, strict=True):
            values[i] = (scales[i] * math.exp(x - 1.0) if params[i].log
                         else start[i] + scales[i] * (x - 1.0))
        return values

    def scaled(i: int, v: float) -> float:
        return 1.0 + (math.log(v / scales[i]) if params[i].log else (v - start[i]) / scales[i])

    u0 = np.array([scaled(i, start[i]) for i in chosen])
    lower = np.array([scaled(i, params[i].lower) if params[i].lower > -math.inf else -np.inf
                      for i in chosen])
    upper = np.array([scaled(i, params[i].upper) if params[i].upper < math.inf else np.inf
                      for i in chosen])
    u0 = np.clip(u0, lower + 1e-9, upper - 1e-9)
    values: dict[bytes, np.ndarray] = {}
    last: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []  # (u, tolerated, Jacobian)

    def kept(u: np.ndarray) -> bool:
        """The last Jacobian holds at u (see `jac`)."""
        return bool(last) and bool(np.all(np.abs(u - last[0][0]) <= last[0][1]))

    def fun(u: np.ndarray) -> np.ndarray:
        key = u.tobytes()  # a few dozen points at most: every one kept
        if key not in values:
            values[key] = (residual(physical(u)) if jacobian is None
                           else residual(physical(u), not kept(u)))
        return values[key]

    def jac(u: np.ndarray) -> np.ndarray:
        """The exact Jacobian (``jacobian``) in the scaled variables, else forward
        differences as scipy's "2-point" with diff_step (a backward one where a bound is in
        the way); the last Jacobian again after a step below REUSE_SIGMA standard deviations
        of the estimate there (the answer then moves by a small fraction of its own
        uncertainty, and the intervals by as little) or, of differences, below a hundredth
        of their steps, which changes them less than their own error (a last accepted step
        of round-off size would otherwise cost a simulation per parameter)."""
        if kept(u):
            return last[0][2]
        f0 = fun(u)
        point = physical(u)
        exact = jacobian(point) if jacobian is not None else None
        if exact is not None:
            # ∂v/∂u: v on a log scale, the scale on a linear one
            jacobian_u = exact * np.array([point[i] if params[i].log else scales[i]
                                           for i in chosen])
            steps = np.zeros(u.size)
        else:
            steps = DIFF_STEP * np.where(u >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(u))
            steps = np.where(u + steps > upper, -steps, steps)
            columns = []
            for i, h in enumerate(steps):
                shifted = u.copy()
                shifted[i] += h
                h = shifted[i] - u[i]  # the step as represented
                columns.append((fun(shifted) - f0) / h)
            jacobian_u = np.column_stack(columns) if columns else np.zeros((f0.size, 0))
        sigma = np.sqrt(np.clip(np.diag(_covariance(jacobian_u, f0, 0.0, known_weights)),
                                0.0, None))
        tolerated = np.maximum(1e-2 * np.abs(steps), REUSE_SIGMA * np.nan_to_num(sigma))
        last[:] = [(u.copy(), tolerated, jacobian_u)]
        return jacobian_u

    solution = least_squares(fun, u0, jac=jac, bounds=(lower, upper), method="trf",
                             x_scale=1.0, xtol=1e-5, ftol=1e-8, gtol=1e-8, max_nfev=budget)
    return solution, physical(solution.x)


DIFF_STEP = 1e-3  # relative difference step of the fit's Jacobian, in the scaled variables
REUSE_SIGMA = 0.02  # a step below this many standard deviations keeps the Jacobian


MAX_FEATURES = 2  # components per channel whose frequency and damping are matched
MAX_COMPONENTS = 3  # components fitted to a simulated channel
MIN_ENERGY = 0.1  # of the channel's dominant component


def _measured_features(measured_modes: dict[str, list[Mode]]) -> dict[str, list[Mode]]:
    """The strongest free-vibration components of every measured channel, from its fitted
    components (`damped_modes`)."""
    out = {}
    for c, modes in measured_modes.items():
        if not modes:
            continue
        top = max(m.energy for m in modes)
        strong = sorted((m for m in modes if m.energy >= MIN_ENERGY * top),
                        key=lambda m: -m.energy)[:MAX_FEATURES]
        out[c] = strong
    return out


def _modal_residual(t: np.ndarray, results: Results, features: dict[str, list[Mode]],
                    mask: np.ndarray, slopes: dict[str, np.ndarray] | None = None
                    ) -> tuple[np.ndarray, np.ndarray | None]:
    """(f_sim − f_meas)/σ_f and (ζ_sim − ζ_meas)/σ_ζ of every matched component; the
    simulated components are fitted from the measured frequencies, so they stay matched.
    With ``slopes`` ({channel: ∂channel/∂p over time}) also their exact Jacobian in p
    (`vibration.damped_mode_slopes`), else None."""
    r, rows = [], []
    for c, modes in features.items():
        y = results[c][mask]
        guesses = [m.frequency_hz for m in modes]
        # components the measurement does not show (noise) still bias the matched ones if
        # left out of the simulated signal's fit: add the simulation's own other peaks
        others = [f for f in spectral_peaks(t, y, MAX_COMPONENTS)
                  if all(abs(f / g - 1) > 0.1 for g in guesses)]
        guesses += others[:MAX_COMPONENTS - len(guesses)]
        if slopes is None:
            sim = damped_modes(t, y, guesses=guesses)
        else:
            sim, d_freq, d_zeta = damped_mode_slopes(t, y, slopes[c][mask], guesses)
        for k, (meas, got) in enumerate(zip(modes, sim, strict=False)):
            sf = max(meas.frequency_std, 1e-4 * meas.frequency_hz)
            sz = max(meas.damping_std, 0.02 * abs(meas.damping_ratio), 1e-5)
            r += [(got.frequency_hz - meas.frequency_hz) / sf,
                  (got.damping_ratio - meas.damping_ratio) / sz]
            if slopes is not None:
                rows += [d_freq[k] / sf, d_zeta[k] / sz]
    if slopes is None:
        return np.array(r), None
    width = next(iter(slopes.values())).shape[1] if slopes else 0
    return np.array(r), np.array(rows).reshape(len(r), width)


def _time_jacobian(results: Results, slopes: dict[str, np.ndarray], params: list[Parameter],
                   values: list[float], channels: list[str], mask: np.ndarray,
                   norm: dict[str, float]) -> np.ndarray:
    """∂/∂params of the time objective's residuals (gain·sim(t − delay) + offset + drift·t −
    meas)/norm, in the parameters' own units: the model columns from the run's
    sensitivities (``slopes``, columns in the order of the model parameters), the
    calibration ones analytic (a delay's through the slope of the linear interpolation)."""
    t = results.time
    model = [i for i, p in enumerate(params) if p.is_model]
    blocks = []
    for c in channels:
        cal = {p.field: v for p, v in zip(params, values, strict=True)
               if not p.is_model and p.channel == c}
        gain, delay = cal.get("gain", 1.0), cal.get("delay", 0.0)
        sim = results[c]
        d_sim = slopes[c] if model else np.zeros((t.size, 0))
        slope = np.zeros(t.size)
        if "delay" in cal:
            shifted = t - delay
            # the segment a growing delay moves along (the one left of a grid point)
            segment = np.clip(np.searchsorted(t, shifted, side="left") - 1, 0, t.size - 2)
            slope = np.diff(sim)[segment] / np.diff(t)[segment]
            slope[(shifted <= t[0]) | (shifted > t[-1])] = 0.0  # np.interp holds the ends
            sim = np.interp(shifted, t, sim)
            d_sim = np.column_stack([np.interp(shifted, t, col) for col in d_sim.T]
                                    ) if model else d_sim
        n = int(mask.sum())
        block = np.zeros((n, len(params)))
        block[:, model] = gain * d_sim[mask]
        columns = {"gain": sim[mask], "offset": np.ones(n), "drift": t[mask],
                   "delay": -gain * slope[mask]}
        for i, p in enumerate(params):
            if not p.is_model and p.channel == c:
                block[:, i] = columns[p.field]
        blocks.append(block / norm[c])
    return np.vstack(blocks)


BAND_FRACTION = 0.5  # gains are regressed below this fraction of the lowest free frequency


def _linear_calibration(results: Results, params: list[Parameter], values: list[float],
                        channels: list[str], measured: dict[str, np.ndarray], mask: np.ndarray,
                        solved: list[int], cov_model: np.ndarray, scales: list[float],
                        bands: dict[str, float] | None = None) -> tuple[list[float], np.ndarray]:
    """Gains, offsets and drifts by linear least squares on the fitted simulation, both sides
    low-passed at ``bands[channel]`` (Hz) where given; the covariance of all parameters
    (model block from the modal fit, calibration blocks from the regression with
    AR(1)-widened residual variance), all in scaled units."""
    values = list(values)
    n = len(params)
    cov = np.zeros((n, n))
    cov[np.ix_(solved, solved)] = cov_model
    t = results.time[mask]
    for c in channels:
        cal = [i for i, p in enumerate(params) if not p.is_model and p.channel == c]
        if not cal:
            continue
        columns = {"gain": results[c][mask], "offset": np.ones(t.size), "drift": t}
        a = np.column_stack([columns[params[i].field] for i in cal])
        b = measured[c][mask]
        band = (bands or {}).get(c)
        if band is not None and band < 0.5 / float(t[1] - t[0]):
            # the same linear filter on both sides keeps meas = gain·sim + … exact
            fs = 1.0 / float(t[1] - t[0])
            a = np.column_stack([zero_phase_lowpass(col, band, fs) for col in a.T])
            b = zero_phase_lowpass(b, band, fs)
        coef, *_ = np.linalg.lstsq(a, b, rcond=None)
        r = a @ coef - b
        s2 = float(r @ r) / max(r.size - len(cal), 1) * _ar1_factor(_ar1([r]))
        size = np.array([scales[i] for i in cal])
        cov[np.ix_(cal, cal)] = s2 * np.linalg.pinv(a.T @ a) / np.outer(size, size)
        for i, v in zip(cal, coef, strict=True):
            values[i] = float(v)
    return values, cov

def _neutral(p: Parameter) -> float:
    return 1.0 if p.field == "gain" else 0.0


def _window(window: tuple[float | None, float | None], measurement: Measurement,
            results: Results) -> tuple[float, float]:
    t = results.time
    start, end = window
    if start is None:
        found = manoeuvre(measurement, results)
        start = found.free_start
        if start is None:
            raise MeasurementError(
                f"no free vibration found after the manoeuvre: {found.reason}; give the fit "
                "window explicitly (--window START:END or [fit] window = [START, END]) or "
                "free_vibration_start in [measurement]")
    end = float(t[-1]) if end is None else end
    if end > t[-1] + 0.5 * (t[-1] - t[-2]):  # not clipped: a typo (30 for 3) would pass
        raise MeasurementError(f"fit window end {end:g} s is past the simulated span "
                               f"{t[0]:g} … {t[-1]:g} s; give END <= {t[-1]:g} or leave it "
                               "out (the end of the data)")
    if not t[0] <= start < end:
        raise MeasurementError(f"fit window {start:g} … {end:g} s is empty or outside the "
                               f"simulated span {t[0]:g} … {t[-1]:g} s")
    return float(start), float(end)


def _initial_guess(model: _Model, params: list[Parameter], values: list[float],
                   channels: list[str], measured: dict[str, np.ndarray],
                   mask: np.ndarray, measured_modes: dict[str, list[Mode]]) -> list[float]:
    """Frequency- and damping-matched model values, linear calibration (see module doc);
    ``measured_modes``: the measured channels' fitted components on the window."""
    values = list(values)
    t = model.results(values).time
    duration = float(t[mask][-1] - t[mask][0])
    ref = {c: strongest(measured_modes[c], duration) for c in channels}
    link_of = _channel_links(model.base)
    for _ in range(2):
        results = model.results(values)
        sims: dict[str, Mode | None] = {}  # this run's dominant modes, by channel
        changed = False
        for i, p in enumerate(params):
            link = _link_of(p)
            if link is None or p.field not in ("EI", "E", "damping_ratio") or p.initial:
                continue
            mine = [c for c in channels if link_of.get(c) == link] or channels
            ratios = []
            for c in mine:
                if c not in sims:
                    sims[c] = dominant_mode(t[mask], results[c][mask])
                sim = sims[c]
                if ref[c] is None or sim is None:
                    continue
                if p.field != "damping_ratio":  # f² ∝ EI ∝ E
                    ratio = (ref[c].frequency_hz / sim.frequency_hz) ** 2
                else:
                    ratio = ref[c].damping_ratio / max(sim.damping_ratio, 1e-6)
                if 0.25 < ratio < 4.0:  # the same mode in both, else leave it to the fit
                    ratios.append(ratio)
            if ratios:
                new = float(np.clip(values[i] * np.median(ratios), p.lower, p.upper))
                changed |= abs(new / values[i] - 1) > 1e-3
                values[i] = new
        if not changed:
            break
    # the fit starts here with a Jacobian: its run computes the sensitivities with it
    results = model.results(values, with_slopes=True)
    for c in channels:
        cal = [i for i, p in enumerate(params) if not p.is_model and p.channel == c
               and p.field in ("gain", "offset", "drift") and p.initial is None]
        if not cal:
            continue
        columns = {"gain": results[c][mask], "offset": np.ones(int(mask.sum())),
                   "drift": t[mask]}
        a = np.column_stack([columns[params[i].field] for i in cal])
        rest = measured[c][mask] - calibrated(results, c, params, values)[mask]
        rest += sum(columns[params[i].field] * values[i] for i in cal)
        coef, *_ = np.linalg.lstsq(a, rest, rcond=None)
        for i, v in zip(cal, coef, strict=True):
            values[i] = float(np.clip(v, params[i].lower, params[i].upper))
    return values


def _link_of(p: Parameter) -> int | None:
    """The link index of a ``links[k].…`` parameter, else None."""
    if p.target is None or p.target[0] != "links" or len(p.target) != 3:
        return None
    return int(p.target[1])  # type: ignore[arg-type]  # entry names are resolved to indices


def _channel_links(scenario: Scenario) -> dict[str, int]:
    """The link each channel of ``scenario`` is on (sensors and tip positions)."""
    index = {link.name: k for k, link in enumerate(scenario.chain.links)}
    return {c.name: index[c.subject] for c in catalogue(scenario) if c.subject in index}


def _check_measured_joints(params: list[Parameter], measurement: Measurement) -> None:
    """Fields of a joint driven by the measured angles change nothing: refuse them."""
    for p in params:
        joint = p.target[1] if p.target and p.target[0] == "joints" else None
        if joint in measurement.angles:
            raise MeasurementError(f"parameter {p.path}: joint {int(joint) + 1} is driven by "  # type: ignore[arg-type]
                                   "the measured angles, so its fields change nothing")


def _scale(p: Parameter, value: float, norm: dict[str, float], duration: float) -> float:
    if p.log:
        return value
    if p.is_model:  # a zero start has both bounds (parameters.py)
        return abs(value) or (p.upper - p.lower) / 10.0
    size = norm.get(str(p.channel), 1.0)
    return {"gain": max(abs(value), 0.1), "offset": size, "drift": size / max(duration, 1e-9),
            "delay": 1e-3}[p.field]


def _ar1(parts: list[np.ndarray]) -> float:
    """Mean lag-one autocorrelation of residual blocks."""
    rhos = []
    for r in parts:
        r = r - r.mean()
        denom = float(r @ r)
        rhos.append(float(r[1:] @ r[:-1]) / denom if denom > 0 else 0.0)
    return float(np.mean(rhos)) if rhos else 0.0


def _ar1_factor(rho: float) -> float:
    return (1 + rho) / (1 - rho) if 0 < rho < 1 else 1.0


def _covariance(jac: np.ndarray, r: np.ndarray, rho: float,
                known_weights: bool = False) -> np.ndarray:
    """s² (JᵀJ)⁻¹ in scaled variables. With residuals already divided by their standard
    errors (known_weights), s² = max(1, χ²/dof); else s² = Σr²/dof, AR(1)-widened."""
    m, n = jac.shape
    dof = m - n
    chi2 = float(r @ r) / dof if dof > 0 else 1.0
    s2 = max(1.0, chi2) if known_weights else chi2 * _ar1_factor(rho)
    return s2 * np.linalg.pinv(jac.T @ jac)


def _estimates(params: list[Parameter], values: list[float], scales: list[float],
               cov: np.ndarray, initial: list[float], start: list[float],
               active: np.ndarray | None, solved: list[int]) -> tuple[list[Estimate],
                                                                     np.ndarray]:
    """Estimates with 95 % intervals from ``cov`` over all params in scaled units (log of
    value/scale, or value/scale); ``active`` is least_squares' bound mask of params[solved]."""
    full = cov
    std_u = np.sqrt(np.clip(np.diag(full), 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        corr = np.nan_to_num(full / np.outer(std_u, std_u))
    at_bound = {i: bool(a != 0) for i, a in zip(solved, active if active is not None else [],
                                                  strict=False)}
    out = []
    for i, p in enumerate(params):
        v, su = values[i], float(std_u[i])
        if p.log:
            std, low, high = v * su, v * math.exp(-Z95 * su), v * math.exp(Z95 * su)
        else:
            std = scales[i] * su
            low, high = v - Z95 * std, v + Z95 * std
        # log-scaled: wider than a decade; linear: wider than ± the parameter's typical size
        wide = (high / low > UNIDENTIFIABLE_RATIO if p.log and low > 0
                else not math.isfinite(su) or Z95 * su > 1.0)
        out.append(Estimate(path=p.path, unit=p.unit, initial=initial[i], start=start[i],
                            value=v, std=std, ci_low=low, ci_high=high, lower=p.lower,
                            upper=p.upper, at_bound=at_bound.get(i, False), identifiable=not wide))
    return out, corr


def _warn_doubts(estimates: list[Estimate], solution: Any, simulations: int) -> None:
    """FitWarning for an optimiser stopped by its budget and for unidentifiable parameters."""
    import warnings

    if solution is not None and solution.status == 0:  # scipy: max_nfev reached
        warnings.warn(f"the fit stopped at its budget ({simulations} simulations) before "
                      "converging; the estimates may not be the optimum: raise "
                      "max_simulations or start closer", FitWarning, stacklevel=3)
    for e in estimates:
        if not e.identifiable:
            warnings.warn(f"{e.path} is not identifiable from these data: {e.doubt}; fix it "
                          "or measure what excites it", FitWarning, stacklevel=3)


def _calibrated_results(results: Results, channels: list[str], params: list[Parameter],
                        values: list[float]) -> Results:
    out = Results(time=results.time, metadata=dict(results.metadata))
    for name, channel in results.channels.items():
        data = calibrated(results, name, params, values) if name in channels else results[name]
        out.add(channel, data)
    return out
