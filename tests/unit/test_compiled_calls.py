"""The kernels' uncounted arrays (flexlink/_compiled_calls.py): scratch on the stack of a
kernel compiled without numba's runtime, and borrowed views of a caller's arrays."""

from __future__ import annotations

import numpy as np
from numba import njit

from flexlink._compiled_calls import borrowed, stack_array


@njit(_nrt=False)
def _fill_and_sum(rows, cols, out):
    """A (rows, cols) and a (rows,) stack array, filled, read back into ``out``: the sum of
    a[i, j] = 10 i + j, a's strides (bytes), b's sum."""
    a = stack_array((rows, cols))
    b = stack_array(rows)
    for i in range(rows):
        b[i] = 1.0
        for j in range(cols):
            a[i, j] = 10.0 * i + j
    total = 0.0
    for i in range(rows):
        for j in range(cols):
            total += a[i, j]
    out[0] = total
    out[1] = a.strides[0]
    out[2] = a.strides[1]
    out[3] = b.sum()


def test_a_stack_array_has_its_shape_and_c_strides_in_a_kernel_without_runtime() -> None:
    out = np.zeros(4)
    _fill_and_sum(3, 5, out)
    expected = sum(10.0 * i + j for i in range(3) for j in range(5))
    assert out.tolist() == [expected, 40.0, 8.0, 3.0]


@njit
def _scale_borrowed(x, factor):
    view = borrowed(x)
    for i in range(view.shape[0]):
        view[i] *= factor
    return view.sum()


def test_a_borrowed_view_writes_into_the_callers_array() -> None:
    x = np.arange(4.0)
    assert _scale_borrowed(x, 2.0) == 12.0
    assert x.tolist() == [0.0, 2.0, 4.0, 6.0]
