"""report.html of a compare or fit folder: the metrics (and the estimates with their 95 %
intervals) that report.md lists, the measured and simulated signals overlaid and zoomable,
the figures and the scenario, on one self-contained page (`flexlink.results.report_html`)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from ..results.folder import REPORT_NAME
from ..results.plotting import display_scale
from ..results.report_html import ReportPage, Trace
from ..results.writers import resolved_toml
from .comparison import Comparison
from .identification import FitResult


def write_experiment_report(folder: Path, comparison: Comparison, resolved: Mapping[str, Any],
                            fit: FitResult | None = None) -> Path:
    """Write ``folder``/report.html for a comparison, or for a fit when ``fit`` is given."""
    name = resolved["simulation"]["name"]
    source = comparison.measurement.source
    page = ReportPage(f"Fit: {name} to {source}" if fit else f"Comparison: {name} against "
                                                            f"{source}")
    t = comparison.results.time
    page.summary = {"scenario": name, "measurement": source,
                    "time": f"{t[0]:g} … {t[-1]:g} s, {t.size} samples",
                    "free vibration from [s]": comparison.free_start}
    if fit is not None:
        page.summary.update({"fitted channels": ", ".join(fit.channels),
                             "window [s]": f"{fit.window[0]:.4g} … {fit.window[1]:.4g}",
                             "simulations": fit.simulations,
                             "RMS normalised residual": fit.rms_residual, "status": fit.status})
        page.add_table("Estimates", [{
            "parameter": e.path, "unit": e.unit, "initial": e.initial, "start": e.start, "estimate": e.value,
            "95 % interval": f"{e.ci_low:.5g} … {e.ci_high:.5g}",
            "bounds": f"{e.lower:.3g} … {e.upper:.3g}", "at bound": "yes" if e.at_bound else ""}
            for e in fit.estimates], note="start: after matching the free-vibration frequency "
            "and damping. Intervals assume the model is right; they are widened for correlated "
            "residuals but not for model error (docs/experiment.md).")
    page.add_table("Metrics", [m.row() for m in comparison.metrics],
                   note="nrmse = RMS(sim − meas)/RMS(meas) over the whole run; peaks in the "
                        "channel's unit; frequency (damped, Hz) and damping ratio of the "
                        "dominant component of the free vibration; errors (sim − meas)/meas "
                        "in percent.")
    traces = []
    for m in comparison.metrics:
        factor, unit = display_scale(comparison.results.channels[m.name].unit)
        traces.append(Trace(m.name, unit, t, {
            "measured": comparison.measured[m.name] * factor,
            "simulated": comparison.results[m.name] * factor}))
    page.add_traces("Measured and simulated", traces)
    page.add_images("Figures", sorted((folder / "figures").glob("*.png")))
    if comparison.measurement.notes:
        page.add_table("Data repairs", [{"note": n} for n in comparison.measurement.notes])
    page.add_text("Scenario (scenario.resolved.toml)", resolved_toml(resolved))
    return page.write(folder / REPORT_NAME)
