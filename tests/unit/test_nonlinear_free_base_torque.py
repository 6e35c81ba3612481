"""The held joint's torque on a free base, nonlinear model: its derivative in the base's
mass. The torque reads accelerations solved from the moved equations; their round-off
over the field's difference step (1e-5 of the mass) showed as 2.5e-5 of the derivative,
so the field's own part of the channels is differenced over a wider, fourth-order stencil
(`nonlinear_sensitivities.WIDE_STEP`)."""

from __future__ import annotations

import tomllib

import numpy as np

import flexlink
from flexlink.scenario.load import scenario_from_dict
from flexlink.simulation.sensitivities import scenario_file
from tests.unit.test_forward_sensitivities import FREE_BASE

FIELD = "base.mass"


def test_the_held_joints_torque_derivative_in_the_base_mass() -> None:
    """Adaptive steps at rtol 1e-10 against the derivative of a run on uniform steps of
    1 ms, itself checked against central differences of same-step runs (the runs on one
    step sequence are smooth in the mass): within 1e-6 of the derivative's peak on the
    torque, the base's attitude and the tip."""
    text = FREE_BASE.replace("geometric_stiffening = true",
                             'geometric_stiffening = true\nmodel = "nonlinear"')
    file = scenario_file(scenario_from_dict(tomllib.loads(text)))
    path, value = file.locate(FIELD).path, float(file.locate(FIELD).value)
    adaptive = flexlink.simulate(file.build({("simulation", "rtol"): 1e-10}), shapes=False,
                                 sensitivities=[FIELD])
    uniform = {("simulation", "step"): 1e-3}
    reference = flexlink.simulate(file.build(uniform), shapes=False, sensitivities=[FIELD])
    h = 1e-4 * value
    up = flexlink.simulate(file.build({**uniform, path: value + h}), shapes=False)
    down = flexlink.simulate(file.build({**uniform, path: value - h}), shapes=False)
    for name in ("joint1_torque", "base_attitude", "array_tip_X"):
        ref = reference.sensitivities.sel(channel=name, field=FIELD).values
        peak = float(np.max(np.abs(ref)))
        assert peak > 0.0
        difference = (up[name] - down[name]) / (2 * h)
        assert np.max(np.abs(ref - difference)) <= 2e-7 * peak, name  # the reference holds
        got = adaptive.sensitivities.sel(channel=name, field=FIELD).values
        assert np.max(np.abs(got - ref)) <= 1e-6 * peak, name
