"""Input shapers (flexlink.motion.shapers), the Shaped and Harmonic profiles, their scenario
keys: against the closed forms of Singer & Seering (1990) and finite differences."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexlink.model import JointMotion
from flexlink.motion import Cycloidal, Harmonic, Quintic, Shaped
from flexlink.motion.shapers import ImpulseSequence, design, ei, residual_vibration, zv, zvd
from flexlink.scenario import ScenarioError, scenario_from_dict
from tests.unit.test_scenario import minimal

DAMPINGS = [0.0, 0.02, 0.1]


@pytest.mark.parametrize("zeta", DAMPINGS)
@pytest.mark.parametrize("kind", ["zv", "zvd", "ei"])
def test_amplitudes_sum_to_one_and_times_follow_the_period(kind: str, zeta: float) -> None:
    s = design(kind, [2.0], zeta)
    assert math.isclose(sum(s.amplitudes), 1.0, abs_tol=1e-12)
    assert all(a > 0 for a in s.amplitudes)
    period = 1.0 / (2.0 * math.sqrt(1 - zeta**2))
    assert s.duration == pytest.approx(period / 2 if kind == "zv" else period, rel=0.01)


@pytest.mark.parametrize("zeta", DAMPINGS)
def test_zv_and_zvd_cancel_the_design_mode(zeta: float) -> None:
    for s in (zv(3.0, zeta), zvd(3.0, zeta)):
        assert residual_vibration(s, 3.0, zeta) < 1e-12
    # ZVD's zero is of second order: V ~ (Δω)², its slope at the design frequency is zero
    s = zvd(3.0, zeta)
    h = 1e-4
    v = residual_vibration(s, np.array([3.0 - h, 3.0 + h]), zeta)
    assert np.all(v < 1e-6)
    ratio = residual_vibration(s, 3.0 * 1.02, zeta) / residual_vibration(s, 3.0 * 1.01, zeta)
    assert ratio == pytest.approx(4.0, rel=0.02)


def test_undamped_curves_equal_the_closed_forms() -> None:
    """V_ZV = |cos(π ω / 2ω_m)|, V_ZVD = cos²(π ω / 2ω_m) (Singer & Seering 1990)."""
    ratio = np.linspace(0.5, 1.5, 201)
    closed = np.abs(np.cos(0.5 * np.pi * ratio))
    np.testing.assert_allclose(residual_vibration(zv(2.0), 2.0 * ratio), closed, atol=1e-12)
    np.testing.assert_allclose(residual_vibration(zvd(2.0), 2.0 * ratio), closed**2, atol=1e-12)
    # the textbook numbers: ZV leaves 15.6 % at ±10 %, ZVD 2.4 %
    assert residual_vibration(zv(2.0), 2.2) == pytest.approx(0.156, abs=0.001)
    assert residual_vibration(zvd(2.0), 2.2) == pytest.approx(0.0245, abs=0.001)


@pytest.mark.parametrize("zeta", DAMPINGS)
def test_ei_holds_its_tolerable_vibration(zeta: float) -> None:
    s = ei(2.0, zeta, 0.05)
    assert residual_vibration(s, 2.0, zeta) == pytest.approx(0.05, abs=1e-9)
    h = 1e-4
    v = residual_vibration(s, np.array([2.0 - h, 2.0 + h]), zeta)
    assert abs(v[1] - v[0]) / (2 * h) < 1e-4  # a flat top at the design frequency
    f = np.linspace(1.4, 2.6, 1201)  # zeros on both sides, V ≤ 5 % in between
    v = residual_vibration(s, f, zeta)
    low = np.argmin(np.where(f < 2.0, v, np.inf))
    high = np.argmin(np.where(f > 2.0, v, np.inf))
    assert v[low] < 1e-3 and v[high] < 1e-3
    assert v[low:high + 1].max() <= 0.05 + 1e-9
    # wider than ZVD: at ±15 % EI stays below ZVD
    assert residual_vibration(s, 2.3, zeta) < residual_vibration(zvd(2.0, zeta), 2.3, zeta)


def test_undamped_ei_is_the_textbook_sequence() -> None:
    s = ei(1.0, 0.0, 0.05)
    np.testing.assert_allclose(s.amplitudes, [0.2625, 0.475, 0.2625])
    np.testing.assert_allclose(s.times, [0.0, 0.5, 1.0])


def test_multi_mode_shapers_are_convolutions() -> None:
    s = design("zv", [2.0, 5.0], [0.01, 0.02])
    assert len(s.times) == 4 and math.isclose(sum(s.amplitudes), 1.0)
    for f, z in ((2.0, 0.01), (5.0, 0.02)):
        assert residual_vibration(s, f, z) < 1e-12
    # the curve of a convolution is the product of the curves
    f = np.linspace(1.0, 6.0, 50)
    np.testing.assert_allclose(residual_vibration(s, f, 0.01),
                               residual_vibration(zv(2.0, 0.01), f, 0.01)
                               * residual_vibration(zv(5.0, 0.02), f, 0.01), rtol=1e-9)


@pytest.mark.parametrize(("call", "message"), [
    (lambda: design("zz", [2.0]), "shaper must be one of 'zv', 'zvd', 'ei'"),
    (lambda: design("zv", [-2.0]), "frequencies_hz must be > 0 Hz"),
    (lambda: design("zv", [2.0], 1.0), r"damping must be in \[0, 1\)"),
    (lambda: design("zv", [2.0, 3.0], [0.1, 0.1, 0.1]), "one ratio per frequency"),
    (lambda: ei(2.0, 0.0, 0.0), r"tolerable_vibration must be in \(0, 1\)"),
    (lambda: ImpulseSequence((0.5, 0.4), (0.0, 1.0)), "must sum to 1"),
])
def test_bad_shapers_are_refused(call, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()


MOTIONS = [Shaped(Cycloidal(10.0, 100.0, 0.3, 0.8), design("zvd", [2.0, 5.0], 0.02)),
           Shaped(Quintic(-20.0, 30.0, 0.0, 0.5), ei(3.0, 0.05)),
           Harmonic(10.0, 100.0, 0.3, 0.8, (0.3, -0.2, 0.1), (0.2, 0.05))]


def _kinks(motion: object) -> list[float]:
    if isinstance(motion, Shaped):
        return list(motion.breakpoints)
    return [motion.start, motion.end]  # type: ignore[attr-defined]


@pytest.mark.parametrize("motion", MOTIONS, ids=lambda m: type(m).__name__)
def test_rate_and_acceleration_match_finite_differences(motion: JointMotion) -> None:
    assert isinstance(motion, JointMotion)
    t = np.linspace(0.0, 2.5, 3001)
    for e in _kinks(motion):
        t = t[np.abs(t - e) > 1e-4]
    h = 1e-5
    _, rate, acc = motion.evaluate(t)
    ap, rp, _ = motion.evaluate(t + h)
    am, rm, _ = motion.evaluate(t - h)
    np.testing.assert_allclose(rate, (ap - am) / (2 * h), atol=1e-7 * np.abs(rate).max())
    np.testing.assert_allclose(acc, (rp - rm) / (2 * h), atol=1e-6 * np.abs(acc).max())


@pytest.mark.parametrize("motion", MOTIONS, ids=lambda m: type(m).__name__)
def test_end_angles_and_rest_at_both_ends(motion) -> None:
    before = motion.evaluate(np.array([0.0, motion.start]))
    after = motion.evaluate(np.array([motion.end, motion.end + 1.0]))
    np.testing.assert_allclose(before[0], math.radians(motion.from_deg), atol=1e-12)
    np.testing.assert_allclose(after[0], math.radians(motion.to_deg), atol=1e-12)
    for state in (before, after):
        np.testing.assert_allclose(state[1:], 0.0, atol=1e-9)


def test_shaped_end_and_breakpoints() -> None:
    s = design("zv", [2.0])
    m = Shaped(Cycloidal(0.0, 90.0, 0.5, 1.0), s)
    assert m.end == pytest.approx(1.5 + 0.25)
    assert m.breakpoints == (0.5, 0.75, 1.5, 1.75)


def _scenario_with(segment: dict) -> dict:
    d = minimal()
    d["joints"][0]["motion"] = [segment]
    return d


def test_shaped_and_harmonic_profiles_load() -> None:
    d = _scenario_with({"profile": "shaped", "shaped": "cycloidal", "from_deg": 0,
                        "to_deg": 30, "start": 0.1, "duration": 0.5, "shaper": "zvd",
                        "frequencies_hz": [2.0, 6.0], "damping": [0.01]})
    motion = scenario_from_dict(d).chain.joints[0]
    assert isinstance(motion, Shaped)
    assert motion.shaper == design("zvd", [2.0, 6.0], 0.01)
    d = _scenario_with({"profile": "harmonic", "from_deg": 0, "to_deg": 30, "start": 0.1,
                        "duration": 0.5, "sine": [0.2]})
    assert scenario_from_dict(d).chain.joints[0] == Harmonic(0.0, 30.0, 0.1, 0.5, (), (0.2,))


def test_bad_shaper_keys_name_the_field() -> None:
    d = _scenario_with({"profile": "shaped", "shaped": "linear", "from_deg": 0, "to_deg": 30,
                        "start": 0.1, "duration": 0.5, "shaper": "zx",
                        "frequencies_hz": [-1.0, 2.0], "damping": [1.5, 0.0, 0.0]})
    with pytest.raises(ScenarioError) as info:
        scenario_from_dict(d)
    text = str(info.value)
    for part in ("joints[0].motion[0].shaped must be one of 'cycloidal', 'quintic'",
                 "joints[0].motion[0].shaper must be one of 'zv', 'zvd', 'ei'",
                 "joints[0].motion[0].frequencies_hz[0] must be > 0 Hz, got -1.0",
                 "joints[0].motion[0].damping[0] must be in [0, 1)",
                 "joints[0].motion[0].damping: give one damping ratio per frequency (2)"):
        assert part in text
    d = _scenario_with({"profile": "shaped", "shaped": "cycloidal", "from_deg": 0,
                        "to_deg": 30, "start": 0.1, "duration": 0.5, "shaper": "zv"})
    with pytest.raises(ScenarioError, match="missing required key 'frequencies_hz'"):
        scenario_from_dict(d)
