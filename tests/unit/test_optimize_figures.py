"""``flexlink optimize`` draws its figures in the forked figure worker of `flexlink fit`
(`flexlink.experiment.figure_worker`): the folder it writes is complete and the same as when
the command draws them itself, and a failure after the job was handed over leaves nothing."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from .test_optimize import ARM_TOML

needs_fork = pytest.mark.skipif(not sys.platform.startswith("linux"),
                                reason="the figure worker forks on Linux only")

# In a fresh interpreter: the suite's own process runs threads (the worker is then not forked).
_CHECK = """
import json, os, sys
from pathlib import Path
sys.path[:0] = {paths!r}
from flexlink.cli import main
from flexlink.experiment.figure_worker import FigureWorker
from flexlink.scenario import toml_writer
from flexlink.shaping.figures import OptimizeFigures

tmp = Path({tmp!r})
arm = tmp / "arm.toml"
arm.write_text({arm!r})
options = ["--workers", "1", "--harmonics", "1", "--max-iterations", "1",
           "--stiffening", "scenario"]
start, write = FigureWorker.start.__func__, OptimizeFigures.write
started = []

def refuse_to_draw_here(self, folder, stems=None):
    raise AssertionError("drawn in the command's process")

def start_then_refuse(cls, *args, **kwargs):
    worker = start(cls, *args, **kwargs)
    started.append(worker)
    OptimizeFigures.write = refuse_to_draw_here  # the forked child keeps the real one
    return worker

def command(name):
    return main(["optimize", str(arm), "-o", str(tmp / name), *options])

# the worker draws: this process could not
FigureWorker.start = classmethod(start_then_refuse)
assert command("worker") == 0
assert started and started[0] is not None, "not forked"
assert started[0]._pid == 0, "the worker was not reaped"
OptimizeFigures.write = write
# the same command drawing in its own process
FigureWorker.start = classmethod(lambda cls, *a, **k: None)
assert command("here") == 0
files = sorted(p.name for p in (tmp / "here").iterdir())
assert files == ["optimized.toml", "residual.png", "robustness.png", "scenario.resolved.toml",
                 "summary.json", "trajectory.csv"], files
assert sorted(p.name for p in (tmp / "worker").iterdir()) == files
for name in ("residual.png", "robustness.png", "optimized.toml", "trajectory.csv"):
    assert (tmp / "worker" / name).read_bytes() == (tmp / "here" / name).read_bytes(), name
summaries = [json.loads((tmp / k / "summary.json").read_text()) for k in ("worker", "here")]
for s in summaries:
    s["optimiser"].pop("wall_time_s")
assert summaries[0] == summaries[1]
assert "robustness" in summaries[0]
# a failure after the job was handed over: nothing left behind, the worker reaped
started.clear()
FigureWorker.start = classmethod(start_then_refuse)
OptimizeFigures.write = write

def fail(data):
    assert started[0]._submitted, "the figures were not handed over first"
    raise OSError("disk full")

toml_writer.dump_toml = fail
assert command("failed") == 2
assert started[0]._pid == 0, "the worker was not reaped"
left = sorted(p.name for p in tmp.iterdir())
assert left == ["arm.toml", "here", "worker"], left
try:
    os.waitpid(-1, os.WNOHANG)
    raise AssertionError("a child process is left")
except ChildProcessError:
    pass
print("ok")
"""


@needs_fork
def test_optimize_figures_come_from_the_worker_and_failures_leave_nothing(tmp_path: Path
                                                                          ) -> None:
    root = Path(__file__).resolve().parents[2]
    code = _CHECK.format(paths=[str(root), str(root / "src")], tmp=str(tmp_path),
                         arm=ARM_TOML)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=600, check=False)
    assert done.returncode == 0 and done.stdout.strip().endswith("ok"), done.stderr[-3000:]


def test_the_residual_figure_keeps_its_axis_label_and_says_what_is_drawn() -> None:
    """Tick labels of −150 mm pushed the axis label out of the figure's left edge; the grey
    band (the move) and the dotted lines (± the residual peak) were not explained."""
    import numpy as np
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from flexlink.shaping.figures import trace_figure

    t = np.linspace(0.0, 3.5, 200)
    traces = {label: (t, -0.15 * np.sin(3.0 * t), 0.0184)
              for label in ("cycloidal", "shaped (ZVD)", "optimised")}
    fig = trace_figure(traces, 0.5, 1.5, "arm: residual vibration")
    canvas = FigureCanvasAgg(fig)
    canvas.draw()  # places the axis label beside the tick labels
    label = fig.axes[0].yaxis.label.get_window_extent(canvas.get_renderer())
    assert label.x0 >= 0.0
    assert "grey: the move" in fig.texts[0].get_text()  # the suptitle
