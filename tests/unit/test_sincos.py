"""The vectorised cosines and sines of the nonlinear residual's node angles against libm's."""

from __future__ import annotations

import numpy as np

from flexlink.dynamics._sincos_numba import LIMIT, sincos_rows


def test_within_one_unit_in_the_last_place_of_libm() -> None:
    """Angles over ±LIMIT (the quadrant boundaries and tiny angles included): each cosine
    and sine within one unit in the last place of numpy's (libm's)."""
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.uniform(-4.0, 4.0, 100_000), rng.uniform(-LIMIT, LIMIT, 100_000),
                        np.arange(-40, 41) * (np.pi / 4), [0.0, -0.0, 1e-300, -1e-9, 3e-8]])
    c, s = np.empty_like(x), np.empty_like(x)
    sincos_rows(x, c, s)
    for got, want in ((c, np.cos(x)), (s, np.sin(x))):
        assert np.all(np.abs(got - want) <= np.spacing(np.abs(want))), np.abs(got - want).max()


def test_angles_beyond_the_limit_and_not_finite_are_libms() -> None:
    x = np.array([0.5, 3.0 * LIMIT, -1e300, np.inf, np.nan, 2.0])
    c, s = np.empty_like(x), np.empty_like(x)
    sincos_rows(x, c, s)
    with np.errstate(invalid="ignore"):
        np.testing.assert_array_equal(c[1:5], np.cos(x[1:5]))
        np.testing.assert_array_equal(s[1:5], np.sin(x[1:5]))
    np.testing.assert_allclose([c[0], s[0], c[5], s[5]],
                               [np.cos(0.5), np.sin(0.5), np.cos(2.0), np.sin(2.0)],
                               rtol=3e-16)
