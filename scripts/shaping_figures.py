"""The figures of docs/shaping.md, written to docs/figures/:

* shaping_shaper_curves.png — residual vibration V of the ZV, ZVD and EI shapers against the
  frequency ratio (the textbook curves, `flexlink.motion.shapers.residual_vibration`);
* shaping_residual.png — link-2 tip deflection of the paper arm's 90° / 80° move in 1.2 s:
  cycloidal, ZVD-shaped (same total duration) and optimised (the default design, robust to
  ±10 %), first-order model;
* shaping_robustness.png — residual peak against the plant's frequency error, relative to the
  cycloid's, with the optimised move designed for the nominal plant only (--robust 0) and
  robust to ±10 % (the default).

    python scripts/shaping_figures.py          # a few minutes (two optimisations)
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from flexlink.motion.shapers import design, residual_vibration
from flexlink.scenario import load_scenario, paper_experiment_path
from flexlink.shaping import figures, optimize_move
from flexlink.shaping.compare import (
    cycloidal_version,
    residuals,
    run_residual,
    shaped_version,
)
from flexlink.shaping.paper import DURATION_S, LIMITS, SEED

OUT = ROOT / "docs" / "figures"


def shaper_curves() -> None:
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.5, 3.4), layout="constrained")
    ax = fig.subplots()
    ratio = np.linspace(0.5, 1.5, 501)
    for kind, colour in (("zv", "#1f77b4"), ("zvd", "#d62728"), ("ei", "#2ca02c")):
        for zeta, style in ((0.0, "-"), (0.05, ":")):
            v = residual_vibration(design(kind, [1.0], zeta), ratio, zeta)
            ax.plot(ratio, 100 * v, style, color=colour,
                    label=f"{kind.upper()}, ζ = {zeta:g}")
    ax.axhline(5.0, color="0.5", lw=0.6)
    ax.set_xlabel("actual / design frequency")
    ax.set_ylabel("residual vibration V (%)")
    ax.set_ylim(0, 100)
    ax.grid(True, lw=0.3)
    ax.legend(fontsize=7, ncol=2)
    figures.save(fig, OUT / "shaping_shaper_curves.png")


def paper_arm() -> None:
    scenario = load_scenario(paper_experiment_path())
    nominal = optimize_move(scenario, DURATION_S, LIMITS, seed=SEED, robust=0.0)
    robust = optimize_move(scenario, DURATION_S, LIMITS, seed=SEED)  # the default, ±10 %
    versions = {"cycloidal": cycloidal_version(robust.scenario, robust.moves),
                "shaped (ZVD)": shaped_version(robust.scenario, robust.moves, "zvd")[0],
                "optimised (default, robust ±10 %)": robust.scenario}
    runs = {k: run_residual(v, robust.move_end) for k, v in versions.items()}
    start = min(m.start for m in robust.moves)
    figures.save(figures.residual_figure(runs, start, robust.move_end,
                                         "paper arm, 90° / 80° in 1.2 s (first-order model)"),
                 OUT / "shaping_residual.png")
    errors = np.arange(-20.0, 20.1, 2.5) / 100.0
    curves = residuals({**versions, "optimised, nominal only (--robust 0)": nominal.scenario},
                       robust.move_end, errors)
    figures.save(figures.robustness_figure(errors, curves, "cycloidal",
                                           title="paper arm: residual against frequency error"),
                 OUT / "shaping_robustness.png")
    for label, values in curves.items():
        print(label, " ".join(f"{1e3 * v:.3g}" for v in values), "mm")


if __name__ == "__main__":
    shaper_curves()
    paper_arm()
