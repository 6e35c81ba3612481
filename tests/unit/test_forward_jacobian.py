"""The forward rates' Jacobian (dynamics/_forward_jacobian_numba.py, exact along the
elastic coordinates) against central differences of the rates at the stage states of runs:
a torque-driven hub–beam with geometric stiffening, two links behind servos, an elastic
joint behind a servo, a free base, a cart, a slider."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import flexlink
from flexlink.simulation.driven_sensitivities import _jacobians, _model, _rates
from flexlink.simulation.forward import run_forward
from flexlink.solvers.radau_sensitivity import (
    NODES,
    stage_jacobians,
    step_sequence,
    table_rows,
)


@pytest.mark.parametrize("example, t_end", [
    ("examples/paper_servo.toml", 1.2), ("examples/flexible_joint_arm.toml", 0.5),
    ("examples/satellite_slew.toml", 2.0), ("examples/cart_beam.toml", 0.5),
    ("examples/telescoping_arm.toml", 0.5)])
def test_forward_jacobians_match_central_differences(example: str, t_end: float) -> None:
    scenario = flexlink.load_scenario(example)
    scenario = dataclasses.replace(scenario, settings=dataclasses.replace(
        scenario.settings, t_end=t_end))
    t = np.linspace(0.0, t_end, 11)
    records: list = []
    run_forward(scenario, t, None, False, steps=records)
    steps = step_sequence(records)
    model = _model(scenario, t, None)
    Y = (steps.y0[:, None, :] + steps.z).reshape(-1, model.y0.size)
    u = table_rows(model.table, np.repeat(steps.segment, 3),
                   (steps.t[:, None] + steps.h[:, None] * NODES).ravel())
    pick = np.linspace(0, Y.shape[0] - 1, 40).astype(int)
    exact = _jacobians(model)(u[pick], Y[pick])
    central = stage_jacobians(_rates(model), u[pick], Y[pick])
    scale = np.abs(central).max(axis=1, keepdims=True)  # per state, per column
    assert np.all(np.abs(exact - central) <= 1e-6 * np.maximum(scale, 1e-12))
