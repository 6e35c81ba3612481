"""Regenerate the figures of docs/control.md (and print the numbers quoted there).

    python scripts/control_figures.py            # into docs/figures/

The paper's arm (built-in scenario, 4 clamped-free modes per link as in the paper, and 10
per link) at rest with its joints locked: frozen-time natural frequencies against β₂, and the
lowest mode shapes at β₂ = 90°; the frequencies of the paper manoeuvre against time. With
Exudyn installed, the geometrically exact FE frequencies at β₂ = 0°, 45°, 90° are marked
(tests/validation/exudyn_modal_reference.py, 150 elements per link, Richardson). ~1 min.
"""

from __future__ import annotations

import dataclasses
import math
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))  # for tests.validation

import flexlink
from flexlink.control import frozen_modes
from flexlink.control.figures import frequency_figure, shapes_figure

OUT = ROOT / "docs" / "figures"
GRID = np.arange(0.0, 180.0 + 1e-9, 5.0)


def _with_modes(scenario: flexlink.Scenario, modes: int) -> flexlink.Scenario:
    links = tuple(dataclasses.replace(link, modes=modes) for link in scenario.chain.links)
    return dataclasses.replace(scenario, chain=dataclasses.replace(scenario.chain, links=links))


def main() -> None:
    OUT.mkdir(parents=True, exist_ok=True)
    paper = flexlink.load_paper_experiment()
    four = frozen_modes(paper, angles={"joint2": GRID}, count=4)
    ten = frozen_modes(_with_modes(paper, 10), angles={"joint2": GRID}, count=4)
    fe = _fe_points()
    fig, axes = plt.subplots(2, 2, figsize=(9, 6), sharex=True, layout="constrained")
    for j, ax in enumerate(axes.flat):
        ax.plot(GRID, four.frequency_hz[:, j], label="4 modes per link (the paper)")
        ax.plot(GRID, ten.frequency_hz[:, j], "--", label="10 modes per link")
        if fe is not None:
            ax.plot(fe[0], fe[1][:, j], "ko", mfc="none", label="geometrically exact FE")
        ax.set_title(f"mode {j + 1}")
        ax.set_ylabel("frequency (Hz)")
        ax.grid(alpha=0.3)
    for ax in axes[1]:
        ax.set_xlabel("β₂ (deg), β₁ = 0, joints locked")
    axes[0, 0].legend(fontsize="small")
    fig.suptitle("Paper arm at rest: natural frequencies against β₂")
    fig.savefig(OUT / "control_paper_arm_frequencies_beta2.png", dpi=110)
    plt.close(fig)
    index = int(np.argmin(np.abs(GRID - 90.0)))
    shapes_figure(ten, OUT / "control_paper_arm_shapes.png", index=index, count=4)
    run = frozen_modes(paper, times=np.linspace(0.0, 2.0, 81), count=4)
    frequency_figure(run, OUT / "control_paper_manoeuvre_frequencies.png", count=4)
    for name, modes in (("4 modes", four), ("10 modes", ten)):
        lo, hi = modes.frequency_hz.min(axis=0), modes.frequency_hz.max(axis=0)
        print(name, "f range over beta2 (Hz):",
              ", ".join(f"{a:.3f}–{b:.3f}" for a, b in zip(lo, hi)))
    if fe is not None:
        for beta, row in zip(fe[0], fe[1]):
            i = int(np.argmin(np.abs(GRID - beta)))
            print(f"beta2 = {beta:g}: FE {np.round(row, 4)}, flexlink (10 modes) "
                  f"{np.round(ten.frequency_hz[i], 4)}, max rel. diff "
                  f"{np.abs(ten.frequency_hz[i] / row - 1).max():.1e}")


def _fe_points() -> tuple[list[float], np.ndarray] | None:
    try:
        import exudyn  # noqa: F401
    except ImportError:
        return None
    from tests.helpers import paper_links
    from tests.validation.exudyn_modal_reference import locked_chain_frequencies

    links = paper_links(modes=10, damping=False)
    betas = [0.0, 45.0, 90.0]
    rows = []
    for beta in betas:
        coarse, fine = (locked_chain_frequencies(links, [0.0, math.radians(beta)], n, 4)
                        for n in (75, 150))
        rows.append(fine + (fine - coarse) / 3)
    return betas, np.array(rows)


if __name__ == "__main__":
    main()
