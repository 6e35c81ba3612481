"""What a field's move changes in a forward model's kernel records, and ∂E/∂p from only
that where it is simple: for the sensitivities of a forward run (`driven_sensitivities`)
and an objective's reverse pass (`forward_adjoint`).

The forward equations E(a; y) = M[:, z] z̈ + r(p̈_free; x, ẋ) − Q (`_forward_jacobian_numba`)
read the drives' gains and limits (`DRIVE_ARRAYS`) in the applied forces Q alone, and the
links' modal stiffness and damping (`ELASTIC_ARRAYS`) in r's K z + D ż alone. A field whose
stencil models differ from the nominal one in those arrays only, with the same input table
(a servo's gain, a link's E, EI or damping ratio), moves E by

    E_p − E_0 = −(Q_p − Q_0) + (K_p − K_0) z + (D_p − D_0) ż,

exactly (r and M are otherwise the nominal model's): one evaluation of the drives and a
product instead of the residual and mass matrix of each moved model, and E's change
without the round-off of E itself. The momentum projection reads none of those arrays.
"""

from __future__ import annotations

from typing import Any

import numpy as np

# a forward model (`driven_sensitivities._Model`; that module imports this one)
_Model = Any

DRIVE_ARRAYS = frozenset({"P", "I", "D", "saturation", "rate_per_volt", "loop_gain",
                          "torque_limit", "bandwidth", "rate_limit"})
ELASTIC_ARRAYS = frozenset({"stiffness", "damping"})
# the Projection's fields that are not scratch
_KNOWN = ("active", "start", "rate", "impulse", "t0", "about_cm", "total_mass", "size",
          "origin", "velocity")


def moved_arrays(nominal: _Model, group: list[_Model]) -> frozenset[str] | None:
    """The names of the ForwardData arrays in which the models of a field's stencil
    differ from the nominal one, if all lie in DRIVE_ARRAYS | ELASTIC_ARRAYS and the input
    table is the same; else None (the moved equations are evaluated whole)."""
    if nominal.loops is not None:
        return None
    names: set[str] = set()
    for md in group:
        if md is nominal:
            continue
        if md.table is not nominal.table and not all(
                np.array_equal(a, b) for a, b in zip(md.table, nominal.table, strict=True)):
            return None
        for name, a, b in zip(nominal.data._fields, md.data, nominal.data, strict=True):
            if a is not b and not np.array_equal(a, b):
                if name not in DRIVE_ARRAYS and name not in ELASTIC_ARRAYS:
                    return None
                names.add(name)
    return frozenset(names)


def same_projection(nominal: _Model, group: list[_Model]) -> bool:
    """Whether the models of a field's stencil project as the nominal one does (their
    records differ only where the projection does not read, the same known momentum)."""
    if moved_arrays(nominal, group) is None:
        return False
    a = nominal.projection
    return all(all(np.array_equal(getattr(md.projection, name), getattr(a, name))
                   for name in _KNOWN) for md in group if md is not nominal)


def applied_forces(model: _Model, u: np.ndarray, Y: np.ndarray
                   ) -> tuple[np.ndarray, np.ndarray]:
    """The applied forces Q (n, q) of ``model`` on the free and elastic rows and the servo
    integrals' rates (n, ·) at states Y (n, m) and input rows u
    (`_forward_jacobian_numba.forward_applied`)."""
    from ..dynamics._forward_jacobian_numba import forward_applied

    d = model.data
    Q = np.empty((Y.shape[0], d.free.shape[0] + d.n_x - d.n_rigid))
    S = np.empty((Y.shape[0], Y.shape[1] - 2 * Q.shape[1]))
    forward_applied(d, model.work, np.ascontiguousarray(u), Y, Q, S)
    return Q, S


def moved_equations(model: _Model, nominal: _Model, names: frozenset[str] | None,
                    applied0: tuple[np.ndarray, np.ndarray] | None, u: np.ndarray,
                    Y: np.ndarray, acc: np.ndarray, E: np.ndarray, srates: np.ndarray
                    ) -> None:
    """E (n, q) and the servo integrals' rates (n, ·) of a moved ``model`` at states Y
    (n, m) (contiguous), input rows u and the nominal accelerations acc
    (`_forward_jacobian_numba.forward_equations`); where its field moves only ``names``
    (`moved_arrays`), E − E_0 (module docstring; E_0 = 0 at the nominal accelerations)
    from the nominal model's applied forces and integrals' rates ``applied0``
    (`applied_forces` at Y)."""
    from ..dynamics._forward_jacobian_numba import forward_applied, forward_equations

    d = model.data
    if names is None:
        forward_equations(d, model.work, np.ascontiguousarray(u), Y, acc, E, srates)
        return
    Q0, S0 = applied0  # type: ignore[misc]
    if names & DRIVE_ARRAYS:
        forward_applied(d, model.work, np.ascontiguousarray(u), Y, E, srates)
        np.subtract(Q0, E, out=E)
    else:
        E[:] = 0.0
        srates[:] = S0
    if names & ELASTIC_ARRAYS:
        d0 = nominal.data
        nu, nr = d.free.shape[0], d.n_rigid
        n = d.n_x - nr
        dK, dD = d.stiffness - d0.stiffness, d.damping - d0.damping
        for k in range(d.length.shape[0]):
            nk, o = int(d.n_modes[k]), int(d.offset[k]) - nr
            if nk == 0:
                continue
            z = Y[:, 2 * nu + o:2 * nu + o + nk]
            zd = Y[:, 2 * nu + n + o:2 * nu + n + o + nk]
            E[:, nu + o:nu + o + nk] += z @ dK[k, :nk, :nk].T + zd @ dD[k, :nk, :nk].T
