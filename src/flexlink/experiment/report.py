"""Output folders of ``flexlink compare`` and ``flexlink fit``: figures, metrics (CSV and
JSON), a Markdown report with the figures embedded; written to a hidden sibling folder first
and renamed into place (as `flexlink.results.writers`), so a failure leaves nothing behind.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..options import json_text
from ..results.writers import (
    RESOLVED_NAME,
    atomic_folder,
    resolved_toml,
    write_channels_csv,
    write_results_csv,
)
from .comparison import METRIC_COLUMNS, Comparison, SignalMetrics
from .figures import FigureData, write_figures
from .identification import PARAMETER_COLUMNS, FitResult
from .report_html import write_experiment_report

if TYPE_CHECKING:
    from .figure_worker import FigureWorker


def write_comparison(comparison: Comparison, out_dir: Path, resolved: Mapping[str, Any],
                     overwrite: bool = False, figures: bool = True,
                     figure_worker: FigureWorker | None = None) -> Path:
    """metrics.csv, metrics.json, simulated.csv with simulated_channels.csv (its units),
    scenario.resolved.toml, figures, report.md;
    the figures drawn by ``figure_worker`` where given (`figure_worker.FigureWorker`)."""
    with atomic_folder(out_dir, overwrite) as folder:
        drawing = _common(comparison, folder, resolved, figures, figure_worker)
        lines = [(f"# Comparison: {resolved['simulation']['name']} against "
                 f"{comparison.measurement.source}"), ""]
        lines += _report_body(comparison, figures)
        (folder / "report.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
        drawing()
        write_experiment_report(folder, comparison, resolved)
    return Path(out_dir)


def write_fit(result: FitResult, out_dir: Path, resolved: Mapping[str, Any],
              overwrite: bool = False, figures: bool = True,
              figure_worker: FigureWorker | None = None) -> Path:
    """parameters.csv, fit.json, then everything ``write_comparison`` writes for the fitted,
    calibrated model; scenario.resolved.toml holds the fitted values."""
    with atomic_folder(out_dir, overwrite) as folder:
        drawing = _common(result.comparison, folder, resolved, figures, figure_worker)
        rows = [e.row() for e in result.estimates]
        _write_csv(folder / "parameters.csv", list(PARAMETER_COLUMNS), rows)
        info = {"parameters": rows, "channels": result.channels, "window_s": result.window,
                "cost": result.cost, "rms_normalised_residual": result.rms_residual,
                "simulations": result.simulations, "status": result.status,
                "correlation": result.correlation.tolist(), **result.info}
        (folder / "fit.json").write_text(json_text(info), encoding="utf-8")
        lines = [(f"# Fit: {resolved['simulation']['name']} to "
                 f"{result.comparison.measurement.source}"), "",
                 (f"{len(result.estimates)} parameter(s) from {', '.join(result.channels)} on "
                 f"{result.window[0]:.4g} … {result.window[1]:.4g} s; {result.simulations} "
                 f"simulations; RMS normalised residual {result.rms_residual:.4g}; "
                 f"{result.status}."), ""]
        lines += _fit_warnings(result)
        lines += ["| parameter | initial | start | estimate | 95 % interval | bounds |",
                 "|---|---|---|---|---|---|"]
        for e in result.estimates:
            flag = (" (at bound)" if e.at_bound else "") + (
                "" if e.identifiable else " (not identifiable)")
            unit = f" [{e.unit}]" if e.unit else ""
            lines.append(f"| `{e.path}`{unit} | {e.initial:.5g} | {e.start:.5g} | **{e.value:.5g}**"
                         f"{flag} | {e.ci_low:.5g} … {e.ci_high:.5g} | {e.lower:.3g} … "
                         f"{e.upper:.3g} |")
        lines += ["", ("*start*: after matching the free-vibration frequency and damping "
                  "(docs/experiment.md). Intervals assume the model is right; they are "
                  "widened for correlated residuals but not for model error."), "",
                  "## Fitted model against the measurement", ""]
        lines += _report_body(result.comparison, figures)
        (folder / "report.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
        drawing()
        write_experiment_report(folder, result.comparison, resolved, fit=result)
    return Path(out_dir)


def _fit_warnings(result: FitResult) -> list[str]:
    """Warning lines of the fit report: a budget-stopped optimiser, unidentifiable values."""
    lines = []
    if not result.info.get("converged", True):
        lines.append(f"> **Warning:** the optimiser stopped at its budget of "
                     f"{result.simulations} simulations before converging (scipy: "
                     f"{result.info.get('optimizer_message', '')}); raise max_simulations.")
    for e in result.estimates:
        if not e.identifiable:
            lines.append(f"> **Warning:** `{e.path}` is not identifiable from these data: "
                         f"{e.doubt}.")
    return [*lines, ""] if lines else []


def _common(comparison: Comparison, folder: Path, resolved: Mapping[str, Any],
            figures: bool, figure_worker: FigureWorker | None = None) -> Callable[[], None]:
    """The data files; the figures handed to ``figure_worker`` first if there is one. Returns
    what completes the figures (waiting for the worker, or drawing them here)."""
    data = FigureData.of(comparison) if figures else None
    if data is not None:
        (folder / "figures").mkdir()
        if figure_worker is not None:
            figure_worker.submit(data, folder / "figures")
    rows = [m.row() for m in comparison.metrics]
    _write_csv(folder / "metrics.csv", list(METRIC_COLUMNS), rows)
    meta = {"measurement": comparison.measurement.source,
            "free_vibration_start_s": comparison.free_start,
            "notes": comparison.measurement.notes, "metrics": rows}
    (folder / "metrics.json").write_text(json_text(meta), encoding="utf-8")
    write_results_csv(comparison.results, folder / "simulated.csv")
    # its columns' units, kinds and descriptions, as channels.csv beside a run's results.csv
    write_channels_csv(comparison.results, folder / "simulated_channels.csv")
    (folder / RESOLVED_NAME).write_text(resolved_toml(resolved), encoding="utf-8")

    def drawing() -> None:
        if data is not None and (figure_worker is None or not figure_worker.wait()):
            write_figures(data, folder / "figures")

    return drawing


def _report_body(comparison: Comparison, figures: bool) -> list[str]:
    free = comparison.free_start
    lines = [("| channel | NRMSE | correlation | peak meas. | peak sim. | peak error | "
             "f meas. [Hz] | f sim. [Hz] | f error | ζ meas. | ζ sim. |"),
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for m in comparison.metrics:
        lines.append(f"| {m.name} [{m.unit}] | {m.nrmse:.3g} | {m.correlation:.4f} | "
                     f"{m.peak_measured:.4g} | {m.peak_simulated:.4g} | {_pct(m.peak_error)} | "
                     f"{_num(m.frequency_measured)} | {_num(m.frequency_simulated)} | "
                     f"{_pct(m.frequency_error)} | {_num(m.damping_measured)} | "
                     f"{_num(m.damping_simulated)} |")
    lines += ["", "NRMSE = RMS(sim − meas)/RMS(meas) over the whole run; frequency (damped) "
              "and damping ratio of the dominant component of the free vibration from "
              + (f"t = {free:.4g} s" if free is not None else "— (no free vibration found)")
              + " (docs/experiment.md)."]
    if comparison.measurement.notes:
        lines += ["", "Data repairs:", *(f"- {n}" for n in comparison.measurement.notes)]
    if figures:
        lines += ["", "![measured and simulated signals](figures/overlay.png)"]
        if free is not None:
            lines += ["", "![free-vibration spectra](figures/spectra.png)"]
    return lines


def _write_csv(path: Path, columns: list[str], rows: list[dict[str, Any]]) -> None:
    with path.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns)
        writer.writeheader()
        for row in rows:
            writer.writerow({k: "" if row.get(k) is None else row.get(k) for k in columns})


def _num(value: float | None) -> str:
    return "—" if value is None else f"{value:.4g}"


def _pct(value: float | None) -> str:
    return "—" if value is None or not math.isfinite(value) else f"{100 * value:+.2f} %"


def metrics_table(metrics: list[SignalMetrics]) -> str:
    """A plain-text table for the terminal."""
    lines = [(f"{'channel':<26} {'NRMSE':>7} {'corr':>7} {'f meas':>9} {'f sim':>9} "
             f"{'f err':>8} {'ζ meas':>8} {'ζ sim':>8}")]
    for m in metrics:
        lines.append(f"{m.name:<26} {m.nrmse:7.3f} {m.correlation:7.4f} "
                     f"{_num(m.frequency_measured):>9} {_num(m.frequency_simulated):>9} "
                     f"{_pct(m.frequency_error):>8} {_num(m.damping_measured):>8} "
                     f"{_num(m.damping_simulated):>8}")
    return "\n".join(lines)
