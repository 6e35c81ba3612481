"""Calls of compiled numba procedures through the address of their code rather than by name.

numba optimises and emits every function a kernel calls by name again inside that kernel
(ARCHITECTURE.md, "What a kernel costs to compile"): a large function that many kernels
call is compiled many times over. Called through its address, it is compiled once, as a
kernel of its own, and its callers hold only the call. The address is data (a kernel
cached on disk cannot hold one): the caller gets it in an argument, found for the
argument types it will pass (`address`). The integrators reach the models this way
(`solvers/_radau_model.py`, `solvers/_gauss_numba.py`), and the forward model's kernels
their residual (`dynamics/_forward_numba.py`).
"""

from __future__ import annotations

import ctypes
import struct
from typing import Any

import numpy as np
from numba import types
from numba.core import cgutils
from numba.core.errors import TypingError
from numba.extending import intrinsic

ROW = types.Array(types.float64, 1, "C")  # a float row, as the callers pass them
MATRIX = types.Array(types.float64, 2, "C")
# A compiled loop's context (solvers/_radau_model.py): HEAD words of addresses, then records
CONTEXT = types.Array(types.int64, 1, "C")
HEAD = 2
# struct codes of the numbers a record may hold, by (numba type class, bits, signed)
_NUMBER_CODES = {(types.Integer, 8, True): "b", (types.Integer, 8, False): "B",
                 (types.Integer, 16, True): "h", (types.Integer, 16, False): "H",
                 (types.Integer, 32, True): "i", (types.Integer, 32, False): "I",
                 (types.Integer, 64, True): "q", (types.Integer, 64, False): "Q",
                 (types.Float, 32, True): "f", (types.Float, 64, True): "d"}
_ADDRESSES: dict[tuple, int] = {}  # (kernel, argument types) → address of its compiled code


def address(kernel: Any, argument_types: tuple) -> int:
    """The address of `kernel`'s compiled code (numba's own calling convention) for these
    argument types, compiled or loaded from its cache first."""
    key = (kernel, argument_types)
    if key not in _ADDRESSES:
        kernel.compile(argument_types)
        result = kernel.get_compile_result(types.none(*argument_types))
        if result.signature.return_type != types.none:
            raise TypeError(f"{kernel.py_func.__qualname__} must return nothing: it is "
                            "called as a procedure")
        _ADDRESSES[key] = result.library.get_pointer_to_function(result.fndesc.llvm_func_name)
    return _ADDRESSES[key]


def type_key(x: Any) -> Any:
    """A hashable key that determines numba's type of ``x`` (arrays, numbers, tuples of
    them), built without numba's typeof, which on records of dozens of arrays costs more
    than a short run's integration: equal keys, equal types (the key may separate more)."""
    if isinstance(x, np.ndarray):
        f = x.flags
        return (x.dtype, x.ndim, f.c_contiguous, f.f_contiguous, f.writeable, f.aligned)
    if isinstance(x, tuple):
        return (type(x), *map(type_key, x))
    if isinstance(x, int) and not isinstance(x, bool):
        return (int, x.bit_length() > 62)  # typeof widens very large ints
    return type(x)


def call_codegen(opaque: int):
    """Code of a call of the compiled procedure at the address in the first argument with
    the other arguments, then ``opaque`` NULL pointers (the callee's type-reference
    arguments); an error the callee raises is raised on."""
    def codegen(context, builder, signature, args):
        argument_types = signature.args[1:] + (types.voidptr,) * opaque
        values = list(args[1:]) + [cgutils.voidptr_t(None)] * opaque
        function = context.call_conv.get_function_type(types.none, argument_types)
        pointer = builder.inttoptr(args[0], function.as_pointer())
        status, _ = context.call_conv.call_function(builder, pointer, types.none,
                                                    argument_types, values)
        with cgutils.if_unlikely(builder, status.is_error):
            context.call_conv.return_status_propagate(builder, status)
        return context.get_dummy_value()
    return codegen


def check(name: str, got: tuple, wanted: tuple) -> None:
    """A call's argument types against those the callee was compiled for."""
    if got != wanted:
        raise TypingError(f"{name} takes {wanted}, got {got}")


def records_pointer(context, builder, records, array):
    """Pointer to the records stored in the context array after its head."""
    data = cgutils.create_struct_proxy(CONTEXT)(context, builder, value=array).data
    start = builder.gep(data, [context.get_constant(types.intp, HEAD)])
    return builder.bitcast(start, context.get_value_type(records).as_pointer())


@intrinsic
def load(typingctx, array, records_type):
    """The records of type ``records_type`` stored in the context ``array`` (or its leading
    records: a tuple's members lie at the same places in any tuple it begins)."""
    records = records_type.instance_type
    if array != CONTEXT:
        raise TypingError(f"the context is {CONTEXT}, not {array}")

    def codegen(context, builder, signature, args):
        return builder.load(records_pointer(context, builder, records, args[0]))
    return records(array, records_type), codegen


@intrinsic
def stack_array(typingctx, shape):
    """A C-contiguous float64 array of ``shape`` (an integer or a tuple of them) on the
    calling kernel's stack, freed when it returns, uncounted: scratch for a kernel compiled
    without numba's runtime (``_nrt=False``), which cannot allocate. Call it outside loops
    (each call takes more stack)."""
    dims = shape.types if isinstance(shape, types.BaseTuple) else (shape,)
    if not dims or not all(isinstance(t, types.Integer) for t in dims):
        raise TypingError(f"stack_array takes an integer or a tuple of them, got {shape}")
    array = types.Array(types.float64, len(dims), "C")

    def codegen(context, builder, signature, args):
        from numba.np.arrayobj import make_array, populate_array

        values = (cgutils.unpack_tuple(builder, args[0])
                  if isinstance(shape, types.BaseTuple) else [args[0]])
        sizes = [context.cast(builder, v, t, types.intp) for v, t in zip(values, dims)]
        count = context.get_constant(types.intp, 1)
        for size in sizes:
            count = builder.mul(count, size)
        data = builder.alloca(context.get_value_type(types.float64), size=count)
        strides = [context.get_constant(types.intp, 8)]
        for size in reversed(sizes[1:]):
            strides.insert(0, builder.mul(strides[0], size))
        out = make_array(array)(context, builder)
        populate_array(out, data=data, shape=sizes, strides=strides,
                       itemsize=context.get_constant(types.intp, 8), meminfo=None)
        return out._getvalue()
    return array(shape), codegen


@intrinsic
def borrowed(typingctx, array):
    """``array`` with its reference-count (meminfo) and owner pointers NULL: a view that
    numba neither counts nor frees, for the hot calls of a kernel on arrays that outlive
    them (each count is an atomic operation, at every call level)."""
    if not isinstance(array, types.Array):
        raise TypingError(f"borrowed takes an array, got {array}")

    def codegen(context, builder, signature, args):
        view = cgutils.create_struct_proxy(array)(context, builder, value=args[0])
        view.meminfo = cgutils.get_null_value(view.meminfo.type)
        view.parent = cgutils.get_null_value(view.parent.type)
        return view._getvalue()
    return array(array), codegen


def layout(records: Any) -> struct.Struct:
    """How numba holds a value of type ``records`` (arrays, numbers and tuples of them) in
    memory, as a `struct` format of its fields (`words`' order): an array is its
    reference-count and owner pointers, element count, item size, data pointer, shape and
    strides (bytes), 8 bytes each; a number its bytes; a tuple its members, each at the next
    multiple of its alignment, padded to a multiple of the tuple's. Checked against numba's
    own size of the type."""
    from numba.core.registry import cpu_target

    code, size, _ = _layout(records, 0)
    target = cpu_target.target_context
    if size != target.get_abi_sizeof(target.get_value_type(records)):
        raise TypeError(f"numba lays out {records} in another way than `layout` finds")
    return struct.Struct("<" + code)


def _layout(typ: Any, offset: int) -> tuple[str, int, int]:
    """(`struct` format, end offset, alignment) of a value of numba type ``typ`` placed at
    ``offset`` (bytes)."""
    if isinstance(typ, types.Array):
        words = 5 + 2 * typ.ndim
        return "q" * words, offset + 8 * words, 8
    if isinstance(typ, types.Boolean):
        return "?", offset + 1, 1
    if isinstance(typ, (types.Integer, types.Float)):
        code = _NUMBER_CODES[type(typ), typ.bitwidth, getattr(typ, "signed", True)]
        return code, offset + typ.bitwidth // 8, typ.bitwidth // 8
    if isinstance(typ, types.BaseTuple):
        codes, alignment = [], 1
        for member in typ.types:
            _, _, align = _layout(member, 0)
            pad = -offset % align
            code, offset, _ = _layout(member, offset + pad)
            codes.append("x" * pad + code)
            alignment = max(alignment, align)
        pad = -offset % alignment
        return "".join(codes) + "x" * pad, offset + pad, alignment
    raise TypeError(f"a model record holds {typ}: only arrays, numbers and tuples of them "
                    "can be handed to a compiled loop")


def words(x: Any, into: list) -> list:
    """The field values of ``x`` in `layout`'s order onto ``into``: an array's pointers to
    its reference count and owner are NULL (a borrowed view that numba neither counts nor
    frees: the caller keeps ``x`` alive)."""
    if isinstance(x, np.ndarray):
        into += (0, 0, x.size, x.itemsize, _data(x), *x.shape, *x.strides)
    elif isinstance(x, tuple):
        for member in x:
            words(member, into)
    else:
        into.append(x)
    return into


def _data(x: np.ndarray) -> int:
    """The address of array ``x``'s first element: through the buffer protocol where that
    works (a writable, C-contiguous, non-empty array: a fourth of the time of ``ctypes``,
    which dominates a record's `pack`), else numpy's own."""
    try:
        return ctypes.addressof(ctypes.c_char.from_buffer(x))
    except (TypeError, ValueError, BufferError):
        return x.ctypes.data


def pack(records: Any, fields: struct.Struct, head: tuple[int, ...]) -> np.ndarray:
    """A context (`CONTEXT`): the `HEAD` words ``head``, then ``records`` as numba holds
    them (``fields``: `layout` of their type), as `load` reads them back."""
    context = np.zeros(HEAD + (fields.size + 7) // 8, dtype=np.int64)
    context[:HEAD] = head
    fields.pack_into(context, 8 * HEAD, *words(records, []))
    return context
