"""report.html's summary names the run's metadata in words, not by attribute names."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import flexlink
from flexlink.results.report_html import run_page


def test_the_summary_rows_are_readable(tmp_path: Path) -> None:
    paper = flexlink.load_paper_experiment()
    short = dataclasses.replace(paper, settings=dataclasses.replace(paper.settings, t_end=0.3))
    results = flexlink.simulate(short, shapes=False)
    page = run_page(tmp_path, results, "").html()
    heads = re.findall(r"<tr><th>([^<]*)</th>", page.split("</table>")[0])
    assert "integrator" in heads and "geometric stiffening" in heads
    assert "accuracy against the nonlinear model" in heads
    assert not [h for h in heads if "_" in h], heads  # no raw attribute names
