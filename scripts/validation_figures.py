"""Regenerate every figure of docs/validation.md (and print the numbers quoted there).

    python scripts/validation_figures.py        # all figures into docs/figures/

The reference problems, published values and the independent FE reference come from
tests/validation/benchmarks.py, the same objects the validation tests use. Ten simulations
of the spin-up beam plus the FE references: about 30 s.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy.linalg import eigh

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # for tests.validation.benchmarks

from flexlink.dynamics.first_order import FirstOrderSystem
from flexlink.errors import SimulationError
from flexlink.model import Chain
from flexlink.motion import Spinup
from flexlink.simulation import output_times, simulate
from flexlink.solvers import GivenMatrices, integrate_magnus
from tests.validation.benchmarks import KANE_RYAN_BANERJEE_1987 as BEAM
from tests.validation.benchmarks import WRIGHT_1982 as TABLE
from tests.validation.benchmarks import RotatingBeamFE

FIGURES = ROOT / "docs" / "figures"
DPI = 150
COLORS = plt.rcParams["axes.prop_cycle"].by_key()["color"]


def omega2(rate: float, modes: int, stiffening: bool) -> np.ndarray:
    """flexlink's ω² (rad²/s²) at constant hub rate, ascending (as in test_rotating_beam.py)."""
    chain = Chain((BEAM.link(modes),), (Spinup(math.degrees(rate), 0.0, 1.0),))
    M, _, K, _ = (a[0] for a in FirstOrderSystem(chain, stiffening).matrices(np.array([2.0])))
    return eigh(K, M, eigvals_only=True)


def rotating_beam_frequencies() -> None:
    s = BEAM.time_scale
    gamma = np.linspace(0.0, 12.0, 241)
    stiff = np.array([np.sqrt(omega2(g / s, 8, True)[:2]) * s for g in gamma])
    plain = np.array([omega2(g / s, 8, False)[:2] * s * s for g in gamma])
    fe = RotatingBeamFE(1.0, 1.0, 1.0, elements=80)

    fig, (ax, ax_err) = plt.subplots(1, 2, figsize=(11.5, 4.4))
    for mode, color in ((1, COLORS[0]), (2, COLORS[1])):
        ax.plot(gamma, stiff[:, mode - 1], color=color, label=f"flexlink, stiffened, mode {mode}")
        real = np.where(plain[:, mode - 1] >= 0, np.sqrt(np.abs(plain[:, mode - 1])), np.nan)
        ax.plot(gamma, real, "--", color=color, label=f"flexlink, paper's model, mode {mode}")
        ax.plot(TABLE.gamma, TABLE.in_plane(mode), "o", color=color, mfc="none",
                label=f"Wright et al. 1982, mode {mode} (in-plane)")
    excess = gamma**2 - TABLE.flapwise(1)[0] ** 2
    ax.plot(gamma, np.where(excess >= 0, np.sqrt(np.abs(excess)), np.nan), ":",
            color=COLORS[0], label="paper's model, growth rate of mode 1")
    for rate in BEAM.rates:
        ax.axvline(rate * s, color="0.6", lw=0.8)
        ax.text(rate * s, 39, f" KRB Ω = {rate:g} rad/s", fontsize=8, va="top", color="0.4")
    ax.set_xlabel("dimensionless rotation speed γ = Ω√(m̄L⁴/EI)")
    ax.set_ylabel("dimensionless in-plane frequency ω√(m̄L⁴/EI)")
    ax.set_title("In-plane frequencies of the rotating cantilever")
    ax.set_xlim(0, 12)
    ax.set_ylim(0, 40)
    ax.legend(fontsize=7, loc="center right")

    g_err = np.array(TABLE.gamma[1:])
    for n, ls in ((2, ":"), (4, "-."), (8, "-")):
        err = np.array([np.sqrt(omega2(g / s, n, True)[:2]) * s / fe.frequencies(g, 2) - 1
                        for g in g_err])
        for mode, color in ((1, COLORS[0]), (2, COLORS[1])):
            ax_err.semilogy(g_err, err[:, mode - 1], ls, color=color,
                            label=f"{n} modes vs FE, mode {mode}")
    table_err = np.array([np.abs(np.sqrt(omega2(g / s, 8, True)[:2]) * s
                                 / [TABLE.in_plane(1)[k], TABLE.in_plane(2)[k]] - 1)
                          for k, g in enumerate(TABLE.gamma)])
    for mode, color in ((1, COLORS[0]), (2, COLORS[1])):
        ax_err.semilogy(TABLE.gamma, table_err[:, mode - 1], "o", color=color, mfc="none",
                        label=f"|8 modes vs Wright 1982|, mode {mode}")
        ax_err.semilogy(TABLE.gamma, TABLE.in_plane_rounding(mode), "x", color=color, ms=4,
                        label=f"rounding bound of the table, mode {mode}")
    ax_err.set_xlabel("dimensionless rotation speed γ")
    ax_err.set_ylabel("relative error of the in-plane frequency")
    ax_err.set_title("Error (flexlink with stiffening)")
    ax_err.set_ylim(1e-8, 1e-1)
    ax_err.legend(fontsize=7, ncol=2, loc="upper left")
    fig.tight_layout()
    fig.savefig(FIGURES / "rotating_beam_frequencies.png", dpi=DPI)
    plt.close(fig)

    print("case 1: rotating cantilever, flexlink 8 modes with stiffening vs Wright et al. 1982")
    rounding = np.stack([TABLE.in_plane_rounding(1), TABLE.in_plane_rounding(2)], axis=1)
    for k, g in enumerate(TABLE.gamma):
        print(f"  γ = {g:4.1f}: mode 1 {table_err[k, 0]:.1e}  mode 2 {table_err[k, 1]:.1e}  "
              f"(rounding {rounding[k, 0]:.1e}, {rounding[k, 1]:.1e})")
    print(f"  max: mode 1 {table_err[:, 0].max():.2e}, mode 2 {table_err[:, 1].max():.2e}")
    print(f"  divergence speed of the paper's model: {BEAM.first_frequency:.4f} rad/s")


def spinup_runs(mode_counts: tuple[int, ...]) -> dict:
    runs = {}
    for rate in BEAM.rates:
        for n in mode_counts:
            started = time.perf_counter()
            result = simulate(BEAM.scenario(rate, n, True))
            runs[rate, n] = result
            print(f"  simulate Ω = {rate:g} rad/s, {n} modes, stiffened: "
                  f"{time.perf_counter() - started:.1f} s wall")
    return runs


def diverging_tip(rate: float, t_end: float) -> tuple[np.ndarray, np.ndarray]:
    """Tip deflection of the paper's model past the point where simulate() refuses it (the
    integrator alone, no validity check), for the plot."""
    system = FirstOrderSystem(BEAM.scenario(rate, 4, False).chain, geometric_stiffening=False)
    t = output_times(t_end, BEAM.dt_out)
    z = integrate_magnus(GivenMatrices(system.matrices, system.n, system.max_frequency), t,
                         1e-6, 1e-12).q
    return t, z @ system.bodies[0].data.tip_value


def spinup_figures(mode_counts: tuple[int, ...]) -> None:
    print("case 2: Kane-Ryan-Banerjee spin-up")
    runs = spinup_runs(mode_counts)
    fe = RotatingBeamFE(BEAM.length, BEAM.mass_per_length, BEAM.EI, elements=24)
    reference = {}
    for rate in BEAM.rates:
        t_ref, w_ref = fe.spinup_tip_deflection(BEAM.motion(rate), BEAM.t_end, BEAM.dt_out)
        reference[rate] = w_ref
        fine = RotatingBeamFE(BEAM.length, BEAM.mass_per_length, BEAM.EI, elements=48)
        _, w_fine = fine.spinup_tip_deflection(BEAM.motion(rate), BEAM.t_end, BEAM.dt_out,
                                               dt=1e-3)
        peak = np.abs(w_ref).max()
        i = int(np.argmax(np.abs(w_ref)))
        print(f"  FE reference Ω = {rate:g}: peak {w_ref[i]:.4f} m at t = {t_ref[i]:.2f} s, "
              f"self-convergence (2x elements, dt/2) {np.abs(w_fine - w_ref).max() / peak:.1e}")
        for n in mode_counts:
            w = runs[rate, n]["tip"]
            after = runs[rate, n].time > BEAM.spin_time
            print(f"    {n} modes: peak {w.min():.4f} m at t = {t_ref[np.argmin(w)]:.2f} s, "
                  f"max|w − w_FE|/peak {np.abs(w - w_ref).max() / peak:.1e}, "
                  f"residual after T {np.abs(w[after]).max():.4f} m")

    # Figure: tip deflection, flexlink vs FE reference, both rates
    fig, axes = plt.subplots(1, 2, figsize=(11.5, 4.2), sharex=True)
    n_best = max(mode_counts)
    for ax, rate in zip(axes, BEAM.rates):
        result = runs[rate, n_best]
        ax.plot(result.time, result["tip"], color=COLORS[0],
                label=f"flexlink, stiffened, {n_best} modes")
        ax.plot(result.time, reference[rate], "--", color=COLORS[1],
                label="FE + Newmark reference (24 elements)")
        hub = BEAM.motion(rate).evaluate(result.time)[1]
        twin = ax.twinx()
        twin.plot(result.time, hub, ":", color="0.5")
        twin.set_ylabel("hub rate (rad/s)", color="0.4")
        twin.set_ylim(0, 1.6 * rate)
        ax.axvline(BEAM.spin_time, color="0.7", lw=0.8)
        ax.set_title(f"Spin-up to Ω = {rate:g} rad/s in T = {BEAM.spin_time:g} s")
        ax.set_xlabel("time (s)")
        ax.set_ylabel("tip deflection in the rotating frame (m)")
        ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(FIGURES / "spinup_tip_deflection.png", dpi=DPI)
    plt.close(fig)

    # Figure: difference to the reference, mode-count convergence
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for rate, color in zip(BEAM.rates, (COLORS[0], COLORS[1])):
        peak = np.abs(reference[rate]).max()
        for n, ls in zip(mode_counts, ("-", "--", ":", "-.")):
            result = runs[rate, n]
            ax.semilogy(result.time, np.abs(result["tip"] - reference[rate]) / peak, ls,
                        color=color, lw=1, label=f"Ω = {rate:g} rad/s, {n} modes")
    ax.axhline(1e-3, color="k", lw=0.8)
    ax.text(0.3, 1.2e-3, "test tolerance", fontsize=8)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("|w_flexlink − w_FE| / peak |w_FE|")
    ax.set_title("Spin-up: difference to the FE reference")
    ax.set_ylim(1e-8, 1e-1)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(FIGURES / "spinup_error.png", dpi=DPI)
    plt.close(fig)

    # Figure: the paper's model diverges
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    for rate, color in zip(BEAM.rates, (COLORS[0], COLORS[1])):
        try:
            simulate(BEAM.scenario(rate, 4, False, t_end=BEAM.spin_time))
            refused = "simulate() returned"
        except SimulationError as error:
            refused = f"simulate() refused: {str(error)[:70]}…"
        print(f"  paper's model Ω = {rate:g}: {refused}")
        t, w = diverging_tip(rate, BEAM.spin_time)
        beyond = np.argmax(np.abs(w) > BEAM.length)
        print(f"    |w| > L at t = {t[beyond]:.2f} s; hub passes ω₁ at "
              f"t = {BEAM.crossing_time(rate, BEAM.first_frequency):.2f} s")
        ax.semilogy(t, np.abs(w), "--", color=color, label=f"paper's model, Ω = {rate:g} rad/s")
        stiff = runs[rate, n_best]
        at_peak = int(np.argmax(np.abs(stiff["tip"])))
        print(f"    at the stiffened peak (t = {stiff.time[at_peak]:.2f} s) the paper's model "
              f"deflects {w[at_peak] / stiff['tip'][at_peak]:.2f}× as much")
        ax.semilogy(stiff.time, np.abs(stiff["tip"]), color=color,
                    label=f"stiffened, Ω = {rate:g} rad/s")
        ax.axvline(BEAM.crossing_time(rate, BEAM.first_frequency), color=color, lw=0.8, ls=":")
    ax.axhline(BEAM.length, color="k", lw=0.8)
    ax.text(0.3, BEAM.length * 1.4, "link length: simulate() refuses beyond", fontsize=8)
    ax.set_xlim(0, BEAM.t_end)
    ax.set_ylim(1e-4, 1e4)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("|tip deflection| (m)")
    ax.set_title("Spin-up without geometric stiffening diverges (dotted: hub rate = ω₁)")
    ax.legend(fontsize=8, loc="center right")
    fig.tight_layout()
    fig.savefig(FIGURES / "spinup_divergence.png", dpi=DPI)
    plt.close(fig)


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    FIGURES.mkdir(parents=True, exist_ok=True)
    rotating_beam_frequencies()
    spinup_figures((4, 6, 8))
    print(f"figures written to {FIGURES.relative_to(ROOT)}/")


if __name__ == "__main__":
    main()
