"""What a closed-loop run says about its own loop (docs/closed_loop.md, "Warnings"): an
actuator held at its limit for most of a phase of the motion (the loop was not acting as the
linear design assumed), and a loop unstable about the final configuration (the eigenvalues
of the sampled closed loop: the linearised first-order plant held over each sample interval,
with every controller's discrete state space, saturation left out)."""

from __future__ import annotations

import dataclasses
import itertools
import math
from collections.abc import Mapping

import numpy as np

from ..channels.catalogue import voltage_name
from ..model import FunctionController, Scenario

# Fraction of a phase at the limit above which the actuator "sits at its limit".
SATURATED_SHARE = 0.5
# |eigenvalue| of the sampled closed loop above which it is unstable (1 + round-off).
UNSTABLE_RADIUS = 1.0 + 1e-9
# Phases shorter than this share of the run are not judged on their own.
_SHORTEST_PHASE = 0.05
_MOST_PHASES = 20


def loop_warnings(scenario: Scenario, t: np.ndarray, values: Mapping[str, np.ndarray]
                  ) -> list[str]:
    """The warnings of a run with controllers: saturation per phase, then stability about
    the final configuration. ``t`` (s) and ``values`` are the run's output times and
    channels (the actuators' applied voltages among them, V)."""
    out = saturation_warnings(scenario, t, values)
    unstable = final_loop_instability(scenario)
    if unstable:
        out.append(unstable)
    return out


def phases(scenario: Scenario, t_end: float) -> list[tuple[float, float]]:
    """The run cut where a prescribed joint motion starts, ends or switches (its
    breakpoints); one phase if there are none or very many (a measured motion)."""
    cuts = sorted({float(b) for j in scenario.chain.joints
                   for b in getattr(j, "breakpoints", ()) if 0.0 < b < t_end})
    if len(cuts) > _MOST_PHASES:
        cuts = []
    edges = [0.0, *cuts, t_end]
    return [(a, b) for a, b in itertools.pairwise(edges)
            if b - a >= _SHORTEST_PHASE * t_end]


def saturation_warnings(scenario: Scenario, t: np.ndarray,
                        values: Mapping[str, np.ndarray]) -> list[str]:
    """One warning per actuator and phase where it sat at its limit more than
    SATURATED_SHARE of the time."""
    out = []
    for actuator in scenario.actuators:
        volts = values.get(voltage_name(actuator.name))
        if volts is None or t.size < 2:
            continue
        at_limit = np.abs(volts) >= actuator.limit * (1.0 - 1e-9)
        for a, b in phases(scenario, float(t[-1])):
            inside = (t >= a) & (t <= b)
            share = float(at_limit[inside].mean()) if inside.any() else 0.0
            if share > SATURATED_SHARE:
                out.append(f"actuator {actuator.name} sat at its ±{actuator.limit:g} V limit "
                           f"{share:.0%} of the time from {a:g} to {b:g} s: the loop did not "
                           "act as its linear design; lower the controller's gain or raise "
                           "the limit")
    return out


def final_loop_instability(scenario: Scenario) -> str | None:
    """A warning if the sampled closed loop about the final configuration has an eigenvalue
    outside the unit circle, None if it is stable or cannot be judged this way (driven
    joints or a moving base, Python controllers, several sample rates)."""
    controllers = scenario.controllers
    if (not controllers or scenario.is_forward
            or any(isinstance(c, FunctionController) for c in controllers)
            or len({c.sample_rate for c in controllers}) != 1):
        return None
    try:
        radius, frequency = closed_loop_radius(scenario)
    except (ValueError, np.linalg.LinAlgError):  # a plant the check cannot linearise: the
        return None                               # run stands, its own blow-up checks apply
    if not radius > UNSTABLE_RADIUS:
        return None
    rate = controllers[0].sample_rate
    growth = math.log(radius) * rate
    mode = (f"a mode near {frequency:.3g} Hz" if frequency >= 0.01
            else "a non-oscillating mode (a static loop gain above 1)")
    return (f"the closed loop is unstable about the final configuration: {mode} grows by e "
            f"every {1 / growth:.3g} s (sampled closed-loop "
            f"eigenvalue |λ| = {radius:.6g} at {rate:g} Hz); lower the controllers' gain")


def closed_loop_radius(scenario: Scenario) -> tuple[float, float]:
    """Spectral radius of the sampled closed loop about the final configuration of a
    prescribed-joint scenario, and the frequency (Hz) of that eigenvalue."""
    from scipy.linalg import expm

    from ..dynamics.controllers import controller_inputs, controller_outputs, discretize
    from .linearization import linearize

    t_end = scenario.settings.t_end
    angles = tuple(float(j.evaluate(np.array([t_end]))[0][0]) for j in scenario.chain.joints)
    first_order = dataclasses.replace(
        scenario, settings=dataclasses.replace(scenario.settings, model="first_order"))
    plant = linearize(first_order, at=[math.degrees(a) for a in angles])
    controllers = scenario.controllers
    T = 1.0 / controllers[0].sample_rate
    # The sensors a controller reads are rows over the elastic coordinates (no feedthrough:
    # simulation/closed_loop.sensor_rows), so the plant's D is zero here.
    inputs = [voltage_name(a) for c in controllers for a in controller_outputs(c)]
    outputs = [s for c in controllers for s in controller_inputs(c)]
    plant = plant.select(inputs, outputs)
    n, m = plant.B.shape
    # zero-order hold over one sample: exp([[A, B], [0, 0]] T)
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = plant.A, plant.B
    held = expm(block * T)
    Phi, Gamma = held[:n, :n], held[:n, n:]
    parts = [discretize(c) for c in controllers]
    Ad = _block_diag([p[0] for p in parts])
    Bd = _block_diag([p[1] for p in parts])
    Cd = _block_diag([p[2] for p in parts])
    Dd = _block_diag([p[3] for p in parts])
    C = plant.C
    k = Ad.shape[0]
    loop = np.zeros((n + k, n + k))
    loop[:n, :n] = Phi + Gamma @ Dd @ C
    loop[:n, n:] = Gamma @ Cd
    loop[n:, :n] = Bd @ C
    loop[n:, n:] = Ad
    eig = np.linalg.eigvals(loop)
    i = int(np.argmax(np.abs(eig)))
    return float(abs(eig[i])), float(abs(np.angle(eig[i])) / (2 * np.pi * T))


def _block_diag(blocks: list[np.ndarray]) -> np.ndarray:
    rows = sum(b.shape[0] for b in blocks)
    cols = sum(b.shape[1] for b in blocks)
    out = np.zeros((rows, cols))
    r = c = 0
    for b in blocks:
        out[r:r + b.shape[0], c:c + b.shape[1]] = b
        r, c = r + b.shape[0], c + b.shape[1]
    return out
