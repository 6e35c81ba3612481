"""Closed loops with prescribed joints, first-order model: FirstOrderSystem plus the
actuators' generalized forces → the closed-loop Lawson integrator with the sampled
controllers inside (solvers/closed_loop.py) → channels, including the actuator voltages and
the controllers' commands and states (docs/closed_loop.md).

Why this path and not the forward machinery: with prescribed joints the plant is linear in
z, and over a sample interval with held voltages it is the prescribed model with a constant
input. The prescribed Lawson integrator (tabulated coefficients, compiled steps) carries it
unchanged with the voltages appended to its state, so a closed-loop run costs a small
multiple of an open-loop one, far less than on the forward kernel
(benchmarks/closed_loop.py).
"""

from __future__ import annotations

import numpy as np

from ..channels.catalogue import command_name, state_name, voltage_name
from ..channels.modal import modal_reading
from ..dynamics.actuators import actuator_matrix
from ..dynamics.controllers import (
    controller_inputs,
    controller_outputs,
    draw_noise,
    pack_controllers,
    sample_times,
    state_count,
)
from ..dynamics.first_order import FirstOrderSystem
from ..errors import SimulationError, UnstableLoop
from ..model import FunctionController, PointSensor, Scenario
from ..solvers import Accuracy, Solution
from ..solvers.closed_loop import PythonLoop, integrate_closed_loop
from ..solvers.gauss_sampled import sample_grid
from ..solvers.solution import RICHARDSON
from .common import PathRun, Progress
from .prescribed import prescribed_values


def run_closed_loop(scenario: Scenario, t: np.ndarray, on_progress: Progress,
                    with_shapes: bool = True) -> PathRun:
    settings = scenario.settings
    system = FirstOrderSystem(scenario.chain, settings.geometric_stiffening,
                              gravity=settings.gravity)
    system.joint_history(t)
    n, actuators = system.n, scenario.actuators
    B = actuator_matrix(actuators, system.modal)
    if n == 0:
        raise SimulationError("controllers need an elastic link: every link is rigid")

    def rows(times: np.ndarray) -> np.ndarray:
        M, C, K, f = system.matrices(times)
        rhs = np.concatenate([-K, -C, f[:, :, None],
                              np.broadcast_to(B, (times.size, *B.shape))], axis=2)
        return np.linalg.solve(M, rhs)

    controllers = scenario.controllers
    grid = sample_grid(controllers, float(t[-1]), t)
    readings = sensor_rows(scenario, system.modal, [b.slice for b in system.bodies], system.n,
                           "first_order")
    v_open = np.column_stack([np.clip(a.voltage.value(grid), -a.limit, a.limit)
                              for a in actuators]).reshape(grid.size, len(actuators))
    control, python_index = pack_controllers(controllers, actuators, readings, grid,
                                             2 * n + 1, v_open)
    python = _python_loop(scenario, [controllers[i] for i in python_index], readings, grid)
    start = None
    if settings.initial == "equilibrium":  # under gravity and the open-loop voltages at t = 0
        _, _, K, f = system.matrices(grid[:1])
        start = np.linalg.solve(K[0], f[0] + B @ v_open[0])
    try:
        run = integrate_closed_loop(rows, n, len(actuators), system.coefficient_keys,
                                    system.breakpoints(), system.max_frequency, t, grid,
                                    settings.rtol, settings.atol, control, python, on_progress,
                                    start, system.tip_bounds())
    except UnstableLoop as exc:
        raise SimulationError(_unstable_message(scenario, exc, readings, grid)) from None
    out = np.searchsorted(grid, t - 1e-9 * max(1.0, t[-1]))
    states = run.states[out]
    solution = Solution(t, states[:, :n], states[:, n:2 * n], run.acc[out], "lawson",
                        run.stats, accuracy=Accuracy(settings.rtol, run.estimate, RICHARDSON),
                        reach=run.reach)
    try:
        values, shapes, validity = prescribed_values(scenario, system, solution, with_shapes)
    except SimulationError as exc:  # the tips ran away: say it is the loop
        raise SimulationError(f"closed loop unstable: {exc}") from None
    values.update(control_values(scenario, run, out, python_index))
    return PathRun(solution, values, shapes=shapes, metadata={
        "path": "closed_loop", "geometric_stiffening": settings.geometric_stiffening,
        "elastic_coordinates": n, "controllers": len(controllers), **validity})


def sensor_rows(scenario: Scenario, modal: list, coords: list[slice], n: int,
                model: str) -> dict[str, np.ndarray]:
    """Each sensor a controller reads as a row over the elastic coordinates: reading = row · q
    (piezo patches, slopes and strains are linear in q in every model, channels/modal.py; a
    deflection only in the first-order model)."""
    used = {s for c in scenario.controllers for s in controller_inputs(c)}
    out = {}
    for sensor in scenario.sensors:
        if sensor.name not in used:
            continue
        k = sensor.link
        shapes = modal[k].shapes
        reading = modal_reading(sensor, shapes, np.eye(modal[k].n), scenario.chain)
        if reading is None:
            assert isinstance(sensor, PointSensor)
            if sensor.kind != "deflection" or model == "nonlinear":
                raise SimulationError(f"sensor {sensor.name!r} ({sensor.kind}) cannot feed a "
                                      f"controller in the {model.replace('_', '-')} model: its "
                                      "reading is not linear in the elastic coordinates (use a "
                                      "piezo, strain or slope sensor)")
            reading = shapes.evaluate(np.array([sensor.x]), 0)[0]
        row = np.zeros(n)
        row[coords[k]] = reading
        out[sensor.name] = row
    return out


def _python_loop(scenario: Scenario, controllers: list, readings: dict[str, np.ndarray],
                 grid: np.ndarray) -> PythonLoop:
    act = {a.name: j for j, a in enumerate(scenario.actuators)}
    points, rows, noise, outputs = [], [], [], []
    for c in controllers:
        assert isinstance(c, FunctionController)
        times = sample_times(c, grid[-1])
        points.append(np.searchsorted(grid, times - 1e-9 * max(1.0, grid[-1])))
        rows.append(np.array([readings[s] for s in c.inputs]))
        noise.append(draw_noise(c, times.size))
        outputs.append(np.array([act[a] for a in c.outputs], dtype=np.int64))
    return PythonLoop(controllers, points, rows, noise, outputs)


def control_values(scenario: Scenario, run, out: np.ndarray,
                    python_index: list[int]) -> dict[str, np.ndarray]:
    values = {}
    for j, a in enumerate(scenario.actuators):
        values[voltage_name(a.name)] = run.work.v_rec[out, j]
    compiled = 0
    for i, c in enumerate(scenario.controllers):
        outputs = controller_outputs(c)
        if i in python_index:
            commands = run.python_commands[python_index.index(i)][out]
            states = np.zeros((out.size, 0))
        else:
            commands = run.work.held_rec[out, compiled, :len(outputs)]
            states = run.work.x_rec[out, compiled]
            compiled += 1
        for j in range(len(outputs)):
            values[command_name(c.name, j, len(outputs))] = commands[:, j]
        for s in range(state_count(c)):
            values[state_name(c.name, s)] = states[:, s]
    return values


def _unstable_message(scenario: Scenario, exc: UnstableLoop, readings: dict[str, np.ndarray],
                      grid: np.ndarray) -> str:
    """Which controller input grew the most, from what (its peak over the first quarter of
    the run up to the blow-up) to what, and when."""
    n = next(iter(readings.values())).size if readings else 0
    z = exc.states[:, :n]
    quarter = max(1, z.shape[0] // 4)
    text, growth = "the response grows without bound", 0.0
    for name, row in readings.items():
        y = np.nan_to_num(np.abs(z @ row), nan=np.inf)
        early, late = float(y[:quarter].max()), float(y.max())
        if late / max(early, 1e-300) > growth:
            growth = late / max(early, 1e-300)
            text = (f"sensor {name!r} grows from {early:.3g} (peak up to t = "
                    f"{grid[quarter - 1]:.4g} s) to {late:.3g}")
    names = ", ".join(repr(c.name) for c in scenario.controllers)
    return (f"closed loop unstable: {text} at t = {exc.t:.4g} s, where the response or a "
            f"controller state passed its bound (controllers {names}); lower the gain or "
            "retune")
