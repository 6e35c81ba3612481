"""Sensitivities on the forward path (simulation/driven_sensitivities.py): a torque-driven
hub–beam and a free base against converged central differences of tight-tolerance runs,
fields of different kinds (stiffness, mass, drive torque, hub inertia, sensor position,
a base's initial rate: through the initial state and the momentum projection)."""

from __future__ import annotations

import tomllib

import numpy as np
import pytest

import flexlink
from flexlink.scenario.load import scenario_from_dict
from flexlink.simulation.sensitivities import SensitivityError, scenario_file

HUB_BEAM = """
[simulation]
t_end = 0.6
dt_out = 0.01
geometric_stiffening = true

[[links]]
name = "beam"
length = 1.0
mass_per_length = 1.0
EI = 10.0
tip_mass = 0.1
damping_ratio = 0.01
modes = 2

[[joints]]
drive = "torque"
motor_inertia = 1.0
torque = [{ profile = "bang_bang", amplitude = 2.0, start = 0.0, duration = 0.4 }]

[[sensors]]
name = "root_strain"
kind = "strain"
link = "beam"
x = 0.1
thickness = 0.02
"""

FREE_BASE = """
[simulation]
t_end = 1.0
dt_out = 0.01
geometric_stiffening = true

[base]
type = "free"
mass = 10.0
inertia = 2.0
rate_deg_s = 5.0

[[base.loads]]
moment = [{ profile = "bang_bang", amplitude = 1.0, start = 0.0, duration = 2.0 }]

[[links]]
name = "array"
length = 1.5
mass_per_length = 2.0
EI = 50.0
modes = 2

[[joints]]
base_point = [0.3, 0.0]
motion = [{ profile = "hold", angle_deg = 0.0 }]
"""


def _differences(file, text: str) -> dict[str, np.ndarray]:
    """Central differences of runs at rtol 1e-12, δ = 1e-3 and 2e-3 of the value,
    Richardson."""
    target = file.locate(text)
    value = float(target.value)
    out = []
    for rel in (2e-3, 1e-3):
        h = rel * abs(value)
        runs = [flexlink.simulate(file.build({target.path: value + s * h,
                                              ("simulation", "rtol"): 1e-12}), shapes=False)
                for s in (1, -1)]
        out.append({name: (runs[0][name] - runs[1][name]) / (2 * h) for name in runs[0].names})
    return {name: (4 * out[1][name] - out[0][name]) / 3 for name in out[0]}


@pytest.mark.parametrize("text, fields", [
    (HUB_BEAM, ["links[0].EI", "joints[0].torque[0].amplitude", "joints[0].motor_inertia",
                "sensors[0].x"]),
    (FREE_BASE, ["base.inertia", "base.rate_deg_s", "links[0].mass_per_length"]),
])
def test_forward_sensitivities_match_converged_differences(text: str, fields: list[str]
                                                           ) -> None:
    """Every channel within 2e-5 of its peak derivative (measured: 1e-10 … 6e-7; the
    differences' own noise is of that size)."""
    file = scenario_file(scenario_from_dict(tomllib.loads(text)))
    results = flexlink.simulate(file.build({("simulation", "rtol"): 1e-10}), shapes=False,
                                sensitivities=fields)
    for field in fields:
        value = abs(float(file.locate(field).value))
        largest = max(np.abs(results[name]).max() for name in results.names)
        for channel, reference in _differences(file, field).items():
            peak = np.abs(reference).max()
            if np.abs(results[channel]).max() <= 1e-9 * largest:  # zero to round-off
                assert np.abs(results.sensitivity(channel, field).values).max() * value \
                    <= 1e-9 * largest
                continue
            s = results.sensitivity(channel, field).values
            # a field that does not move the channel: its derivative is zero to round-off
            floor = 1e-3 * np.abs(results[channel]).max() / value
            assert np.abs(s - reference).max() < 2e-5 * max(peak, floor), (field, channel)


def test_a_field_that_moves_an_input_breakpoint_is_refused() -> None:
    file = scenario_file(scenario_from_dict(tomllib.loads(HUB_BEAM)))
    with pytest.raises(SensitivityError, match="duration"):
        flexlink.simulate(file.build(), sensitivities=["joints[0].torque[0].duration"])


def _converged(file, text: str, overrides: dict) -> tuple[dict, dict]:
    """Central differences of runs at rtol 1e-12, δ = 4e-3, 2e-3, 1e-3 of the value, the
    two Richardson estimates' mean per channel and their disagreement (max over time)."""
    target = file.locate(text)
    value = float(target.value)
    D = []
    for rel in (4e-3, 2e-3, 1e-3):
        h = rel * abs(value)
        runs = [flexlink.simulate(file.build({**overrides, target.path: value + s * h,
                                              ("simulation", "rtol"): 1e-12}), shapes=False)
                for s in (1, -1)]
        D.append({name: (runs[0][name] - runs[1][name]) / (2 * h) for name in runs[0].names})
    mean, spread = {}, {}
    for name in D[0]:
        R = [(4 * D[i + 1][name] - D[i][name]) / 3 for i in range(2)]
        mean[name] = 0.5 * (R[0] + R[1])
        spread[name] = np.abs(R[1] - R[0]).max()
    return mean, spread


@pytest.mark.parametrize("field", ["links[1].EI", "joints[2].base_point[0]"])
def test_closed_loop_sensitivities_match_converged_differences(field: str) -> None:
    """The four-bar (examples/four_bar.toml, first 0.3 s): every channel within 1e-6 of its
    peak derivative where the differences agree among themselves to better than that, and
    within twice their own spread elsewhere. The coupler's bending stiffness barely moves
    the forces (its derivative is 5e-5 of a force's scale: the differences' spread there
    is 5e-5 of the peak); with second-order stage Jacobians the closure force was 1e-3 off.
    The rocker's pivot moves the closure itself (the dependent joints, the closed start)."""
    from pathlib import Path

    path = Path(__file__).parents[2] / "examples" / "four_bar.toml"
    file = scenario_file(flexlink.load_scenario(path))
    overrides = {("simulation", "t_end"): 0.3}
    results = flexlink.simulate(file.build({**overrides, ("simulation", "rtol"): 1e-10}),
                                shapes=False, sensitivities=[field])
    value = abs(float(file.locate(field).value))
    largest = max(np.abs(results[name]).max() for name in results.names)
    reference, spread = _converged(file, field, overrides)
    converged = 0
    for channel, d in reference.items():
        if np.abs(results[channel]).max() <= 1e-9 * largest:  # a free pin's torque: zero
            continue
        s = results.sensitivity(channel, field).values
        # a field that barely moves the channel: its derivative is zero to round-off
        peak = max(np.abs(d).max(), 1e-3 * np.abs(results[channel]).max() / value)
        allowed = max(1e-6 * peak, 2.0 * spread[channel])
        converged += spread[channel] < 1e-6 * peak
        assert np.abs(s - d).max() < allowed, (channel, np.abs(s - d).max() / peak,
                                               spread[channel] / peak)
    assert converged >= 3  # the check is at 1e-6 on several channels, forces among them


PPF = HUB_BEAM + """
[[actuators]]
name = "pzt"
kind = "piezo"
link = "beam"
x_start = 0.045
x_end = 0.095
width = 0.025
thickness = 0.0005
E_p = 30.33e9
d31 = 265e-12

[[controllers]]
name = "ppf"
kind = "ppf"
sensor = "root_strain"
actuator = "pzt"
frequency_hz = 5.0
damping = 0.3
gain = 3e6
sample_rate = 200.0
"""


def test_sensitivities_through_sampled_controllers_match_converged_differences() -> None:
    """PPF on the torque-driven hub–beam, sampled at 200 Hz: the held voltages'
    derivative at each sample (the controller's update of the moved model at the state
    and filter state moved along their sensitivities) carried through the tangent. Every
    channel (strain, joint, tip, voltage, the filter's states) within 1e-6 of its peak
    derivative for the filter frequency, the PPF gain and the bending stiffness (measured
    5e-7 at most, the tip's X on the frequency; the differences' spread 1e-8 there)."""
    file = scenario_file(scenario_from_dict(tomllib.loads(PPF)))
    fields = ["controllers[0].frequency_hz", "controllers[0].gain", "links[0].EI"]
    results = flexlink.simulate(file.build({("simulation", "rtol"): 1e-10}), shapes=False,
                                sensitivities=fields)
    assert np.abs(results["pzt_voltage"]).max() > 1e3  # the loop acts
    for field in fields:
        value = abs(float(file.locate(field).value))
        reference, spread = _converged(file, field, {})
        for channel, d in reference.items():
            s = results.sensitivity(channel, field).values
            peak = max(np.abs(d).max(), 1e-3 * np.abs(results[channel]).max() / value)
            assert spread[channel] < 1e-6 * peak, (field, channel)  # the reference converged
            assert np.abs(s - d).max() < 1e-6 * peak, (field, channel,
                                                        np.abs(s - d).max() / peak)


def test_quantised_controllers_are_refused_naming_them() -> None:
    file = scenario_file(scenario_from_dict(tomllib.loads(
        PPF + "quantization = [1e-6]\n")))
    with pytest.raises(SensitivityError, match=r"controllers\[0\] \('ppf'\) with quantization"):
        flexlink.simulate(file.build(), sensitivities=["links[0].EI"])
