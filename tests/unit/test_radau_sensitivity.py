"""Sensitivities of a compiled Radau IIA run (solvers/radau_sensitivity.py): the recorded
step sequence reproduces the run, and the tangent is the derivative of the run on those
steps (against differences of an exact replay of the collocation steps, on a damped
oscillator whose frequency is the parameter)."""

from __future__ import annotations

import numpy as np

from flexlink.solvers._radau_numba import LinearData
from flexlink.solvers.radau import integrate_radau
from flexlink.solvers.radau_sensitivity import (
    COEFFICIENTS,
    NODES,
    dense,
    output_steps,
    radau_tangent,
    step_sequence,
)

ZETA = 0.02


def _matrix(omega: float) -> np.ndarray:
    return np.array([[0.0, 1.0], [-omega**2, -2 * ZETA * omega]])


def _force(t: np.ndarray) -> np.ndarray:
    return np.where(t < 0.3, 50.0 * np.sin(7.0 * t), 0.0)[:, None]


def _run(omega: float, steps: list | None = None) -> tuple[np.ndarray, np.ndarray]:
    t = np.linspace(0.0, 1.0, 41)
    states, _ = integrate_radau(LinearData(_matrix(omega), np.array([[0.0], [1.0]])), (),
                                np.array([0.1, 0.0]), t, _force, np.array([0.3]), 1e-6,
                                1e-12, np.array([0, 1]), steps=steps)
    return t, states


def _replay(omega: float, steps, t: np.ndarray) -> np.ndarray:
    """The collocation steps solved exactly (linear) with the run's t, h at ``omega``; the
    outputs from each step's collocation polynomial."""
    A = _matrix(omega)
    y = np.array([0.1, 0.0])
    z_all, y0_all, y1_all = [], [], []
    for k in range(steps.h.size):
        h = steps.h[k]
        u = _force_left(steps.t[k] + NODES * h, steps.segment[k])
        G = np.eye(6) - h * np.kron(COEFFICIENTS, A)
        rhs = h * np.kron(COEFFICIENTS, A) @ np.tile(y, 3) + h * np.kron(
            COEFFICIENTS, np.eye(2)) @ np.concatenate([[0.0, ui] for ui in u])
        z = np.linalg.solve(G, rhs).reshape(3, 2)
        y0_all.append(y)
        z_all.append(z)
        y = y + z[2]
        y1_all.append(y)
    which, s = output_steps(steps, t)
    out = np.empty((t.size, 2))
    out[0] = [0.1, 0.0]
    out[1:] = dense(np.array(y0_all)[which], np.array(z_all)[which], np.array(y1_all)[which],
                    s)
    return out


def _force_left(times: np.ndarray, segment: int) -> np.ndarray:
    """The force as the run's segments see it: segment 0 continued up to 0.3 s."""
    return 50.0 * np.sin(7.0 * times) if segment == 0 else np.zeros_like(times)


def test_recording_the_steps_changes_nothing_and_records_the_collocation_solution() -> None:
    records: list = []
    t, plain = _run(20.0)
    _, recorded = _run(20.0, records)
    assert np.array_equal(plain, recorded)
    steps = step_sequence(records)
    assert np.all(steps.y0[1:] == steps.y1[:-1])
    assert np.isclose(steps.t[-1] + steps.h[-1], t[-1])
    assert np.any(np.isclose(steps.t, 0.3, rtol=0, atol=1e-12))  # a step starts at the jump
    which, s = output_steps(steps, t)
    assert np.allclose(dense(steps.y0[which], steps.z[which], steps.y1[which], s), plain[1:],
                       rtol=0, atol=1e-14)
    assert np.allclose(_replay(20.0, steps, t), plain, rtol=0, atol=1e-9)  # Newton's residual


def test_the_tangent_is_the_derivative_of_the_run_on_its_steps() -> None:
    omega = 20.0
    records: list = []
    t, _ = _run(omega, records)
    steps = step_sequence(records)
    A = _matrix(omega)
    dA = np.array([[0.0, 0.0], [-2 * omega, -2 * ZETA]])

    def rates(u: np.ndarray, Y: np.ndarray) -> np.ndarray:
        return Y @ A.T + u[:, :1] * np.array([0.0, 1.0])

    def forcing(times: np.ndarray, segment: np.ndarray, Y: np.ndarray) -> np.ndarray:
        return (Y @ dA.T)[:, :, None]

    u = np.stack([_force_left(steps.t[k] + NODES * steps.h[k], steps.segment[k])
                  for k in range(steps.h.size)])[:, :, None]
    starts, dz, ends = radau_tangent(steps, rates, u, forcing, np.zeros((2, 1)))
    which, s = output_steps(steps, t)
    derivative = dense(starts[which], dz[which], ends[which], s)[:, :, 0]
    delta = 1e-4
    replayed = (_replay(omega + delta, steps, t) - _replay(omega - delta, steps, t)) / (2 * delta)
    error = np.abs(derivative - replayed[1:]).max() / np.abs(replayed).max(axis=0).max()
    assert error < 1e-8
