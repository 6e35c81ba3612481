"""The forked worker of ``flexlink fit`` and ``flexlink compare`` draws the same figures as
the process itself, and where it cannot, the caller is told to draw them."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

needs_fork = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="the figure worker forks on Linux only")

# In a fresh interpreter: the suite's own process runs threads (the worker is then not forked).
_CHECK = """
import os, signal, sys
from pathlib import Path
sys.path[:0] = {paths!r}
import numpy as np
from flexlink.experiment import figures
from flexlink.experiment.figure_worker import FigureWorker

t = np.arange(2001) * 0.002
measured = {{"pzt": np.exp(-0.3 * t) * np.sin(2 * np.pi * 2.5 * t),
            "acc": 3 * np.exp(-1.0 * t) * np.sin(2 * np.pi * 5 * t) + 0.01}}
simulated = {{k: 0.97 * v for k, v in measured.items()}}
data = figures.FigureData(names=["pzt", "acc"], units={{"pzt": "V", "acc": "m/s^2"}}, time=t,
                          measured=measured, simulated=simulated, free_start=1.2,
                          frequencies={{"pzt": (2.5, 2.49), "acc": (5.0, None)}})
tmp = Path({tmp!r})
for name in ("here", "worker", "half", "dead"):
    (tmp / name).mkdir()
figures.write_figures(data, tmp / "here")
names = sorted(p.name for p in (tmp / "here").iterdir())
assert names == ["overlay.png", "spectra.png"], names
worker = FigureWorker.start()
assert worker is not None, "not forked"
worker.submit(data, tmp / "worker")
assert worker.wait(), "the worker did not draw"
worker.close()
for name in names:
    assert (tmp / "worker" / name).read_bytes() == (tmp / "here" / name).read_bytes(), name
# the partner fails: the worker's child draws its figure too
draw, parent = figures.write_figures, os.getpid()

def failing_in_the_grandchild(data, folder, stems=None):
    if os.getppid() != parent:
        raise RuntimeError("grandchild fails")
    return draw(data, folder, stems)

figures.write_figures = failing_in_the_grandchild
half = FigureWorker.start()
figures.write_figures = draw
half.submit(data, tmp / "half")
assert half.wait(), "the worker did not draw"
half.close()
for name in names:
    assert (tmp / "half" / name).read_bytes() == (tmp / "here" / name).read_bytes(), name
dead = FigureWorker.start()
os.kill(dead._pid, signal.SIGKILL)
dead.submit(data, tmp / "dead")
assert not dead.wait(), "a dead worker reported figures"
print("ok")
"""


@needs_fork
def test_worker_draws_the_figures_byte_for_byte_and_reports_failure(tmp_path: Path) -> None:
    root = Path(__file__).resolve().parents[2]
    code = _CHECK.format(paths=[str(root), str(root / "src")], tmp=str(tmp_path))
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, check=False)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr[-2000:]
