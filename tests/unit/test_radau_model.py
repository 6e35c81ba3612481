"""How the compiled Radau IIA loop reaches a model (solvers/_radau_model.py): the addresses
of the model's compiled code are found once per layout of its records, by a key that
separates every pair of records numba types differently (it may separate more: a (1, n)
array is both C- and F-contiguous); the context written in Python holds the records' fields
byte for byte as numba's own store of them (arrays' counts and owners cleared)."""

from __future__ import annotations

from collections import namedtuple

import numpy as np
import pytest
from numba import njit, typeof, types
from numba.core import cgutils
from numba.extending import intrinsic

from flexlink._compiled_calls import HEAD, layout, pack, records_pointer
from flexlink.solvers import _radau_model
from flexlink.solvers._radau_model import LinearData, _type_key, model_functions

Record = namedtuple("Record", ["a", "b", "k", "x", "flag"])


def _samples() -> list:
    c = np.zeros((3, 3))
    readonly = np.zeros(3)
    readonly.setflags(write=False)
    return [
        np.zeros(3), np.zeros(4), np.zeros(3, dtype=np.int64), c, np.asfortranarray(c),
        c[:, 1], c[::2], readonly, np.zeros((1, 3)), 1, 2**63, 1.5, True, (), (1, 2.0),
        (np.zeros(3), np.zeros(3)), Record(np.zeros(2), c, 3, 0.5, False),
        Record(np.zeros(2), np.asfortranarray(c), 3, 0.5, False),
        Record(np.zeros(2), c, 3, 0.5, np.bool_(False)),
    ]


def test_records_of_one_key_have_one_numba_type() -> None:
    samples = _samples()
    distinct = 0
    for i, x in enumerate(samples):
        for z in samples[i:]:
            if typeof(x) != typeof(z):
                assert _type_key(x) != _type_key(z), (x, z)
                distinct += 1
    assert distinct > 100  # the samples do differ


def test_a_model_is_looked_up_once_per_layout() -> None:
    d = LinearData(np.eye(2), np.zeros((2, 1)))
    first = model_functions(d, ())
    key = _type_key((d, (), ()))
    assert key in _radau_model._MODELS
    again = model_functions(LinearData(-np.eye(2), np.ones((2, 1))), ())
    assert again[:2] == first[:2]  # the same compiled code, a context of its own records
    assert not np.array_equal(again[2], first[2])
    other = LinearData(np.asfortranarray(np.eye(2)), np.zeros((2, 1)))
    assert _type_key((other, (), ())) != key


def _cleared(context, builder, typ, value):
    """``value`` with every array's reference-count and owner pointers NULL."""
    if isinstance(typ, types.Array):
        array = cgutils.create_struct_proxy(typ)(context, builder, value=value)
        array.meminfo = cgutils.get_null_value(array.meminfo.type)
        array.parent = cgutils.get_null_value(array.parent.type)
        return array._getvalue()
    if isinstance(typ, types.BaseTuple):
        for k, member in enumerate(typ.types):
            inner = _cleared(context, builder, member, builder.extract_value(value, k))
            value = builder.insert_value(value, inner, k)
    return value


@intrinsic
def _words(typingctx, records):
    def codegen(context, builder, signature, args):
        size = context.get_abi_sizeof(context.get_value_type(records))
        return context.get_constant(types.intp, HEAD + (size + 7) // 8)
    return types.intp(records), codegen


@intrinsic
def _store(typingctx, array, records):
    def codegen(context, builder, signature, args):
        value = _cleared(context, builder, records, args[1])
        builder.store(value, records_pointer(context, builder, records, args[0]))
        return context.get_dummy_value()
    return types.none(array, records), codegen


@njit
def _numba_pack(records, first, second):
    """numba's own store of ``records`` into a context, the reference."""
    context = np.zeros(_words(records), dtype=np.int64)
    context[0] = first
    context[1] = second
    _store(context, records)
    return context


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


Padded = namedtuple("Padded", ["flag", "x", "small", "rows", "inner", "last"])


@pytest.mark.parametrize("records", [
    (LinearData(np.eye(2), np.zeros((2, 1))), (), ()),
    (np.zeros((2, 3, 4))[:, ::2], np.zeros(0), np.zeros((0, 3)), True, 7, 2**63, -1.5),
    Padded(True, 2.5, np.int32(-3), np.arange(6.0).reshape(2, 3).T,
           (False, np.float32(1.5), np.bool_(True), (np.zeros(2, dtype=bool),)), np.uint8(9)),
    (np.ones(3), (True,), (1, True), ((), np.float32(2.0)), np.int16(-2)),
    (_readonly(np.arange(4.0)), np.zeros((3, 2), order="F"), np.zeros(0, dtype=np.int64)),
])
def test_the_context_holds_the_records_as_numba_stores_them(records) -> None:
    fields = layout(typeof(records))
    context = pack(records, fields, (11, 12))
    expected = _numba_pack(records, 11, 12)
    assert context.dtype == np.int64 and context.shape == expected.shape
    assert list(context[:HEAD]) == [11, 12]
    # every field's bytes (numba leaves the padding between fields unset)
    assert fields.unpack_from(context, 8 * HEAD) == fields.unpack_from(expected, 8 * HEAD)


def test_a_record_the_compiled_code_cannot_take_is_refused() -> None:
    with pytest.raises(TypeError, match="only arrays, numbers and tuples"):
        layout(typeof((np.zeros(2), "text")))
