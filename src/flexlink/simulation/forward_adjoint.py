"""The gradient of a scalar objective over a forward run's channels (driven joints, moving
base; first-order model, compiled Radau IIA) by one reverse pass of the run's accepted
steps (`solvers.radau_adjoint`), for `Objective`: the transpose of the forward tangents
(`driven_sensitivities.state_tangents`) on the same steps, with the same stage Jacobians,
∂f/∂p, projection derivative and dense output, so equal to their gradient to round-off.

J = Σ_t metric(channels(t)) depends on the fields p through the output states y(t) and
directly through the channel map: dJ/dp = Σ_t ∂J/∂y(t) dy(t)/dp + ∂J/∂p|y. The reverse
pass gives the first term for all fields at once; ∂f/∂p enters it contracted with the
stage weights, −μᵀ ∂E/∂p with μ = A⁻ᵀ w (E: the forward equations at the nominal
accelerations; ∂E/∂p from the fields' moved models, as the tangents take it). It applies
where every channel of the metric is a sensor read linearly from the modal coordinates
(strain, deflection, slope, piezo: c(t) = r · y(t)), on runs without closed loops or
sampled controllers; elsewhere `Objective` takes the tangents.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from types import SimpleNamespace

import numpy as np

from ..model import PointSensor
from .driven_sensitivities import (
    ForwardSettled,
    _Bases,
    _Model,
    _projection_tangent,
    _states,
)

CHUNK = 512  # steps whose stage Jacobians are held at once (memory)

def sensor_rows(model: _Model, names: Sequence[str]) -> dict[str, np.ndarray] | None:
    """Per channel of ``names``, the row r (m,) with channel(t) = r · y(t) over the forward
    state y, or None if one of them is not a sensor read linearly from the modal
    coordinates (an accelerometer, a joint or tip channel)."""
    from ..channels.first_order import sensor_values
    from ..dynamics.first_order import link_body
    from .channel_subset import State

    sensors = {s.name: s for s in model.scenario.sensors}
    chosen = []
    for name in names:
        sensor = sensors.get(name)
        if sensor is None or (isinstance(sensor, PointSensor)
                              and sensor.kind == "acceleration"):
            return None
        chosen.append(sensor)
    system = model.system
    n, nu = system.n, len(system.free)
    view = SimpleNamespace(chain=system.chain, modal=system.modal,
                           bodies=[link_body(b.data, b.offset - system.n_rigid)
                                   for b in system.bodies])
    unit = State(np.zeros(n), np.eye(n), np.zeros((n, n)), np.zeros((n, n)))
    values = sensor_values(view, None, unit, tuple(chosen))  # type: ignore[arg-type]
    out = {}
    for name in names:
        row = np.zeros(model.y0.size)
        row[2 * nu:2 * nu + n] = values[name]
        out[name] = row
    return out


def state_gradient(settled: ForwardSettled, fields: list, t: np.ndarray,
                   seeds: np.ndarray) -> np.ndarray:
    """dJ/dp (K,) of J = Σ_t seeds(t) · y(t) over the output states y (nt, m; projected if
    the run projects) along the settled run, by the reverse pass: equal to Σ_t seeds(t) ·
    `state_tangents`(t) to round-off."""
    from ..dynamics._forward_jacobian_numba import forward_jacobians, jacobian_scratch
    from ..solvers.radau_adjoint import output_seeds, radau_adjoint
    from ..solvers.radau_sensitivity import JACOBIAN_STEP, NODES, dense, output_steps
    from .record_moves import applied_forces, moved_arrays, moved_equations

    nominal, moved, steps = settled.nominal, settled.moved, settled.steps
    d = nominal.data
    nu, n, m = d.free.shape[0], d.n_x - d.n_rigid, nominal.y0.size
    q, S = nu + n, steps.h.size
    gradient = seeds[0] @ settled.dy0
    # the output seeds, through the outputs' projection if the run projects; it moves
    # the free rigid rates alone (`_momentum_numba.project`), so seeds on the other
    # entries (the sensors' modal coordinates) pass it as they are: its Jacobian's rows
    # there are the identity's, its field term's zero
    projected = nominal.projection.active.size > 0
    which, s = output_steps(steps, t)
    g = seeds[1:]
    if projected and np.any(g[:, nu:2 * nu]):
        kept = np.flatnonzero(np.any(g != 0.0, axis=1))
        w = which[kept]
        raw = dense(steps.y0[w], steps.z[w], steps.y1[w], s[kept])
        out_J, out_c = _projection_tangent(nominal, moved, fields, steps.segment[w],
                                           t[1:][kept], raw)
        g = np.zeros_like(g)
        g[kept] = np.einsum("nij,ni->nj", out_J, seeds[1:][kept])
        gradient += np.einsum("ni,nik->k", seeds[1:][kept], out_c)
    gy0, gz, gy1 = output_seeds(steps, t, g)
    lam = np.zeros(m)
    scratch = jacobian_scratch(d, nominal.work, m)
    parts = [moved_arrays(nominal, group, more=True) for group in moved]
    # backwards in pieces of CHUNK steps (the stage Jacobians take 3 m² numbers a step)
    for b in range(S, 0, -CHUNK):
        a = max(0, b - CHUNK)
        rows = 3 * (b - a)
        # the stage Jacobians, equations' matrices and accelerations (the tangents' own)
        times = (steps.t[a:b, None] + steps.h[a:b, None] * NODES).ravel()
        Y = np.ascontiguousarray((steps.y0[a:b, None, :] + steps.z[a:b]).reshape(-1, m))
        bases = _Bases(np.repeat(steps.segment[a:b], 3), times)
        J, A, acc = np.empty((rows, m, m)), np.empty((rows, q, q)), np.empty((rows, q))
        forward_jacobians(d, nominal.work, np.ascontiguousarray(bases.rows(nominal.table)),
                          Y, JACOBIAN_STEP, J, A, acc, scratch)
        step_J = None
        if projected:
            step_J, step_c = _projection_tangent(nominal, moved, fields, steps.segment[a:b],
                                                 steps.t[a:b] + steps.h[a:b],
                                                 steps.y0[a:b] + steps.z[a:b, 2])
        W, lam_end = radau_adjoint(steps.h[a:b], J.reshape(b - a, 3, m, m), step_J,
                                   gy0[a:b], gz[a:b], gy1[a:b], lam, nu, n)
        if projected:
            gradient += np.einsum("si,sik->k", lam_end, step_c)
        # ∂f/∂p at every stage, contracted with the stage weights: f's accelerations are
        # −A⁻¹ ∂E/∂p, its servo integrals' rates ∂S/∂p
        W = W.reshape(-1, m)
        wa = np.concatenate([W[:, nu:2 * nu], W[:, 2 * nu + n:2 * nu + 2 * n]], axis=1)
        mu = np.linalg.solve(np.swapaxes(A, 1, 2), wa[:, :, None])[:, :, 0]
        ws = W[:, 2 * q:]
        E, Sr = np.empty((rows, q)), np.empty((rows, m - 2 * q))
        applied0 = (applied_forces(nominal, bases.rows(nominal.table), Y)
                    if any(names is not None for names in parts) else None)
        for k, f in enumerate(fields):
            if not settled.reads[k]:
                continue
            for wt, md in zip(f.weights, moved[k], strict=True):
                if wt == 0.0:
                    continue
                moved_equations(md, nominal, parts[k], applied0, bases.rows(md.table), Y, acc,
                                E, Sr)
                gradient[k] += (wt / f.step) * (np.sum(ws * Sr) - np.sum(mu * E))
    return gradient + lam @ settled.dy0


def forward_gradient(settled: ForwardSettled, fields: list, t: np.ndarray,
                     slopes: Mapping[str, np.ndarray]) -> np.ndarray | None:
    """dJ/dp (K,) of J with ∂J/∂channel = ``slopes`` (nt each) along the settled forward run
    by the reverse pass, or None where it does not apply (module docstring)."""
    nominal = settled.nominal
    names = list(slopes)
    if nominal.loops is not None or settled.held is not None:
        return None
    rows = sensor_rows(nominal, names)
    if rows is None:
        return None
    weights = {name: np.asarray(slopes[name], dtype=float) for name in names}
    seeds = sum(weights[name][:, None] * rows[name][None, :] for name in names)
    gradient = state_gradient(settled, fields, t, seeds)  # type: ignore[arg-type]
    # the channel map's own dependence on the fields (a sensor's place, a link's shapes)
    states = _states(settled.run, nominal)
    weighted = {name: weights[name] @ states for name in names}
    for k, f in enumerate(fields):
        for wt, md in zip(f.weights, settled.moved[k], strict=True):
            if wt == 0.0:
                continue
            own = rows if md is nominal else sensor_rows(md, names)
            gradient[k] += (wt / f.step) * sum(float(weighted[name] @ own[name])  # type: ignore[index]
                                               for name in names)
    return gradient
