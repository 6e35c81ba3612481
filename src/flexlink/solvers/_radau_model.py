"""How the compiled Radau IIA loop (`_radau_numba.py`) reaches a model: its rates
dy = f(t, y) and its projection onto known invariants, through pointers to their compiled
code, so that the loop is compiled once for every model.

numba optimises and emits every function it calls by name again inside the caller, and
compiles a caller once per type of its arguments: a loop that took each model's records and
called its rates by name was compiled (a large part of the kernel build) once per model, each
time with the whole model inside. Here the loop takes only `model_functions`' ``model`` =
(address of the rates trampoline, address of the projection entry (0: none), context):
the context is an int64 array holding the address of the model's compiled rates and its
records (kernel data, workspace, projection record) as numba holds
them, with the arrays' reference-count and owner pointers cleared, so that the loop's types
do not depend on the model. The context is written in Python (`_compiled_calls.pack`): a
compiled writer would be one more kernel per record type, most of its compile time spent
on the wrapper that unboxes records of a hundred arrays. A trampoline (one small kernel per record type) reads the
records back and calls the model's compiled code. The records' arrays are not owned by the
context: the caller keeps the records alive while the loop runs.

A model adds its kernel-data record class and compiled rates(d, w, u, y, dy) to
`_KERNELS` (the trampoline's call hands over every array of the records, field by field), or
a compiled entry(context, u, y, dy, records_type) that reads the records (d, w) from the
context itself, only the fields it uses, to `_ENTRIES` (the loop calls it in the
trampoline's place: the forward model's and the closed loops', whose records are large),
and, if it has invariants to keep (a forward system's momentum), its compiled projection
entry(context, u, U, t, y, records_type), which reads the records (d, w, pj) from the
context alike, to `_PROJECTIONS`; all return nothing.
"""

from __future__ import annotations

import struct
from collections import namedtuple
from typing import Any

import numpy as np
from numba import njit, typeof, types
from numba.extending import intrinsic

from .. import _compiled_cache  # noqa: F401 — kernels compiled at installation
from .._compiled_calls import CONTEXT, ROW
from .._compiled_calls import address as _address
from .._compiled_calls import call_codegen as _call_codegen
from .._compiled_calls import check as _check
from .._compiled_calls import layout as _layout
from .._compiled_calls import load as _load
from .._compiled_calls import pack as _pack
from .._compiled_calls import type_key as _type_key
from ..dynamics._forward_numba import rates_in as forward_rates_in
from ..dynamics._loops_numba import rates_in as loop_rates_in
from ..dynamics._momentum_numba import project_in as forward_project_in
from ..dynamics._nonlinear_loops_numba import rates as nonlinear_loop_rates
from ..dynamics.forward_kernel import ForwardData
from ..dynamics.loops import LoopData
from ..dynamics.nonlinear_loops import NonlinearLoopData

LinearData = namedtuple("LinearData", ["A", "B"])
LinearData.__doc__ = ("The linear model f = A y + B u (A (m, m), B (m, columns)): the "
                      "integrator's own test model, against exact solutions.")


@njit  # the tests' model only: no run of flexlink calls it, so nothing compiles it at install
def linear_rates(d, w, u, y, dy):
    """dy = A y + B u (w unused)."""
    for i in range(y.shape[0]):
        acc = 0.0
        for j in range(y.shape[0]):
            acc += d.A[i, j] * y[j]
        for j in range(u.shape[0]):
            acc += d.B[i, j] * u[j]
        dy[i] = acc


# kernel-data record class → its compiled rates(d, w, u, y, dy)
_KERNELS = {LinearData: linear_rates, NonlinearLoopData: nonlinear_loop_rates}
# kernel-data record class → its compiled projection onto known invariants that reads the
# records (d, w, pj) from the context itself, entry(context, u, U, t, y, records_type) (the
# projection trampoline's signature; a model without one is not projected)
_PROJECTIONS = {ForwardData: forward_project_in}
# kernel-data record class → its compiled rates that read the records (d, w) from the context
# themselves, entry(context, u, y, dy, records_type) (the trampoline's signature; the loop
# calls it in the trampoline's place): a large record (the forward model's, the closed
# loops' that hold it) is then not handed over field by field on every evaluation
_ENTRIES = {ForwardData: forward_rates_in, LoopData: loop_rates_in}

# _type_key(records) → `_addresses`
_MODELS: dict[Any, tuple[int, int, int, int, struct.Struct]] = {}


def model_functions(d: Any, w: Any, pj: Any = ()) -> tuple[int, int, np.ndarray]:
    """The ``model`` argument of the compiled loops for kernel data ``d``, workspace ``w``
    and projection record ``pj`` (``()``: none): (address of the rates trampoline, address
    of the projection entry or 0, context). The records must outlive every use of it."""
    records = (d, w, pj)
    key = _type_key(records)
    found = _MODELS.get(key)
    if found is None:
        found = _MODELS[key] = _addresses(records)
    rates_from, project_from, rates, project, fields = found
    return rates_from, project_from, _pack(records, fields, (rates, project))


def _addresses(records: tuple) -> tuple[int, int, int, int, struct.Struct]:
    """The addresses of the rates trampoline (or entry) and of the projection entry (0:
    none) for these records' types, of the model's compiled rates (0: an entry reads the
    records itself) and 0 (the context's second head word, unused), and the records'
    `_layout`."""
    d, w, pj = records
    kernel, entry = _KERNELS.get(type(d)), _ENTRIES.get(type(d))
    if kernel is None and entry is None:
        raise TypeError(f"no compiled rates for kernel data {type(d).__name__}: add its "
                        "record class and rates to _radau_model._KERNELS")
    d_type, w_type = typeof(d), typeof(w)
    records_type = types.TypeRef(typeof(records))
    if entry is not None:
        rates = 0
        rates_from = _address(entry, (CONTEXT, ROW, ROW, ROW,
                                      types.TypeRef(types.Tuple((d_type, w_type)))))
    else:
        rates = _address(kernel, (d_type, w_type, ROW, ROW, ROW))
        rates_from = _address(_rates_from, (CONTEXT, ROW, ROW, ROW, records_type))
    fields = _layout(records_type.instance_type)
    project = _PROJECTIONS.get(type(d))
    if project is None or len(pj) == 0:
        return rates_from, 0, rates, 0, fields
    return rates_from, _address(project, (CONTEXT, ROW, ROW, types.float64, ROW,
                                          records_type)), rates, 0, fields


@intrinsic
def _call_rates(typingctx, address, d, w, u, y, dy):
    """The model's compiled rates(d, w, u, y, dy) at ``address``."""
    _check("the model's rates", (u, y, dy), (ROW, ROW, ROW))
    return types.none(address, d, w, u, y, dy), _call_codegen(0)


@intrinsic
def _call_rates_from(typingctx, address, context, u, y, dy):
    """The rates trampoline (`_rates_from`) at ``address``."""
    _check("the rates trampoline", (context, u, y, dy), (CONTEXT, ROW, ROW, ROW))
    return types.none(address, context, u, y, dy), _call_codegen(1)


@intrinsic
def _call_project_from(typingctx, address, context, u, U, t, y):
    """The model's projection entry (`_PROJECTIONS`) at ``address``."""
    _check("the projection entry", (context, u, U, t, y),
           (CONTEXT, ROW, ROW, types.float64, ROW))
    return types.none(address, context, u, U, t, y), _call_codegen(1)


@njit(cache=True)
def _rates_from(context, u, y, dy, records_type):
    """dy = f(t, y) of the model whose records the context holds (their type given)."""
    d, w, _ = _load(context, records_type)
    _call_rates(context[0], d, w, u, y, dy)


@njit(inline="always")
def model_rates(model, u, y, dy):
    """dy = f(t, y) of ``model`` (`model_functions`) with the input row u at t."""
    _call_rates_from(model[0], model[2], u, y, dy)


@njit(inline="always")
def model_project(model, u, U, t, y):
    """Correct y (in place) onto the model's known invariants at time t (s): u the input
    row and U the inputs' integrals from the start (only where ``model`` has a
    projection)."""
    _call_project_from(model[1], model[2], u, U, t, y)
