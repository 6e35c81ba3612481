"""examples/active_damping.toml: PPF on link 2 of the paper's arm cuts the residual vibration
of link 2's tip 2 s after the move at least 5× against the uncontrolled run, the actuator
never seeing more than its limit."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

SCRIPT = Path(__file__).resolve().parents[2] / "scripts" / "active_damping_figure.py"


@pytest.mark.slow
def test_active_damping_example() -> None:
    spec = importlib.util.spec_from_file_location("active_damping_figure", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    r = module.compare()
    assert r["amplitude_off"] >= 5 * r["amplitude_on"]
    assert r["max_voltage"] <= r["limit"] * (1 + 1e-12)
    assert np.all(np.isfinite(r["on"]))
