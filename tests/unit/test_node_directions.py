"""The node angles' cosines and sines of the compiled nonlinear residual
(`_nonlinear_numba.directions`: a shared rigid angle plus the Taylor series of the elastic
slope) against numpy's cos and sin."""

from __future__ import annotations

import numpy as np

from flexlink.dynamics._nonlinear_numba import SMALL_ANGLE, directions, small_sin_cos


def test_the_series_is_within_an_ulp_of_libm_up_to_the_small_angle() -> None:
    """sin and cos by the series on 2·10⁴ angles in [−SMALL_ANGLE, SMALL_ANGLE] (its ends
    included) within one unit in the last place of numpy's."""
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.uniform(-SMALL_ANGLE, SMALL_ANGLE, 20_000),
                        [0.0, -0.0, 1e-300, SMALL_ANGLE, -SMALL_ANGLE, 1e-8]])
    s, c = np.array([small_sin_cos(v) for v in x]).T
    assert np.all(np.abs(s - np.sin(x)) <= np.spacing(np.abs(np.sin(x))))
    assert np.all(np.abs(c - np.cos(x)) <= np.spacing(np.abs(np.cos(x))))


def test_directions_of_shared_rigid_angles_and_any_slope() -> None:
    """Rigid angles shared by runs of nodes (several turns), slopes small and large (beyond
    SMALL_ANGLE: libm's), NaN: cos and sin of θ + φ to round-off of θ."""
    rng = np.random.default_rng(7)
    theta = np.repeat(rng.uniform(-20.0, 20.0, 6), 5)
    phi = np.concatenate([rng.uniform(-0.4, 0.4, 20), rng.uniform(-3.0, 3.0, 10)])
    rng.shuffle(phi)
    c, s = np.empty(30), np.empty(30)
    directions(theta, phi, c, s)
    tol = 4e-16 * (1.0 + np.abs(theta))
    np.testing.assert_array_less(np.abs(c - np.cos(theta + phi)), tol)
    np.testing.assert_array_less(np.abs(s - np.sin(theta + phi)), tol)
    phi[3] = np.nan
    directions(theta, phi, c, s)
    assert np.isnan(c[3]) and np.isnan(s[3]) and np.all(np.isfinite(np.delete(c, 3)))
