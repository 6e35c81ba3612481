"""The plant of the geometrically nonlinear model (docs/nonlinear.md) about a static deflected
equilibrium: prescribed joints held at a configuration, the piezo actuators at their t = 0
voltages V₀ (their ``voltage`` histories), in the scenario's gravity field.

At rest the inertia forces vanish for any q, so without gravity the equilibrium is
K q₀ = B V₀ (ψ = Φ′q is exact and the bending energy ½qᵀKq: no approximation); with gravity
the weights' generalized force depends on q and q₀ solves the residual at rest
(`NonlinearSystem.initial_coordinates`' Newton), and the stiffness about it is
K_g = ∂(residual at rest)/∂q (central differences: K plus the weights' geometric stiffness,
which stiffens a hanging arm and softens a standing one). About it, with the exact mass
matrix M(q₀) of the deflected arm (`NonlinearSystem.mass_matrix`),

    M(q₀) δq̈ + D δq̇ + K_g δq = B δV

(the velocity-squared terms have no first-order part at rest). The outputs are the nonlinear
channel functions (channels/nonlinear.py: exact deflections, accelerations), differenced
centrally about (q₀, 0, 0).
"""

from __future__ import annotations

import numpy as np

from ..channels.catalogue import catalogue, joint_name
from ..channels.nonlinear import sensor_values, tip_values
from ..dynamics.actuators import actuator_matrix
from ..dynamics.kinematics import JointHistory
from ..dynamics.nonlinear import NodeInputs, NonlinearSystem
from ..model import Scenario
from ..solvers import Solution
from .linear import LinearPlant
from .operating_point import Configuration

STEP = 1e-7  # central-difference step on the modal coordinates, their rates, accelerations


def nonlinear_plant(scenario: Scenario, held: Scenario, point: Configuration) -> LinearPlant:
    """``held``: the scenario held at ``point`` (joints constant); voltages from ``scenario``
    at t = 0."""
    system = NonlinearSystem(held.chain, gravity=scenario.settings.gravity)
    n = system.n
    b_act = actuator_matrix(scenario.actuators, system.modal)  # (n, n_act), N·m/V
    volts = held_voltages(scenario)
    stiffness = system.K
    if not system.gravity.any() or n == 0:
        q0 = np.linalg.solve(system.K, b_act @ volts) if n else np.zeros(0)
    else:
        q0, stiffness = _weighted_equilibrium(system, b_act @ volts)
    angles = np.array([point.angles])
    alpha = system.node_angles(q0[None], angles)
    M = system.mass_matrix(alpha)[0]
    Minv = np.linalg.inv(M)
    A = np.zeros((2 * n, 2 * n))
    A[:n, n:] = np.eye(n)
    A[n:, :n] = -Minv @ stiffness
    A[n:, n:] = -Minv @ system.D
    B = np.zeros((2 * n, len(scenario.actuators)))
    B[n:] = Minv @ b_act
    zero = np.zeros_like(angles)
    names, Y = _readings(held, system, q0, JointHistory(angles, zero, zero))
    C = Y[2] @ A[n:]  # y = Y_q δq + Y_v δq̇ + Y_a δq̈
    C[:, :n] += Y[0]
    C[:, n:] += Y[1]
    D = Y[2] @ B[n:]
    links = held.chain.links
    states = [f"{link.name}_q{i + 1}" for link in links for i in range(link.modes)]
    units = {c.name: c.unit for c in catalogue(held)}
    tip = float(np.max(np.abs(q0), initial=0.0))
    op = {"scenario": scenario.name, "model": "nonlinear", "kind": "static deflected "
          "equilibrium (rest)", **point.describe(),
          **{f"{a.name}_voltage_V": float(v) for a, v in zip(scenario.actuators, volts)},
          "largest_modal_coordinate": tip}
    return LinearPlant(A, B, C, D, tuple(states + [f"{s}_rate" for s in states]),
                       tuple(f"{a.name}_voltage" for a in scenario.actuators), tuple(names),
                       tuple("V" for _ in scenario.actuators),
                       tuple(units.get(name, "") for name in names), op, True)


def _weighted_equilibrium(system: NonlinearSystem, load: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
    """q₀ (n,) at rest under gravity and the generalized forces ``load`` (n,), and the
    stiffness ∂r/∂q there (n, n) of the residual at rest r(q) (central differences)."""
    from ..dynamics import equilibrium

    n = system.n
    inputs = system.node_inputs(np.zeros(1))
    held = NodeInputs(inputs.angle, inputs.rate, inputs.acceleration, inputs.tip_acceleration,
                      load[None])

    def residuals(q: np.ndarray) -> np.ndarray:
        rest = np.zeros_like(q)
        return system.residual(q, rest, rest, held[np.zeros(q.shape[0], dtype=int)])

    q0 = equilibrium.solve(residuals, np.zeros(n))
    shifts = np.concatenate([STEP * np.eye(n), -STEP * np.eye(n)])
    r = residuals(q0 + shifts)
    return q0, ((r[:n] - r[n:]) / (2 * STEP)).T


def held_voltages(scenario: Scenario) -> np.ndarray:
    """Each actuator's voltage at t = 0 (V), within its amplifier's limit."""
    return np.array([float(np.clip(a.voltage.value(np.zeros(1))[0], -a.limit, a.limit))
                     for a in scenario.actuators])


def _readings(held: Scenario, system: NonlinearSystem, q0: np.ndarray, hist: JointHistory
              ) -> tuple[list[str], list[np.ndarray]]:
    """Y_q, Y_v, Y_a (p, n) of the sensors, joint torques and tips by central differences."""
    n = system.n
    rows = 1 + 6 * n
    q = np.tile(q0, (rows, 1))
    qd, qdd = np.zeros((rows, n)), np.zeros((rows, n))
    for block, target in enumerate((q, qd, qdd)):
        r = 1 + 2 * n * block
        target[r:r + n] += STEP * np.eye(n)
        target[r + n:r + 2 * n] -= STEP * np.eye(n)
    many = JointHistory(*(np.repeat(a, rows, axis=0) for a in
                          (hist.angle, hist.rate, hist.acceleration)))
    sol = Solution(np.zeros(rows), q, qd, qdd, "linearize")
    values = sensor_values(system, sol, held.sensors, many)
    torque = system.joint_torques(np.zeros(rows), q, qd, qdd, many)
    for k in range(torque.shape[1]):
        values[joint_name(k, "torque")] = torque[:, k]
    values.update(tip_values(system, sol, many))
    names = list(values)
    V = np.column_stack([values[k] for k in names])
    out = []
    for block in range(3):
        r = 1 + 2 * n * block
        out.append(((V[r:r + n] - V[r + n:r + 2 * n]) / (2 * STEP)).T)
    return names, out
