"""How the compiled Radau IIA loop reaches a model (solvers/_radau_model.py): the addresses
of the model's compiled code are found once per layout of its records, by a key that
separates every pair of records numba types differently (it may separate more: a (1, n)
array is both C- and F-contiguous)."""

from __future__ import annotations

from collections import namedtuple

import numpy as np
from numba import typeof

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
