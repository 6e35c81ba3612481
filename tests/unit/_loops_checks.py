"""What the tests of the compiled loop kernels (dynamics/_loops_numba.py) compute to check
them: a state off the closure, Φ at given coordinates, Φ's differences (the Jacobian G and
the acceleration term γ from them), and the numpy equations at the kernel's constrained
accelerations and multipliers."""

from __future__ import annotations

from typing import Any

import numpy as np
from numba import njit

from flexlink.dynamics import _loops_numba as kernels
from flexlink.dynamics.forward_kernel import inputs
from flexlink.dynamics.loops import LoopSystem


# The kernels below carry no Python wrapper (only other kernels call them): reached here
# through these.
@njit
def constraints(d, w) -> None:
    kernels.constraints(d, w)


@njit
def velocity_terms(d, w) -> None:
    kernels.constraints(d, w, False)


@njit
def load_state(d, w, u, y) -> None:
    kernels.load_state(d, w, u, y)


@njit
def solve_constrained(d, w, u, y) -> bool:
    return kernels.solve_constrained(d, w, u, y)


def random_state(loops: LoopSystem, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A closed state with random deflections and rates (rates not closing the loop: the
    kinematics do not need it)."""
    rng = np.random.default_rng(seed)
    y = loops.y0.copy()
    nu, n = len(loops.system.free), loops.system.n
    y[2 * nu:2 * nu + n] = 2e-3 * rng.standard_normal(n)
    y[nu:2 * nu] = rng.standard_normal(nu)
    y[2 * nu + n:2 * nu + 2 * n] = 0.3 * rng.standard_normal(n)
    return y, inputs(loops.system, np.array([0.2]))[0]


def phi_at(loops: LoopSystem, work: Any, q: np.ndarray, v: np.ndarray) -> np.ndarray:
    work.q[:] = q
    work.v[:] = v
    constraints(loops.data, work)
    return work.Phi.copy()


def closure_differences(loops: LoopSystem, work: Any, q0: np.ndarray, v0: np.ndarray,
                        h: float = 1e-6, tau: float = 1e-4
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Φ's central differences over every coordinate (column c: step ``h`` in q_c), and its
    second and first derivatives along the motion q0 + v0 s with q̈ = 0 (fourth-order
    differences of step ``tau`` s): what G, γ and G v0 must equal."""
    columns = []
    for c in range(q0.size):
        e = np.zeros_like(q0)
        e[c] = h
        columns.append((phi_at(loops, work, q0 + e, v0) - phi_at(loops, work, q0 - e, v0))
                       / (2 * h))
    a, b, c_, d, e = (phi_at(loops, work, q0 + v0 * s, v0)
                      for s in (-2 * tau, -tau, 0.0, tau, 2 * tau))
    second = (-a + 16 * b - 30 * c_ + 16 * d - e) / (12 * tau**2)
    first = (a - 8 * b + 8 * d - e) / (12 * tau)
    return np.stack(columns, axis=1), second, first


def numpy_equations(loops: LoopSystem, work: Any, u: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """After ``solve_constrained(loops.data, work, u, y)``: M ẍ + r − Q − Gᵀλ of the numpy
    ForwardSystem (`matrices`, the reference) on the free and elastic rows at the kernel's
    accelerations and multipliers, its forces f (a scale), and G ẍ + γ."""
    system = loops.system
    nu, n, nr = len(system.free), system.n, system.n_rigid
    yp, m = work.yp, nu + n
    acc, lam = work.rhs[:m].copy(), work.rhs[m:].copy()
    t = np.array([0.2])
    p, pd, pdd = system.rigid_state(t, yp[None, :nu], yp[None, nu:2 * nu], acc[None, :nu])
    M, C, K, f = (a[0] for a in system.matrices(p, pd, pdd))
    z, zd, zdd = yp[2 * nu:2 * nu + n], yp[2 * nu + n:2 * nu + 2 * n], acc[nu:]
    Q, _ = system.applied(t, p, pd, np.zeros((1, len(system.servos))))
    load_state(loops.data, work, u, yp)
    work.v[:nr] = pd[0]
    constraints(loops.data, work)
    # δp̈ = 0: the rigid accelerations are in f(p̈)
    x = [np.concatenate([np.zeros(nr), a]) for a in (z, zd, zdd)]
    residual = M @ x[2] + C @ x[1] + K @ x[0] - f - Q[0] - work.G.T @ lam
    rows = system.free + list(range(nr, nr + n))
    return residual[rows], f, work.G @ np.concatenate([pdd[0], zdd]) + work.gam
