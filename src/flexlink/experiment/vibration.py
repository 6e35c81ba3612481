"""Free vibration: where it starts, and its dominant frequency and damping ratio.

Estimator (docs/experiment.md): the peaks of a zero-padded, Hann-windowed FFT give starting
frequencies of up to ``max_modes`` components; then the signal is fitted by least squares with

    y(t) = c0 + c1·s + Σ_k exp(−σ_k s) (a_k cos ω_k s + b_k sin ω_k s),   s = t − t_start,

the amplitudes (c, a, b) solved linearly inside every evaluation (variable projection), σ_k and
ω_k nonlinearly. The dominant component is the one with the most energy in the window,
Σ over samples of its squared contribution. Its damped frequency is f = ω/2π and its damping
ratio ζ = σ/√(σ² + ω²). The FFT alone resolves 1/(window) Hz at best; the fit is limited
by noise and by how well the components are separated, not by the window length.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..solvers.threads import single_threaded

MIN_CYCLES = 2.0  # the window must hold this many periods of a component
PEAK_FRACTION = 0.05  # spectral peaks below this fraction of the highest are ignored


@dataclass(frozen=True)
class Mode:
    """One damped sinusoid: damped frequency (Hz), damping ratio, amplitude at the window start."""

    frequency_hz: float
    damping_ratio: float
    amplitude: float
    energy: float
    frequency_std: float = math.nan  # Hz, standard error from the fit's Jacobian
    damping_std: float = math.nan  # standard error of the damping ratio


EDGE_S = 0.1  # s ignored at each end of a record: a zero-phase filter's edge transients
SMOOTH_S = 0.05  # s, moving average before thresholds: noise is not motion
REST_FRACTION = 0.1  # of the record at each end where the rest angle and its noise are measured
NOISE_SIGMAS = 5.0  # a departure from rest beyond this many noise σ is motion


@dataclass(frozen=True)
class JointRest:
    """One joint's rest–move–rest: rest angles (rad) before and after, times (s) where it
    leaves the first and reaches the second, the threshold (rad) that decided, the fraction
    of the move's duration those thresholds may hide, and — if it has not come to rest at
    the end of the data — by how much it still moves (rad over the record's last tenth)."""

    name: str
    initial: float
    final: float
    start: float
    end: float
    threshold: float
    hidden: float
    moving: float | None = None  # rad, change over the last tenth; None: at rest at the end

    @property
    def travel(self) -> float:
        return abs(self.final - self.initial)


@dataclass(frozen=True)
class Manoeuvre:
    """When the joints move (s) and where the free vibration starts (None: a joint still
    moves at the end of the data, ``reason`` says which and by how much)."""

    start: float
    end: float
    free_start: float | None
    margin: float = 0.0  # s added after the detected end (and kept before the start)
    joints: tuple[JointRest, ...] = ()
    reason: str = ""


MARGIN_FRACTION_MIN = 0.1  # of the manoeuvre's duration: a smooth move ends asymptotically


def _smoothed(y: np.ndarray, width: int) -> np.ndarray:
    """Centred moving average over ``width`` samples (edges use the samples there are)."""
    if width <= 1:
        return y.astype(float)
    kernel = np.ones(width)
    return np.convolve(y, kernel, "same") / np.convolve(np.ones_like(y), kernel, "same")


def _rest_level(t: np.ndarray, y: np.ndarray) -> tuple[float, float, float]:
    """Median (rad), scatter about a straight line (rad, std) and change along that line
    over the segment (rad) of a rest segment."""
    s = t - t[0]
    line = np.polyfit(s, y, 1) if y.size > 2 else np.array([0.0, float(np.mean(y))])
    return (float(np.median(y)), float(np.std(y - np.polyval(line, s))),
            float(line[0] * (s[-1] if s.size else 0.0)))


def joint_rest(t: np.ndarray, angle: np.ndarray, name: str = "",
               rel_tol: float = 1e-3) -> JointRest | None:
    """The rest–move–rest of one joint angle (rad) on a uniform grid t (s), or None if it
    does not move. Robust to filtered noise (moving average; thresholds from the noise at
    rest, measured on the record's ends, then again on all of the rest found) and to filter
    edge effects (EDGE_S ignored at both ends)."""
    dt = float(t[1] - t[0])
    edge = min(round(EDGE_S / dt), angle.size // 20)
    y = _smoothed(angle, max(1, round(SMOOTH_S / dt)))
    ti, yi = t[edge:angle.size - edge], y[edge:angle.size - edge]
    n_rest = max(3, int(REST_FRACTION * angle.size))
    rest = _move(ti, yi, n_rest, n_rest, rel_tol)
    if rest is None:
        return None
    # the noise of a short rest segment is poorly known (filtered noise is correlated):
    # measure it again on all the rest before and after the move
    head = int(np.searchsorted(ti, rest.start - rest.hidden * (rest.end - rest.start)))
    tail = yi.size - int(np.searchsorted(ti, rest.end + rest.hidden * (rest.end - rest.start)))
    if head > n_rest or tail > n_rest:
        rest = _move(ti, yi, max(head, n_rest), max(tail, n_rest), rel_tol) or rest
    return dataclasses.replace(rest, name=name)


def _move(t: np.ndarray, y: np.ndarray, n_head: int, n_tail: int,
          rel_tol: float) -> JointRest | None:
    """`joint_rest` with the rest measured on the first n_head and last n_tail samples."""
    initial, noise0, _ = _rest_level(t[:n_head], y[:n_head])
    final, noise1, _ = _rest_level(t[-n_tail:], y[-n_tail:])
    span = max(abs(final - initial), float(np.ptp(y)))
    if span <= max(NOISE_SIGMAS * max(noise0, noise1), 1e-6):  # rad: it does not move
        return None
    thr0, thr1 = (max(rel_tol * span, NOISE_SIGMAS * n) for n in (noise0, noise1))
    away0 = np.flatnonzero(np.abs(y - initial) > thr0)
    away1 = np.flatnonzero(np.abs(y - final) > thr1)
    first = int(away0[0]) if away0.size else 0
    last = int(away1[-1]) if away1.size else y.size - 1
    # a rest-to-rest move leaves and reaches rest like c·u³ of its travel (c ≥ 1: cycloidal
    # 6.6, quintic 10), so a threshold of a fraction r of the travel hides up to r^(1/3) of
    # its duration at each end
    hidden = max(MARGIN_FRACTION_MIN, 1.2 * (max(thr0, thr1) / span) ** (1.0 / 3.0))
    n_last = max(3, int(REST_FRACTION * y.size))
    _, _, change = _rest_level(t[-n_last:], y[-n_last:])
    still = abs(change) > thr1 or last >= y.size - 1
    return JointRest(name="", initial=initial, final=final, start=float(t[first]),
                     end=float(t[last]), threshold=max(thr0, thr1), hidden=hidden,
                     moving=max(abs(change), abs(float(y[-1]) - final)) if still else None)


def detect_manoeuvre(t: np.ndarray, angles: Mapping[str, np.ndarray],
                     rel_tol: float = 1e-3) -> Manoeuvre:
    """The joints' manoeuvre on a uniform grid t (s) from their angles (rad, by name): it
    starts when the first leaves rest and ends when the last reaches it (a departure beyond
    ``rel_tol`` of its travel or five noise σ at rest, after a 50 ms moving average). The
    free vibration starts a margin later (the thresholds hide the asymptotic end of a smooth
    move: at least a tenth of its duration)."""
    rests = [r for name, a in angles.items()
             if (r := joint_rest(t, np.asarray(a, dtype=float), name, rel_tol)) is not None]
    if not rests:
        return Manoeuvre(start=float(t[0]), end=float(t[0]), free_start=float(t[0]))
    start = min(r.start for r in rests)
    end = max(r.end for r in rests)
    margin = max(r.hidden for r in rests) * (end - start)
    moving = [r for r in rests if r.moving is not None]
    free = end + margin
    reason = ""
    if moving:
        reason = "; ".join(
            f"{r.name or 'a joint'} still moves at the end of the data: "
            f"{math.degrees(r.moving):.3g} deg over the last {REST_FRACTION:.0%} of the record "
            f"(its noise at rest allows {math.degrees(r.threshold):.2g} deg)" for r in moving)
    elif free >= t[-1]:
        reason = (f"the manoeuvre ends at t = {end:.4g} s and the free vibration would start "
                  f"at {free:.4g} s, too close to the end of the data ({t[-1]:.4g} s)")
    return Manoeuvre(start=start, end=end, free_start=None if reason else float(free),
                     margin=margin, joints=tuple(rests), reason=reason)


def manoeuvre_end(t: np.ndarray, angles: list[np.ndarray], rel_tol: float = 1e-3) -> float | None:
    """Start (s) of the free vibration after the joints' manoeuvre (`detect_manoeuvre`):
    t[0] if nothing moves, None if some joint is still moving at the end."""
    return detect_manoeuvre(t, {f"joint{k + 1}": a for k, a in enumerate(angles)},
                            rel_tol).free_start


def dominant_mode(t: np.ndarray, y: np.ndarray, max_modes: int = 3) -> Mode | None:
    """The component of the free vibration ``y(t)`` (uniform t) with the most energy, or None
    if the window is too short or holds no oscillation."""
    return strongest(damped_modes(t, y, max_modes), float(t[-1] - t[0]) if len(t) else 0.0)


def strongest(modes: list[Mode], duration: float) -> Mode | None:
    """The mode of ``modes`` with the most energy among those with MIN_CYCLES periods in
    ``duration`` (s), or None (`dominant_mode` of already fitted modes)."""
    modes = [m for m in modes if m.frequency_hz * duration >= MIN_CYCLES]  # a drift: none
    return max(modes, key=lambda m: m.energy) if modes else None


def damped_modes(t: np.ndarray, y: np.ndarray, max_modes: int = 3,
                 guesses: list[float] | None = None) -> list[Mode]:
    """Fitted damped sinusoids of y(t), strongest spectral peaks first (see module doc), or
    one per starting frequency in ``guesses`` (Hz), in that order. Standard errors assume
    white residuals, widened by the AR(1) factor of their lag-one autocorrelation."""
    fitted = _fit_components(t, y, max_modes, guesses)
    return fitted.modes if fitted is not None else []


def damped_mode_slopes(t: np.ndarray, y: np.ndarray, dy: np.ndarray,
                       guesses: list[float]) -> tuple[list[Mode], np.ndarray, np.ndarray]:
    """`damped_modes` of y(t) from ``guesses`` and the derivatives of their frequencies (Hz)
    and damping ratios along the columns of ``dy`` (n, P): ∂y/∂p of P parameters p, giving
    (K, P) arrays ∂f_k/∂p and ∂ζ_k/∂p.

    The fitted θ = (σ, ω) minimise F(θ, y) = ½‖r‖², r = A(θ)c(θ) − y (variable projection),
    so ∂F/∂θ = 0 and, by the implicit function theorem, ∂θ/∂y = H⁻¹ Jᵀ with H = ∂²F/∂θ² and
    J = ∂r/∂θ (the exact projected Jacobian; ∂(∂F/∂θ)/∂y = −Jᵀ). H holds the residual's
    second-order term as well as JᵀJ: it comes from central differences of the exact
    gradient Jᵀr in θ at the fixed signal (no refit). A component held at a bound of the
    fit has zero slope."""
    p = dy.shape[1]
    fitted = _fit_components(t, y, len(guesses), guesses)
    if fitted is None:
        return [], np.zeros((0, p)), np.zeros((0, p))
    theta, k = fitted.theta, len(fitted.modes)
    free = fitted.free
    d_theta = np.zeros((theta.size, p))
    if free.any():
        def gradient(x: np.ndarray) -> np.ndarray:
            r, jac = fitted.projected(x)
            return jac.T @ r

        idx = np.flatnonzero(free)
        steps = SLOPE_STEP * (np.abs(theta) + np.max(np.abs(theta[k:])))
        hessian = np.empty((idx.size, idx.size))
        for j, i in enumerate(idx):
            up, down = theta.copy(), theta.copy()
            up[i] += steps[i]
            down[i] -= steps[i]
            hessian[:, j] = (gradient(up)[idx] - gradient(down)[idx]) / (up[i] - down[i])
        hessian = 0.5 * (hessian + hessian.T)
        _, jac = fitted.projected(theta)
        d_theta[idx] = np.linalg.solve(hessian, jac[:, idx].T @ (dy / fitted.scale))
    sigma, omega = theta[:k], theta[k:]
    d_sigma, d_omega = d_theta[:k], d_theta[k:]
    norm3 = np.hypot(sigma, omega)[:, None] ** 3
    d_zeta = (omega[:, None] ** 2 * d_sigma - (sigma * omega)[:, None] * d_omega) / norm3
    return fitted.modes, d_omega / (2 * math.pi), d_zeta


SLOPE_STEP = 1e-7  # of the parameters' size: the step of the differences of the gradient


@dataclass(frozen=True)
class _Fitted:
    """A fit of damped sinusoids: the components, the nonlinear parameters θ = (σ, ω),
    which of them are off their bounds, the signal's scale and the projected residual and
    Jacobian (θ) → (r, ∂r/∂θ) of the signal divided by it."""

    modes: list[Mode]
    theta: np.ndarray
    free: np.ndarray
    scale: float
    projected: Any


def _fit_components(t: np.ndarray, y: np.ndarray, max_modes: int,
                    guesses: list[float] | None) -> _Fitted | None:
    """The fit behind `damped_modes` (see module doc); None without a usable signal."""
    from scipy.optimize import least_squares

    t = np.asarray(t, dtype=float)
    y = np.asarray(y, dtype=float)
    if t.size < 16 or not np.all(np.isfinite(y)):
        return None
    s = t - t[0]
    if guesses is None:
        guesses = spectral_peaks(t, y, max_modes)
    if not guesses:
        return None
    scale = float(np.std(y)) or 1.0
    yn = y / scale
    omega0 = np.array([2 * math.pi * f for f in guesses])

    k_modes = len(guesses)

    def basis(params: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The columns [1, s/s_end, e^(−σs) cos ωs, e^(−σs) sin ωs, …] and, per component,
        s e^(−σs) cos ωs and s e^(−σs) sin ωs (of which their derivatives are made)."""
        sigma, omega = params[:k_modes], params[k_modes:]
        decay = np.exp(-np.outer(s, sigma))
        cos, sin = decay * np.cos(np.outer(s, omega)), decay * np.sin(np.outer(s, omega))
        a = np.empty((s.size, 2 + 2 * k_modes))
        a[:, 0], a[:, 1] = 1.0, s / s[-1]
        a[:, 2::2], a[:, 3::2] = cos, sin
        return a, s[:, None] * cos, s[:, None] * sin

    last: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}

    def projected(params: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Residual a·c − y of the least-squares amplitudes c and its exact Jacobian in the
        nonlinear parameters θ (Golub & Pereyra: ∂r/∂θ = (I − AA⁺) ∂A c − A⁺ᵀ ∂Aᵀ r), from
        the SVD a = U S Vᵀ with lstsq's cut-off of small singular values."""
        key = params.tobytes()
        if key not in last:
            a, s_cos, s_sin = basis(params)
            u, sv, vt = np.linalg.svd(a, full_matrices=False)
            keep = sv > np.finfo(float).eps * max(a.shape) * sv[0]
            u, sv, vt = u[:, keep], sv[keep], vt[keep]
            coef = vt.T @ ((u.T @ yn) / sv)
            r = a @ coef - yn
            # ∂A/∂σ_k: −s times the component's two columns; ∂A/∂ω_k: (−s sin, s cos)
            d = np.empty((s.size, 2 * k_modes))
            c_cos, c_sin = coef[2::2], coef[3::2]
            d[:, :k_modes] = -(s_cos * c_cos + s_sin * c_sin)
            d[:, k_modes:] = -s_sin * c_cos + s_cos * c_sin
            d -= u @ (u.T @ d)
            dtr = np.empty((2 + 2 * k_modes, 2 * k_modes))  # ∂Aᵀ r, column per parameter
            dtr[:] = 0.0
            r_cos, r_sin = s_cos.T @ r, s_sin.T @ r
            for k in range(k_modes):
                dtr[2 + 2 * k, k], dtr[3 + 2 * k, k] = -r_cos[k], -r_sin[k]
                dtr[2 + 2 * k, k_modes + k], dtr[3 + 2 * k, k_modes + k] = -r_sin[k], r_cos[k]
            d -= u @ ((vt @ dtr) / sv[:, None])
            last.clear()
            last[key] = (r, d)
        return last[key]

    x0 = np.concatenate([0.01 * omega0, omega0])
    lower = np.concatenate([np.full(len(guesses), -0.5 / s[-1]), 0.5 * omega0])
    upper = np.concatenate([np.full(len(guesses), np.inf), 1.5 * omega0])
    x0 = np.clip(x0, lower + 1e-12, upper - 1e-12)
    # hundreds of least-squares solves of a few columns: BLAS threads only contend there
    with single_threaded():
        fit = least_squares(lambda p: projected(p)[0], x0, jac=lambda p: projected(p)[1],
                            bounds=(lower, upper), x_scale=np.abs(x0) + 1e-3, method="trf",
                            xtol=1e-12, ftol=1e-12, max_nfev=200)
        a = basis(fit.x)[0]
        coef, *_ = np.linalg.lstsq(a, yn, rcond=None)
        std = _standard_errors(fit.jac, fit.fun, a.shape[1])
    modes = []
    for k in range(len(guesses)):
        sigma, omega = float(fit.x[k]), float(fit.x[len(guesses) + k])
        s_sigma, s_omega = std[k], std[len(guesses) + k]
        part = a[:, 2 + 2 * k: 4 + 2 * k] @ coef[2 + 2 * k: 4 + 2 * k] * scale
        modes.append(Mode(frequency_hz=omega / (2 * math.pi),
                          damping_ratio=sigma / math.hypot(sigma, omega),
                          amplitude=float(math.hypot(*coef[2 + 2 * k: 4 + 2 * k]) * scale),
                          energy=float(np.sum(part**2)),
                          frequency_std=s_omega / (2 * math.pi),
                          damping_std=math.hypot(s_sigma / omega, sigma * s_omega / omega**2)))
    return _Fitted(modes, np.array(fit.x, dtype=float), np.asarray(fit.active_mask) == 0,
                   scale, projected)


def _standard_errors(jac: np.ndarray, r: np.ndarray, n_linear: int) -> np.ndarray:
    """σ of the nonlinear parameters: s² (JᵀJ)⁻¹, s² = Σr²/(m − p), AR(1)-widened."""
    m, p = jac.shape
    s2 = float(r @ r) / max(m - p - n_linear, 1)
    rc = r - r.mean()
    rho = float(rc[1:] @ rc[:-1]) / float(rc @ rc) if float(rc @ rc) > 0 else 0.0
    s2 *= (1 + rho) / (1 - rho) if 0 < rho < 1 else 1.0
    cov = s2 * np.linalg.pinv(jac.T @ jac)
    return np.sqrt(np.clip(np.diag(cov), 0.0, None))


def spectral_peaks(t: np.ndarray, y: np.ndarray, max_peaks: int) -> list[float]:
    """Frequencies (Hz) of the highest peaks of the zero-padded Hann-windowed FFT of the
    linearly detrended y(t), each with at least MIN_CYCLES periods in the window."""
    dt = (t[-1] - t[0]) / (t.size - 1)
    detrended = y - np.polyval(np.polyfit(t - t[0], y, 1), t - t[0])
    n = 1 << max(16, math.ceil(math.log2(16 * t.size)))
    spectrum = np.abs(np.fft.rfft(detrended * np.hanning(t.size), n))
    freqs = np.fft.rfftfreq(n, dt)
    usable = freqs >= MIN_CYCLES / (t[-1] - t[0])
    spectrum = np.where(usable, spectrum, 0.0)
    if spectrum.max() <= 0:
        return []
    peaks = local_maxima(spectrum)
    peaks = peaks[spectrum[peaks] >= PEAK_FRACTION * spectrum.max()]
    order = np.argsort(spectrum[peaks])[::-1][:max_peaks]
    return [float(freqs[peaks[i]]) for i in order]


def local_maxima(x: np.ndarray) -> np.ndarray:
    """Indices of the local maxima of ``x``, the middle (left of two) of a flat top; the ends
    are none (``scipy.signal.find_peaks`` without conditions, which imports scipy.stats)."""
    x = np.asarray(x, dtype=float)
    if x.size < 3:
        return np.zeros(0, dtype=np.intp)
    starts = np.flatnonzero(np.concatenate(([True], x[1:] != x[:-1])))  # runs of equal values
    ends = np.append(starts[1:] - 1, x.size - 1)
    inner = (starts > 0) & (ends < x.size - 1)
    starts, ends = starts[inner], ends[inner]
    peak = (x[starts - 1] < x[starts]) & (x[ends + 1] < x[ends])
    return (starts[peak] + ends[peak]) // 2
