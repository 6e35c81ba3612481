"""[[actuators]] and [[controllers]] in scenarios: bad input refused naming the field;
the discretised PPF peaks at its frequency; a Python callable equals the compiled loop."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from flexlink.dynamics.controllers import discretize
from flexlink.model import FunctionController
from flexlink.scenario import ScenarioError, scenario_from_dict
from flexlink.simulation import simulate
from tests.validation.test_ppf import beam, first_mode, ppf


def _error(d: dict) -> str:
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    return str(info.value)


@pytest.mark.parametrize(("change", "field"), [
    (lambda d: d["controllers"][0].update(sensor="nope"), "controllers[0].sensor"),
    (lambda d: d["controllers"][0].update(actuator="nope"), "controllers[0].actuator"),
    (lambda d: d["controllers"][0].update(sample_rate=0.0), "controllers[0].sample_rate"),
    (lambda d: d["controllers"][0].update(gain=-1.0), "controllers[0].gain"),
    (lambda d: d["controllers"][0].update(sample_rate=3.0), "controllers[0].sample_rate"),
    (lambda d: d["controllers"][0].update(noise_std=[1.0, 2.0]), "controllers[0].noise_std"),
    (lambda d: d["actuators"][0].update(x_start=0.5), "actuators[0].x_start"),
    (lambda d: d["actuators"][0].update(collocated_with="nope"),
     "actuators[0].collocated_with"),
    (lambda d: d["actuators"][0].update(limit=0.0), "actuators[0].limit"),
])
def test_bad_input_names_the_field(change, field: str) -> None:
    d = beam(1, [ppf(2.0, 1.0)])
    change(d)
    assert field in _error(d)


def test_lti_matrix_sizes_are_checked() -> None:
    lti = {"name": "k", "kind": "lti", "inputs": ["pzt"], "outputs": ["patch"],
           "A": [[0.5, 0.0], [0.0, 0.5]], "B": [[1.0]], "C": [[1.0, 0.0]],
           "sample_rate": 100.0}
    text = _error(beam(1, [lti]))
    assert "controllers[0].B: expected 2 × 1" in text
    lti["inputs"] = ["pzt", "ghost"]
    assert "controllers[0].inputs[1]: unknown sensor 'ghost'" in _error(beam(1, [lti]))


def test_ppf_filter_peaks_at_its_frequency() -> None:
    scenario = scenario_from_dict(beam(1, [ppf(50.0, 1.0)]))
    A, B, C, D = discretize(dataclasses.replace(scenario.controllers[0], damping=0.01))
    T = 1.0 / scenario.controllers[0].sample_rate
    w = 2 * np.pi * np.linspace(40, 60, 2001)
    z = np.exp(1j * w * T)
    H = np.array([(C @ np.linalg.solve(zi * np.eye(2) - A, B) + D)[0, 0] for zi in z])
    assert w[np.argmax(np.abs(H))] / (2 * np.pi) == pytest.approx(50.0, abs=0.02)


def test_python_callable_equals_the_compiled_loop() -> None:
    _, _, k, b, s = first_mode(scenario_from_dict(beam(1, [ppf(2.5, 1.0)])))
    scenario = scenario_from_dict(beam(1, [ppf(2.5, 0.3 * k / (b * s))], t_end=0.5))
    A, B, C, D = discretize(scenario.controllers[0])

    class Law:  # a stateful callable object: deep-copied afresh for every integration pass
        def __init__(self) -> None:
            self.x = np.zeros(2)

        def __call__(self, t: float, y: np.ndarray) -> np.ndarray:
            v = C @ self.x + D @ y
            self.x = A @ self.x + B @ y
            return v

    c = scenario.controllers[0]
    python = dataclasses.replace(scenario, controllers=(FunctionController(
        "ppf", (c.sensor,), (c.actuator,), Law(), c.sample_rate),))
    a, b = simulate(scenario, shapes=False), simulate(python, shapes=False)
    assert np.allclose(a["pzt"], b["pzt"], rtol=0, atol=1e-9 * np.abs(a["pzt"]).max())
    assert np.allclose(a["ppf_command"], b["ppf_command"], atol=1e-9)
