"""Residual vibration of the paper's arm with and without active damping
(examples/active_damping.toml): writes docs/figures/active_damping.png and prints the
amplitudes of link 2's tip vibration 2 s after the move, their ratio and the largest voltage.

    PYTHONPATH=src python scripts/active_damping_figure.py
"""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import numpy as np

from flexlink.scenario import load_scenario
from flexlink.simulation import simulate

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "active_damping.toml"
MOVE_END = 1.5  # s: the manoeuvre of the paper scenario ends here
WINDOW = 0.5  # s: amplitude = max |deflection| over [t, t + WINDOW] (> one period, 0.4 s)


def amplitude(t: np.ndarray, y: np.ndarray, start: float) -> float:
    inside = (t >= start) & (t < start + WINDOW)
    return float(np.abs(y[inside]).max())


def compare() -> dict[str, object]:
    """Both runs and the numbers the example is judged by."""
    scenario = load_scenario(EXAMPLE)
    controlled = simulate(scenario, shapes=False)
    free = simulate(dataclasses.replace(scenario, controllers=()), shapes=False)
    t = np.asarray(controlled.time)
    y_on = np.asarray(controlled["link2_tip_deflection"])
    y_off = np.asarray(free["link2_tip_deflection"])
    volts = np.asarray(controlled["pzt_actuator_voltage"])
    at = MOVE_END + 2.0
    return {"t": t, "on": y_on, "off": y_off, "volts": volts,
            "amplitude_off": amplitude(t, y_off, at), "amplitude_on": amplitude(t, y_on, at),
            "max_voltage": float(np.abs(volts).max()),
            "limit": scenario.actuators[0].limit}


def main() -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    r = compare()
    ratio = r["amplitude_off"] / r["amplitude_on"]
    print(f"link 2 tip amplitude 2 s after the move: {1e3 * r['amplitude_off']:.3f} mm without "
          f"control, {1e3 * r['amplitude_on']:.3f} mm with PPF: {ratio:.1f}x smaller; "
          f"max |V| = {r['max_voltage']:.1f} V (limit {r['limit']:g} V)")
    fig, (ax, av) = plt.subplots(2, 1, figsize=(8, 6), sharex=True,
                                 gridspec_kw={"height_ratios": [2, 1]})
    t = r["t"]
    ax.plot(t, 1e3 * r["off"], lw=0.8, label="without control")
    ax.plot(t, 1e3 * r["on"], lw=0.8, label="PPF on link 2's first mode")
    ax.axvspan(0.5, MOVE_END, color="0.9", label="manoeuvre")
    ax.axvline(MOVE_END + 2.0, color="k", ls=":", lw=0.8)
    ax.set_ylabel("link 2 tip deflection (mm)")
    ax.set_title(f"Residual vibration 2 s after the move: {ratio:.0f}× smaller with PPF")
    ax.legend(loc="upper right", fontsize=8)
    av.plot(t, r["volts"], lw=0.8, color="C1")
    av.axhline(r["limit"], color="k", lw=0.6, ls="--")
    av.axhline(-r["limit"], color="k", lw=0.6, ls="--")
    av.set_ylabel("actuator voltage (V)")
    av.set_xlabel("time (s)")
    fig.tight_layout()
    out = ROOT / "docs" / "figures" / "active_damping.png"
    fig.savefig(out, dpi=120)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
