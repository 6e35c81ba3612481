"""examples/gravity_release.toml: a flexible arm released level on a free pin swings down
through the vertical to nearly the other level (light modal damping, rigid limit: exactly
180°), bent by its weight as it goes."""

from __future__ import annotations

from pathlib import Path

import numpy as np

import flexlink

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "gravity_release.toml"


def test_the_released_arm_swings_through_the_vertical() -> None:
    results = flexlink.simulate(flexlink.load_scenario(EXAMPLE))
    angle = np.rad2deg(results["joint1_angle"])
    assert angle[0] == 0.0 and -180.0 < angle.min() < -170.0
    assert 0 < np.argmax(angle < -90.0) < np.argmin(angle)  # through the vertical first
    deflection = np.abs(results["tip_deflection"])
    assert 1e-4 < deflection.max() < 0.05 * 0.8  # bent, well inside first-order validity
    assert np.isfinite(results.to_pandas().to_numpy()).all()
