"""Unit tests of flexlink.motion: analytic profiles, sequences and measured motion."""

from __future__ import annotations

import math

import numpy as np
import pytest

from flexlink.model import JointMotion
from flexlink.motion import Cycloidal, Hold, MeasuredMotion, Quintic, Sequence, Spinup

PROFILES = [
    Cycloidal(10.0, 100.0, 0.5, 1.5),
    Quintic(-20.0, 45.0, 0.25, 0.8),
    Spinup(180.0, 0.3, 1.2, from_deg=15.0),
    Hold(30.0),
    Sequence((Quintic(0.0, 90.0, 0.2, 1.0), Cycloidal(90.0, -30.0, 1.5, 0.7),
              Spinup(-120.0, 2.4, 0.5, from_deg=-30.0))),
]


def _central(motion: JointMotion, t: np.ndarray, h: float = 1e-5) -> tuple[np.ndarray, ...]:
    """Central differences of angle (→ rate) and rate (→ acceleration)."""
    ap, rp, _ = motion.evaluate(t + h)
    am, rm, _ = motion.evaluate(t - h)
    return (ap - am) / (2 * h), (rp - rm) / (2 * h)


def _away_from_kinks(motion: JointMotion, t: np.ndarray, gap: float = 1e-4) -> np.ndarray:
    """Drop times next to segment boundaries, where the acceleration may jump."""
    segs = motion.segments if isinstance(motion, Sequence) else (motion,)
    edges = [e for s in segs if hasattr(s, "start") for e in (s.start, s.end)]
    keep = np.ones(t.shape, bool)
    for e in edges:
        keep &= np.abs(t - e) > gap
    return t[keep]


@pytest.mark.parametrize("motion", PROFILES, ids=lambda m: type(m).__name__)
def test_derivatives_match_finite_differences(motion: JointMotion) -> None:
    assert isinstance(motion, JointMotion)
    t = _away_from_kinks(motion, np.linspace(0.0, 3.5, 2001))
    _angle, rate, acc = motion.evaluate(t)
    fd_rate, fd_acc = _central(motion, t)
    rate_scale = max(1.0, np.abs(rate).max())
    acc_scale = max(1.0, np.abs(acc).max())
    np.testing.assert_allclose(rate, fd_rate, rtol=0, atol=1e-7 * rate_scale)
    np.testing.assert_allclose(acc, fd_acc, rtol=0, atol=1e-6 * acc_scale)


@pytest.mark.parametrize("motion", PROFILES, ids=lambda m: type(m).__name__)
def test_shapes_and_scalars(motion: JointMotion) -> None:
    for t in (0.7, np.float64(0.7), np.zeros((2, 3)) + 0.7, np.array([], float)):
        out = motion.evaluate(t)
        assert all(o.shape == np.shape(t) and o.dtype == float for o in out)
    a, r, c = motion.evaluate(0.7)
    grid = motion.evaluate(np.array([0.1, 0.7]))
    assert (a, r, c) == (grid[0][1], grid[1][1], grid[2][1])


@pytest.mark.parametrize("cls", [Cycloidal, Quintic])
def test_rest_to_rest_end_conditions(cls: type) -> None:
    move = cls(from_deg=-30.0, to_deg=60.0, start=1.0, duration=0.5)
    t = np.array([0.0, 1.0, 1.5, 2.0, 10.0])
    angle, rate, acc = move.evaluate(t)
    th0, th1 = math.radians(-30.0), math.radians(60.0)
    assert list(angle) == [th0, th0, th1, th1, th1]  # exact
    assert np.all(rate == 0.0) and np.all(acc == 0.0)
    # just inside the move the rate and acceleration vanish continuously
    _, r, c = move.evaluate(np.array([1.0 + 1e-7, 1.5 - 1e-7]))
    assert np.all(np.abs(r) < 1e-9) and np.all(np.abs(c) < 1e-4)
    # midpoint: half-way, peak rate
    a_mid, r_mid, c_mid = move.evaluate(1.25)
    assert a_mid == pytest.approx(0.5 * (th0 + th1), abs=1e-14)
    peak = {Cycloidal: 2.0, Quintic: 1.875}[cls] * (th1 - th0) / 0.5
    assert r_mid == pytest.approx(peak, rel=1e-12)
    assert c_mid == pytest.approx(0.0, abs=1e-12)


def test_spinup_formula_and_constant_rate_after() -> None:
    omega, T, start, th0 = math.radians(90.0), 2.0, 0.5, math.radians(10.0)
    spin = Spinup(90.0, start, T, from_deg=10.0)
    s = np.linspace(0.0, T, 101)
    angle, rate, acc = spin.evaluate(start + s)
    phase, k = 2 * np.pi * s / T, T / (2 * np.pi)
    np.testing.assert_allclose(rate, omega / T * (s - k * np.sin(phase)), rtol=1e-12, atol=1e-15)
    expected = th0 + omega / T * (s**2 / 2 + k**2 * (np.cos(phase) - 1))
    np.testing.assert_allclose(angle, expected, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(acc, omega / T * (1 - np.cos(phase)), atol=1e-14)
    # after T: rate Ω, zero acceleration, angle continuous then linear
    after = start + T + np.array([0.0, 1e-9, 1.0, 5.0])
    a, r, c = spin.evaluate(after)
    assert r[1:] == pytest.approx(omega, rel=1e-15) and np.all(c[1:] == 0.0)
    assert a[0] == pytest.approx(th0 + omega * T / 2, rel=1e-14)
    assert a[1] - a[0] == pytest.approx(omega * 1e-9, abs=1e-14)
    np.testing.assert_allclose(a[2:], th0 + omega * T / 2 + omega * (after[2:] - start - T))
    # before start: θ0 at rest
    a, r, c = spin.evaluate(np.array([0.0, start]))
    assert list(a) == [th0, th0] and np.all(r == 0) and np.all(c == 0)


def test_hold_is_constant() -> None:
    a, r, c = Hold(45.0).evaluate(np.linspace(0, 1, 5))
    assert np.all(a == math.radians(45.0)) and np.all(r == 0) and np.all(c == 0)


def test_sequence_semantics() -> None:
    first, second = Cycloidal(0.0, 90.0, 1.0, 1.0), Quintic(90.0, 30.0, 3.0, 2.0)
    spin = Spinup(60.0, 6.0, 1.0, from_deg=30.0)
    seq = Sequence((first, second, spin))
    t = np.array([0.0, 0.5, 1.5, 2.5, 3.0, 4.0, 5.5, 6.5, 9.0])
    expected = [first, first, first, first, second, second, second, spin, spin]
    got = seq.evaluate(t)
    for k, (tk, seg) in enumerate(zip(t, expected, strict=True)):
        for g, e in zip(got, seg.evaluate(tk), strict=True):
            assert g[k] == e
    assert got[1][-1] == pytest.approx(math.radians(60.0))  # still spinning at the end
    single = Sequence((Quintic(5.0, 10.0, 0.0, 1.0),))
    np.testing.assert_array_equal(single.evaluate(t), Quintic(5.0, 10.0, 0.0, 1.0).evaluate(t))
    held = Sequence([Hold(20.0), Cycloidal(20.0, 40.0, 1.0, 1.0)])
    assert held.evaluate(0.5)[0] == math.radians(20.0)
    assert isinstance(held.segments, tuple)


@pytest.mark.parametrize("segments, message", [
    ((Cycloidal(0, 90, 0, 1), Quintic(45, 0, 1, 1)),
     r"motion\[1\]\.from_deg = 45 does not continue from the end of motion\[0\] \(90 deg\)"),
    ((Hold(10), Cycloidal(0, 90, 0, 1)),
     r"motion\[1\]\.from_deg = 0 does not continue from the end of motion\[0\] \(10 deg\)"),
    ((Cycloidal(0, 90, 0, 1), Quintic(90, 0, 1, 1), Spinup(10, 3, 1, from_deg=1)),
     r"motion\[2\]\.from_deg = 1 .*motion\[1\] \(0 deg\)"),
    ((Cycloidal(0, 90, 0, 1), Quintic(90, 0, 0.5, 1)),
     r"motion\[1\] starts at 0.5 s, before motion\[0\] ends"),
    ((Cycloidal(0, 90, 2, 1), Quintic(90, 0, 0, 1)), r"sorted by start: motion\[1\]"),
    ((Spinup(10, 0, 1), Cycloidal(0, 90, 2, 1)), r"motion\[0\] is a Spinup.*only the last"),
    ((Cycloidal(0, 90, 0, 1), Hold(90)), r"motion\[1\] is a Hold"),
    ((), r"at least one segment"),
])
def test_sequence_validation(segments: tuple, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        Sequence(segments)


def test_sequence_tolerates_round_off() -> None:
    Sequence((Cycloidal(0, 0.1 + 0.2, 0, 0.1 + 0.2), Quintic(0.3, 0, 0.3, 1)))


@pytest.mark.parametrize("build, message", [
    (lambda: Cycloidal(0, 90, 0, -1), "duration must be > 0 s, got -1"),
    (lambda: Quintic(0, 90, -0.5, 1), "start must be >= 0 s, got -0.5"),
    (lambda: Cycloidal(float("nan"), 90, 0, 1), "from_deg must be finite"),
    (lambda: Quintic(0, math.inf, 0, 1), "to_deg must be finite"),
    (lambda: Spinup(90, 0, 0), "duration must be > 0 s, got 0"),
    (lambda: Spinup(90, 0, 1, from_deg="x"), "from_deg must be a number"),
    (lambda: Hold(math.nan), "angle_deg must be finite"),
])
def test_constructor_validation(build, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        build()


# --- measured motion -------------------------------------------------------------------------

REFERENCE = Cycloidal(0.0, 90.0, 0.5, 2.0)


def _sampled(fs: float = 1000.0, t_end: float = 3.0) -> tuple[np.ndarray, np.ndarray]:
    t = np.arange(round(t_end * fs) + 1) / fs
    return t, np.degrees(REFERENCE.evaluate(t)[0])


def test_measured_reproduces_smooth_profile() -> None:
    t, deg = _sampled()
    motion = MeasuredMotion.from_arrays(t, deg, name="cyc")
    assert isinstance(motion, JointMotion)
    assert motion.time_range == (0.0, 3.0)
    # away from the ends and from the jerk discontinuities of the cycloid at 0.5 s and 2.5 s
    tq = np.linspace(0.6, 2.4, 777)
    got, ref = motion.evaluate(tq), REFERENCE.evaluate(tq)
    np.testing.assert_allclose(got[0], ref[0], atol=1e-12)
    np.testing.assert_allclose(got[1], ref[1], atol=1e-8)
    np.testing.assert_allclose(got[2], ref[2], atol=1e-5 * np.abs(ref[2]).max())
    # whole range (including the kinks and the ends) still close
    tq = np.linspace(0.0, 3.0, 1001)
    got, ref = motion.evaluate(tq), REFERENCE.evaluate(tq)
    np.testing.assert_allclose(got[0], ref[0], atol=1e-9)
    np.testing.assert_allclose(got[2], ref[2], atol=1e-2 * np.abs(ref[2]).max())


@pytest.mark.parametrize("jitter, acc_tol", [(0.0, 0.05), (0.05, 0.2)])
def test_lowpass_removes_200hz_keeps_1hz(jitter: float, acc_tol: float) -> None:
    rng = np.random.default_rng(1)
    t = np.arange(3001) / 1000.0
    # jittered steps are resampled onto a uniform grid first; resampling the 200 Hz content
    # leaks a little of it below the cut-off, hence the looser tolerance (amplitude 395 deg/s²)
    t[1:-1] += jitter * 1e-3 * rng.uniform(-1, 1, t.size - 2)
    clean = 10.0 * np.sin(2 * np.pi * t)
    noisy = clean + 0.5 * np.sin(2 * np.pi * 200.0 * t)
    motion = MeasuredMotion.from_arrays(t, noisy, lowpass_hz=20.0)
    assert motion.time_range == (0.0, 3.0) and motion.lowpass_hz == 20.0
    tq = np.linspace(0.5, 2.5, 801)  # away from the filter's end transients
    angle, rate, acc = motion.evaluate(tq)
    w = 2 * np.pi
    np.testing.assert_allclose(np.degrees(angle), 10.0 * np.sin(w * tq), atol=1e-3)
    np.testing.assert_allclose(np.degrees(rate), 10.0 * w * np.cos(w * tq), atol=1e-2)
    np.testing.assert_allclose(np.degrees(acc), -10.0 * w**2 * np.sin(w * tq), atol=acc_tol)
    unfiltered = MeasuredMotion.from_arrays(t, noisy)
    assert np.abs(np.degrees(unfiltered.evaluate(tq)[1]) - 10 * w * np.cos(w * tq)).max() > 100


def test_lowpass_above_nyquist() -> None:
    t, deg = _sampled(fs=100.0)
    with pytest.raises(ValueError, match="below the Nyquist frequency 50 Hz"):
        MeasuredMotion.from_arrays(t, deg, lowpass_hz=50.0)
    with pytest.raises(ValueError, match="lowpass_hz must be a finite frequency > 0"):
        MeasuredMotion.from_arrays(t, deg, lowpass_hz=-1.0)


def test_evaluation_outside_range_raises() -> None:
    t, deg = _sampled()
    motion = MeasuredMotion.from_arrays(t + 1.0, deg, name="arm")
    outside = r"'arm': t = 0.5 s is outside the measured range \[1, 4\] s"
    with pytest.raises(ValueError, match=outside):
        motion.evaluate(np.array([0.5, 2.0]))
    with pytest.raises(ValueError, match="outside the measured range"):
        motion.evaluate(4.001)
    motion.evaluate(np.array([1.0, 4.0, 4.0 + 1e-13]))  # ends and round-off are fine


@pytest.mark.parametrize("t, a, message", [
    ([0, 1, 2], [0, 1, 2], "at least 4 samples, got 3"),
    ([0, 1, 2, 3], [0, 1, np.nan, 3], r"angle_deg has a non-finite value \(nan\) at sample 2"),
    ([0, 1, 1, 3], [0, 1, 2, 3], r"not strictly increasing at sample 2 \(t = 1 s after 1 s\)"),
    ([0, 1, 2, 3], [0, 1, 2], "time_s has 4 samples but angle_deg has 3"),
])
def test_from_arrays_validation(t: list, a: list, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        MeasuredMotion.from_arrays(np.array(t, float), np.array(a, float))


def test_few_samples_use_a_cubic() -> None:
    motion = MeasuredMotion.from_arrays([0.0, 1.0, 2.0, 3.0], [0.0, 1.0, 8.0, 27.0])
    assert motion.evaluate(1.5)[0] == pytest.approx(math.radians(1.5**3))


def _write(tmp_path, text: str):
    path = tmp_path / "joint.csv"
    path.write_text(text)
    return path


def test_from_csv_reads_columns(tmp_path) -> None:
    t, deg = _sampled(fs=200.0)
    body = "\n".join(f"{a:.17g},{b:.17g},0" for a, b in zip(t, deg, strict=True))
    path = _write(tmp_path, f"# measured on rig 2\ntime, theta ,other\n{body}\n\n")
    motion = MeasuredMotion.from_csv(path, time_column="time", angle_column="theta")
    assert motion.name == "joint" and motion.time_range == (0.0, 3.0)
    np.testing.assert_allclose(motion.evaluate(1.5)[0], REFERENCE.evaluate(1.5)[0], atol=1e-9)


@pytest.mark.parametrize("text, message", [
    ("t,theta\n0,0\n1,1\n2,2\n3,3\n", r"joint.csv: no column 'angle'; available columns: t, theta"),
    ("t,angle\n0,0\n1,1\n0.5,2\n3,3\n", r"joint.csv: time is not strictly increasing at line 4 "),
    ("t,angle\n0,0\n1,nan\n2,2\n3,3\n",
     r"joint.csv: column 'angle' has a non-finite value \(nan\) at line 3"),
    ("t,angle\n0,0\n1,\n2,2\n3,3\n",
     r"joint.csv: line 3, column 'angle': cannot read '' as a number"),
    ("t,angle\n0,0\n1\n2,2\n3,3\n", r"joint.csv: line 3 has 1 fields"),
    ("", "empty file"),
])
def test_from_csv_errors(tmp_path, text: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        MeasuredMotion.from_csv(_write(tmp_path, text))


def test_breakpoints_are_where_the_acceleration_jumps() -> None:
    from flexlink.motion import Cycloidal, Hold, Quintic, Sequence, Spinup

    assert Cycloidal(0.0, 10.0, 0.5, 1.0).breakpoints == (0.5, 1.5)
    assert Quintic(0.0, 10.0, 0.2, 0.3).breakpoints == (0.2, 0.5)
    assert Spinup(10.0, 1.0, 2.0).breakpoints == (1.0, 3.0)
    assert Hold(5.0).breakpoints == ()
    seq = Sequence((Hold(0.0), Cycloidal(0.0, 10.0, 0.5, 1.0), Cycloidal(10.0, 0.0, 1.5, 1.0)))
    assert seq.breakpoints == (0.5, 1.5, 2.5)


def test_a_sequence_of_something_else_than_segments_is_a_type_error() -> None:
    from flexlink.motion import Cycloidal, Sequence

    with pytest.raises(TypeError, match=r"motion\[1\] must be a Cycloidal.*got float"):
        Sequence((Cycloidal(0.0, 1.0, 0.0, 1.0), 2.0))
