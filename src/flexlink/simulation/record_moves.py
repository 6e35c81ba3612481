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

Two more moves are as simple (``more``): the motors' inertia J_m enters r as J_m p̈ on its
joint's row alone, so it adds ΔJ_m p̈ there (p̈ the nominal accelerations on a free joint's
row); and input columns that only Q reads (a drive's torque, a base load, an actuator's
voltage, a cart's force: `forward_kernel.applied_columns`) moved on the same table pieces
add −(Q_p − Q_0) with the moved inputs. The projection reads both (the motors' momentum, the loads'
impulse), so those fields keep its field term.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..dynamics.forward_kernel import applied_columns

# a forward model (`driven_sensitivities._Model`; that module imports this one)
_Model = Any

DRIVE_ARRAYS = frozenset({"P", "I", "D", "saturation", "rate_per_volt", "loop_gain",
                          "torque_limit", "bandwidth", "rate_limit"})
ELASTIC_ARRAYS = frozenset({"stiffness", "damping"})
INERTIA_ARRAYS = frozenset({"motor_inertia"})
INPUTS = "inputs"  # `moved_arrays`' name of a move in `forward_kernel.applied_columns`
# the Projection's fields that are not scratch
_KNOWN = ("active", "start", "rate", "impulse", "t0", "about_cm", "total_mass", "size",
          "origin", "velocity")


def same(a: Any, b: Any) -> bool:
    """Whether two entries of the kernel records (arrays or scalars) are equal bit for bit
    (a cheap test of many small arrays; 0.0 and −0.0 count as different, which costs a
    full evaluation at most)."""
    if a is b:
        return True
    if isinstance(a, np.ndarray) and isinstance(b, np.ndarray):
        return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
    return bool(np.array_equal(a, b))


def moved_arrays(nominal: _Model, group: list[_Model], more: bool = False
                 ) -> frozenset[str] | None:
    """The names of the ForwardData arrays in which the models of a field's stencil
    differ from the nominal one, if all lie in DRIVE_ARRAYS | ELASTIC_ARRAYS and the input
    table is the same; else None (the moved equations are evaluated whole). ``more``: also
    INERTIA_ARRAYS, and a table moved on the same pieces in `forward_kernel.applied_columns`
    alone (named INPUTS)."""
    if nominal.loops is not None:
        return None
    known = DRIVE_ARRAYS | ELASTIC_ARRAYS | (INERTIA_ARRAYS if more else frozenset())
    names: set[str] = set()
    for md in group:
        if md is nominal:
            continue
        if md.table is not nominal.table and not all(
                same(a, b) for a, b in zip(md.table, nominal.table, strict=True)):
            if not (more and _applied_inputs_moved(md.table, nominal.table, nominal.data)):
                return None
            names.add(INPUTS)
        for name, a, b in zip(nominal.data._fields, md.data, nominal.data, strict=True):
            if not same(a, b):
                if name not in known:
                    return None
                names.add(name)
    return frozenset(names)


def _applied_inputs_moved(table: tuple, other: tuple, d: Any) -> bool:
    """Whether two input tables have the same pieces and differ in the columns only the
    applied forces read (`forward_kernel.applied_columns`) only."""
    a, b, coef, first = table
    a0, b0, coef0, first0 = other
    if not (same(a, a0) and same(b, b0) and same(first, first0)
            and coef.shape == coef0.shape):
        return False
    rest = np.ones(coef.shape[2], dtype=bool)
    rest[applied_columns(d.length.shape[0], d.load_point.shape[0],
                         d.actuator_B.shape[1])] = False
    return bool(np.array_equal(coef[:, :, rest], coef0[:, :, rest]))


def same_projection(nominal: _Model, group: list[_Model]) -> bool:
    """Whether the models of a field's stencil project as the nominal one does (their
    records differ only where the projection does not read, the same known momentum)."""
    if moved_arrays(nominal, group) is None:  # not ``more``: the projection reads those
        return False
    a = nominal.projection
    return all(all(same(getattr(md.projection, name), getattr(a, name))
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
    if names & DRIVE_ARRAYS or INPUTS in names:
        forward_applied(d, model.work, np.ascontiguousarray(u), Y, E, srates)
        np.subtract(Q0, E, out=E)
    else:
        E[:] = 0.0
        srates[:] = S0
    d0 = nominal.data
    nu, nr = d.free.shape[0], d.n_rigid
    if names & ELASTIC_ARRAYS:
        n = d.n_x - nr
        dK, dD = d.stiffness - d0.stiffness, d.damping - d0.damping
        for k in range(d.length.shape[0]):
            nk, o = int(d.n_modes[k]), int(d.offset[k]) - nr
            if nk == 0:
                continue
            z = Y[:, 2 * nu + o:2 * nu + o + nk]
            zd = Y[:, 2 * nu + n + o:2 * nu + n + o + nk]
            E[:, nu + o:nu + o + nk] += z @ dK[k, :nk, :nk].T + zd @ dD[k, :nk, :nk].T
    if names & INERTIA_ARRAYS:  # J_m p̈ on a joint's row (`_forward_numba.acceleration_terms`)
        dJ = d.motor_inertia - d0.motor_inertia
        for j in range(nu):
            k = int(d.free[j]) - d.n_base
            if 0 <= k < dJ.shape[0] and dJ[k] != 0.0:
                E[:, j] += dJ[k] * acc[:, j]
