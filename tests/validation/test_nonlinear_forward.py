"""Forward dynamics of the nonlinear model (docs/nonlinear.md §7) against conservation laws,
the work of the drives and the first-order model in the small-deflection limit."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from flexlink.dynamics.nonlinear_forward import NonlinearForwardSystem
from flexlink.model import Base, Chain, Link, Scenario, SimulationSettings, Step, TorqueDrive
from flexlink.motion import Hold
from flexlink.simulation import simulate
from flexlink.solvers.gauss_forward import solve_nonlinear_forward
from tests.validation.forward_fe_cases import CASES, flexlink_scenario


def _free_system(t_end: float) -> Scenario:
    """A free base spinning and drifting, a two-link branch (its elbow a torque drive at zero
    torque, spinning) and a one-link branch, undamped, no loads: deflections of ~8% of the
    outer links' length."""
    links = (Link("a", 2.0, 1.0, 50.0, tip_mass=0.3, tip_inertia=0.01, modes=3),
             Link("b", 1.5, 1.0, 40.0, modes=3), Link("c", 0.8, 0.5, 20.0, modes=2))
    base = Base("free", mass=20.0, inertia=5.0, attachments=((0, (0.5, 0.0)), (1, (-0.5, 0.1))),
                position=(0.3, 0.2), velocity=(0.1, -0.05), rate=1.5)
    chain = Chain(links, (TorqueDrive(Step(0.0), initial_rate=2.0, motor_inertia=0.02),
                          Hold(180.0),
                          TorqueDrive(Step(0.0), initial_angle=0.3, initial_rate=-3.0)))
    settings = SimulationSettings(t_end, 0.01, model="nonlinear", step=5e-3)
    return Scenario(chain, (), settings, base=base, name="free_spin")


@pytest.mark.parametrize("t_end", [2.0, pytest.param(10.0, marks=pytest.mark.slow)])
def test_momentum_of_a_free_system_is_constant(t_end: float) -> None:
    """Linear and angular momentum (the channels, from the point motion, not the equations)
    constant to 1e-8 of their initial value (measured over 10 s at 5 ms steps: 1.2e-9 linear,
    1.7e-10 angular; the error is the collocation's O(h⁴) plus Newton's tolerance)."""
    results = simulate(_free_system(t_end))
    for name in ("momentum_x", "momentum_y", "angular_momentum"):
        value = np.asarray(results[name])
        scale = max(abs(value[0]), 1e-3)
        assert np.abs(value - value[0]).max() < 1e-8 * scale, name
    # and the run is not trivial: the branches swing and bend
    assert np.ptp(np.asarray(results["joint3_angle"])) > 1.0


def _work(torque: float, switch: float, end: float, t: np.ndarray,
          angle: np.ndarray) -> np.ndarray:
    """Work (J) of a bang-bang torque (+τ before ``switch``, −τ until ``end``, then 0) on the
    angle history: τ Δangle per constant piece (exact, no quadrature)."""
    def at(s: float) -> float:
        return float(np.interp(s, t, angle))

    first = torque * (angle - angle[0])
    second = torque * (at(switch) - angle[0]) - torque * (angle - at(switch))
    third = torque * (at(switch) - angle[0]) - torque * (at(end) - at(switch))
    return np.where(t <= switch, first, np.where(t <= end, second, third))


@pytest.mark.parametrize("name", ["hub_beam_large", "free_hub_large"])
def test_energy_is_the_work_of_the_drive(name: str) -> None:
    """Undamped: kinetic + bending energy equals the work of the bang-bang torque (on the hub
    angle) at every output time, to 1e-8 of the peak energy (measured 1.8e-10 and 1.1e-10),
    through slews with tip deflections of 30% (hub–beam) and 36% (free hub) of the length."""
    case = CASES[name]
    scenario = flexlink_scenario(case, modes=4)
    system = NonlinearForwardSystem(scenario.chain, scenario.base)
    t = np.arange(0.0, case.t_end + 1e-9, case.dt_out)
    solution = solve_nonlinear_forward(system, t, 1e-4, step=1.25e-3)
    y, v, _ = system.from_solution(solution)
    kinetic, elastic = system.energy(t, y, v)
    angle = solution.q[:, 0] if case.kind == "hub_beam" else solution.q[:, 2]
    work = _work(case.amplitude, case.slew / 2, case.slew, t, angle)
    energy = kinetic + elastic
    assert np.abs(energy - work).max() < 1e-8 * energy.max()
    assert elastic.max() > 0.005 * energy.max()  # the links bend hard


def test_small_deflection_agrees_with_the_first_order_model() -> None:
    """Hub–beam slew with a tip deflection of 2.8% of the length: the nonlinear model and the
    first-order stiffened model (same 6 modes) agree to the size of the neglected terms,
    (w/L)² ≈ 1e-3 of the deflection: measured 6.6e-4 of peak on the tip, 1.2e-5 on the hub."""
    case = CASES["hub_beam_small"]
    first = flexlink_scenario(case, modes=6)
    nonlinear = replace(first, settings=replace(first.settings, model="nonlinear",
                                                 step=1.25e-3))
    a, b = simulate(first), simulate(nonlinear)
    tip_a, tip_b = np.asarray(a["tip"]), np.asarray(b["tip"])
    assert 0.02 < np.abs(tip_a).max() < 0.05
    assert np.abs(tip_a - tip_b).max() < 2e-3 * np.abs(tip_a).max()
    hub_a, hub_b = np.asarray(a["joint1_angle"]), np.asarray(b["joint1_angle"])
    assert np.abs(hub_a - hub_b).max() < 1e-4 * np.abs(hub_a).max()
