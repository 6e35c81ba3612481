"""An independent, slow linearisation of a chain's equations of motion.

It shares nothing with flexlink.dynamics but the mode shapes: the exact (nonlinear) position of
every mass point of every link is written down directly,

    r_k(x) = R_k + A(θ_k) [x + u_x(x), w(x)],   R_{k+1} = r_k(L_k),
    θ_{k+1} = θ_k + β_{k+1} + w_k'(L_k),        u_x = −½ ∫₀ˣ w'² ds (stiffening only),

the generalized inertia force Q_i = Σ m_p (∂r_p/∂z_i)·r̈_p + J_t (∂θ_tip/∂z_i) θ̈_tip is obtained by
finite differences in time and in z, and M, C, K, f are read off as ∂Q/∂z̈, ∂Q/∂ż, ∂Q/∂z, −Q(0).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import cumulative_simpson, simpson

from flexlink.modes import ModalData

_GRID = 801


def _link_positions(data, origin, theta, q, stiffening):
    """Positions of the grid points of one link and its tip angle increment."""
    x = np.linspace(0.0, data.length, _GRID)
    w = data.shapes.evaluate(x, 0) @ q
    wp = data.shapes.evaluate(x, 1) @ q
    ux = -0.5 * cumulative_simpson(wp**2, x=x, initial=0.0) if stiffening else 0.0 * x
    c, s = np.cos(theta), np.sin(theta)
    local = np.stack([x + ux, w])
    pts = origin[:, None] + np.array([[c, -s], [s, c]]) @ local
    return x, pts, wp[-1]


def chain_points(modal: list[ModalData], beta: np.ndarray, z: np.ndarray, stiffening: bool):
    """All grid points (list per link) and tip section angles of the chain."""
    origin = np.zeros(2)
    theta = 0.0
    offset = 0
    out = []
    for k, data in enumerate(modal):
        q = z[offset: offset + data.n]
        offset += data.n
        theta = theta + beta[k]
        x, pts, tip_slope = _link_positions(data, origin, theta, q, stiffening)
        out.append((x, pts, theta + tip_slope))
        origin = pts[:, -1]
        theta = theta + tip_slope
    return out


def _second_derivative(samples, h):
    """Fourth-order central second difference from samples at −2h, −h, 0, h, 2h."""
    a, b, c, d, e = samples
    return (-a + 16 * b - 30 * c + 16 * d - e) / (12 * h**2)


def generalized_inertia(links, modal, beta_fn, t0, z, zd, zdd, stiffening, h=1e-3, dz=1e-6):
    """Q(z, ż, z̈) at time t0, for the trajectory z(t) = z + ż τ + ½ z̈ τ²."""

    def points(tau, zz):
        return chain_points(modal, beta_fn(t0 + tau), zz, stiffening)

    taus = (-2 * h, -h, 0.0, h, 2 * h)
    samples = [points(tau, z + zd * tau + 0.5 * zdd * tau**2) for tau in taus]
    p_0 = samples[2]
    Q = np.zeros(z.size)
    for i in range(z.size):
        e = np.zeros(z.size)
        e[i] = dz
        plus, minus = points(0.0, z + e), points(0.0, z - e)
        for k, data in enumerate(modal):
            x = p_0[k][0]
            acc = _second_derivative([smp[k][1] for smp in samples], h)
            dr = (plus[k][1] - minus[k][1]) / (2 * dz)
            integrand = np.sum(dr * acc, axis=0) * links[k].mass_per_length
            Q[i] += simpson(integrand, x=x)
            if links[k].tip_mass:
                Q[i] += links[k].tip_mass * np.dot(dr[:, -1], acc[:, -1])
            if links[k].tip_inertia:
                th_acc = _second_derivative([smp[k][2] for smp in samples], h)
                Q[i] += links[k].tip_inertia * (plus[k][2] - minus[k][2]) / (2 * dz) * th_acc
    return Q


def linearise(links, modal, beta_fn, t0, stiffening, eps=1e-4):
    """M, C, K_inertial (no elastic or damping terms) and f at t0 by finite differences of Q."""
    n = sum(d.n for d in modal)
    zero = np.zeros(n)
    Q0 = generalized_inertia(links, modal, beta_fn, t0, zero, zero, zero, stiffening)
    M, C, K = (np.zeros((n, n)) for _ in range(3))
    for j in range(n):
        e = np.zeros(n)
        e[j] = eps
        for mat, args in ((M, (zero, zero, e)), (C, (zero, e, zero)), (K, (e, zero, zero))):
            qp = generalized_inertia(links, modal, beta_fn, t0, *args, stiffening)
            qm = generalized_inertia(links, modal, beta_fn, t0, *(-a for a in args), stiffening)
            mat[:, j] = (qp - qm) / (2 * eps)
    return M, C, K, -Q0


def exact_joint_torques(links, modal, beta_fn, t0, z, zd, zdd, stiffening, h=1e-3):
    """τ_k = Σ_{j≥k} ∫ (r − P_k) × r̈ dm + J_t ϑ̈ from the exact kinematics, for the trajectory
    z(t0 + τ) = z + ż τ + ½ z̈ τ²."""
    taus = (-2 * h, -h, 0.0, h, 2 * h)
    samples = [chain_points(modal, beta_fn(t0 + tau), z + zd * tau + 0.5 * zdd * tau**2,
                            stiffening) for tau in taus]
    now = samples[2]
    torques = np.zeros(len(modal))
    for k in range(len(modal)):
        joint = now[k][1][:, 0]
        for j in range(k, len(modal)):
            x, pts, _ = now[j]
            acc = _second_derivative([s[j][1] for s in samples], h)
            arm = pts - joint[:, None]
            moment = arm[0] * acc[1] - arm[1] * acc[0]
            torques[k] += simpson(moment * links[j].mass_per_length, x=x)
            torques[k] += links[j].tip_mass * moment[-1]
            torques[k] += links[j].tip_inertia * _second_derivative([s[j][2] for s in samples], h)
    return torques


def exact_energy(links, modal, beta_fn, t0, z, zd, stiffening, h=1e-4):
    """Kinetic energy of the exact kinematics plus the bending energy ½ qᵀK_b q (J)."""
    taus = (-2 * h, -h, h, 2 * h)
    samples = [chain_points(modal, beta_fn(t0 + tau), z + zd * tau, stiffening) for tau in taus]
    kinetic = 0.0
    for j, data in enumerate(modal):
        a, b, d, e = (s[j] for s in samples)
        vel = (a[1] - 8 * b[1] + 8 * d[1] - e[1]) / (12 * h)
        spin = (a[2] - 8 * b[2] + 8 * d[2] - e[2]) / (12 * h)
        speed2 = np.sum(vel**2, axis=0)
        kinetic += 0.5 * simpson(speed2 * links[j].mass_per_length, x=b[0])
        kinetic += 0.5 * links[j].tip_mass * speed2[-1] + 0.5 * links[j].tip_inertia * spin**2
    offsets = np.cumsum([0] + [d.n for d in modal])
    strain = sum(0.5 * z[o: o + d.n] @ d.stiffness_matrix @ z[o: o + d.n]
                 for o, d in zip(offsets, modal))
    return kinetic + strain, strain
