"""The names of the files in a run folder (written by `writers`, read by `reading`, shown
by `report_html`)."""

from __future__ import annotations

from pathlib import Path

RESOLVED_NAME = "scenario.resolved.toml"
RESULTS_CSV = "results.csv"
CHANNELS_CSV = "channels.csv"
RESULTS_NC = "results.nc"
RESULTS_MAT = "results.mat"
ANIMATION_GIF = "animation.gif"
ANIMATION_MP4 = "animation.mp4"  # the same animation as a video (`flexlink animate -o`)
REPORT_NAME = "report.html"
FIGURES_DIR = "figures"

# Every name a flexlink command writes at the top of its output folder (run, compare, fit,
# linearize, modes, optimize; figures/ holds only PNG pictures): --overwrite replaces only a
# folder holding nothing else, so it never deletes a file the user put there.
WRITTEN_NAMES = frozenset({
    RESOLVED_NAME, RESULTS_CSV, CHANNELS_CSV, RESULTS_NC, RESULTS_MAT, ANIMATION_GIF,
    ANIMATION_MP4,
    REPORT_NAME,
    "report.md", "metrics.csv", "metrics.json", "simulated.csv", "simulated_channels.csv",
    "parameters.csv", "fit.json",
    "plant.npz", "plant.mat", "bode.png", "modes.csv", "frequencies.csv", "modes.npz",
    "frequencies.png", "shapes.png",
    "optimized.toml", "trajectory.csv", "summary.json", "residual.png", "robustness.png",
})

# what file browsers leave in a folder they show: replaced with it, as nobody's work
BROWSER_FILES = frozenset({".DS_Store", "Thumbs.db", "desktop.ini"})


def foreign_entries(folder: Path) -> list[str]:
    """The entries of ``folder`` (relative paths, sorted) that no flexlink command writes."""
    foreign = []
    for entry in sorted(folder.iterdir()):
        if entry.name == FIGURES_DIR and entry.is_dir() and not entry.is_symlink():
            foreign += [f"{FIGURES_DIR}/{p.name}" for p in sorted(entry.iterdir())
                        if not _ours(p, p.suffix == ".png")]
        elif not _ours(entry, entry.name in WRITTEN_NAMES):
            foreign.append(entry.name)
    return foreign


def _ours(entry: Path, written: bool) -> bool:
    """``entry`` is a plain file flexlink wrote (``written``: its name is one) or a file
    browser's."""
    return (written or entry.name in BROWSER_FILES) and entry.is_file() and not entry.is_symlink()
