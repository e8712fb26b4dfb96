"""Simulated drive, servo model and trace files against analytic streams."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ipo.contracts import LIMIT_CURVATURE, PeriodBatch
from machine.drive import CommandMismatchError, Drive, DriveLimits, TravelLimitError
from machine.servo import ServoModel
from machine.trace import MemoryTrace, load_trace, open_writer


def limits(period_s=1e-3, blu_mm=1e-4, vmax=200.0, amax=5000.0, lo=-100.0, hi=100.0):
    return DriveLimits(period_s, blu_mm, np.full(3, vmax), np.full(3, amax), np.full(3, 1e6),
                       np.full(3, lo), np.full(3, hi))


def batches(points_mm, blu_mm, start_mm=(0, 0, 0), size=1000, line=7, feed=50.0):
    """Quantise independently (round, remainder carried by construction) and cut into batches."""
    pos_blu = np.rint(np.asarray(points_mm) / blu_mm).astype(np.int64)
    prev = np.rint(np.asarray(start_mm, dtype=float) / blu_mm).astype(np.int64)
    inc = np.diff(np.vstack((prev, pos_blu)), axis=0)
    n = len(points_mm)
    for i in range(0, n, size):
        s = slice(i, min(n, i + size))
        k = s.stop - s.start
        yield PeriodBatch(pos_blu[s] * blu_mm, inc[s], np.full(k, feed), np.full(k, LIMIT_CURVATURE, np.int8),
                          np.full(k, line, np.int32))


def circle(radius_mm, speed_mm_s, period_s, turns=1.0):
    w = speed_mm_s / radius_mm
    n = int(round(turns * 2 * math.pi / (w * period_s)))
    t = period_s * np.arange(1, n + 1)
    pts = np.column_stack((radius_mm * np.cos(w * t), radius_mm * np.sin(w * t), np.zeros(n)))
    return pts, w, n


def test_circle_measurements_match_the_analytic_values():
    R, v, T, blu = 10.0, 50.0, 1e-3, 1e-4
    pts, w, n = circle(R, v, T)
    lim = limits(T, blu)
    drive = Drive(lim, start_mm=(R, 0, 0))
    for b in batches(pts, blu, start_mm=(R, 0, 0), size=777):
        drive.receive(b)
    st = drive.stats
    theta = w * T
    chord = 2 * R * math.sin(theta / 2)
    assert st.periods == n
    assert np.array_equal(drive.position_blu, np.rint(pts[-1] / blu).astype(np.int64))
    assert st.path_length_mm == pytest.approx(n * chord, abs=n * blu * 0.5)
    # peak axis speed: the largest per-period increment of a rotating chord, plus one BLU
    assert st.max_velocity_mm_s[0] == pytest.approx(chord / T, abs=blu / T)
    h = lim.stencil_periods()
    # the h-period second difference of R·cos(wt) peaks at R·(2 sin(w h T/2))² / (hT)²
    acc = R * (2 * math.sin(w * h * T / 2)) ** 2 / (h * T) ** 2
    assert st.max_accel_mm_s2[:2] == pytest.approx([acc, acc], abs=2 * blu / (h * T) ** 2)
    assert acc == pytest.approx(v * v / R, rel=0.01)
    jerk = R * (2 * math.sin(w * h * T / 2)) ** 3 / (h * T) ** 3
    assert st.max_jerk_mm_s3[:2] == pytest.approx([jerk, jerk], abs=4 * blu / (h * T) ** 3)
    sag = R * (1 - math.cos(theta / 2))
    # the three-point estimate carries the BLU rounding: worst case about a third of a BLU
    assert sag <= st.max_chord_error_mm <= sag + 0.36 * blu
    assert st.velocity_violations == st.accel_violations == 0
    assert st.max_accel_mm_s2[2] == 0 and st.max_contour_error_mm is None


def test_chord_error_estimate_converges_with_a_fine_blu():
    R, v, T, blu = 2.0, 60.0, 1e-3, 1e-7
    pts, w, _ = circle(R, v, T, turns=0.5)
    drive = Drive(limits(T, blu, amax=1e4), start_mm=(R, 0, 0))
    for b in batches(pts, blu, start_mm=(R, 0, 0)):
        drive.receive(b)
    assert drive.stats.max_chord_error_mm == pytest.approx(R * (1 - math.cos(w * T / 2)), rel=0.01)


def test_batch_boundaries_do_not_change_the_measurements():
    pts, _, _ = circle(5.0, 80.0, 1e-3, turns=0.7)
    results = []
    for size in (1, 13, 5000):
        drive = Drive(limits(blu_mm=1e-3), start_mm=(5, 0, 0))
        for b in batches(pts, 1e-3, start_mm=(5, 0, 0), size=size):
            drive.receive(b)
        st = drive.stats
        results.append((st.max_velocity_mm_s, st.max_accel_mm_s2, st.max_jerk_mm_s3, st.max_chord_error_mm,
                        st.accel_violations, st.path_length_mm))
    for other in results[1:]:
        for a, b in zip(results[0], other):
            np.testing.assert_allclose(a, b, rtol=1e-12)


def test_acceleration_limit_violations_are_counted_once():
    # constant acceleration 3000 mm/s² along X for 0.2 s against a 1000 mm/s² limit
    T, blu = 1e-3, 1e-4
    t = T * np.arange(1, 201)
    pts = np.column_stack((0.5 * 3000 * t**2, np.zeros_like(t), np.zeros_like(t)))
    lim = limits(T, blu, vmax=1e4, amax=1000.0)
    h = lim.stencil_periods()
    for size in (200, 7):
        drive = Drive(lim)
        for b in batches(pts, blu, size=size):
            drive.receive(b)
        # stencils x[k-h..k+h] inside the motion, plus the ones starting at the standstill before it
        assert drive.stats.accel_violations == 200 - 2 * h + 1
        assert drive.stats.max_accel_mm_s2[0] == pytest.approx(3000, abs=2 * blu / (h * T) ** 2)


def test_travel_limit_stops_before_the_offending_period():
    T, blu = 1e-3, 1e-3
    x = 0.1 * np.arange(1, 301)  # 100 mm/s along X to 30 mm; limit at 12.05 mm
    pts = np.column_stack((x, np.zeros_like(x), np.zeros_like(x)))
    mem = MemoryTrace({})
    drive = Drive(limits(T, blu, hi=12.05), sinks=[mem])
    with pytest.raises(TravelLimitError) as err:
        for b in batches(pts, blu, size=50, line=42):
            drive.receive(b)
    assert err.value.axis == 0 and err.value.line == 42
    assert err.value.value_mm == pytest.approx(12.1) and err.value.limit_mm == 12.05
    assert "line 42" in str(err.value) and "X 12.1000 mm is above" in str(err.value)
    assert drive.stats.periods == 120
    assert drive.position_mm[0] == pytest.approx(12.0)
    assert len(mem.close()) == 120


def test_pos_mm_must_match_the_increments():
    b = PeriodBatch(np.array([[1.0, 0, 0]]), np.array([[2, 0, 0]]), np.array([1.0]),
                    np.zeros(1, np.int8), np.array([3], np.int32))
    with pytest.raises(CommandMismatchError, match="line 3"):
        Drive(limits(blu_mm=0.1)).receive(b)


def test_a_straight_line_has_no_chord_error():
    blu = 1e-4
    k = np.arange(1, 401)[:, None]
    pts = k * np.array([0.01, 0.02, 0.0])  # 100 and 200 BLU a period: every chord counts
    drive = Drive(limits(blu_mm=blu))
    for b in batches(pts, blu):
        drive.receive(b)
    assert drive.stats.periods == 400 and drive.stats.max_chord_error_mm == 0.0


def test_lag_servo_ramp_following_error_is_v_tau():
    tau, T, v = 0.02, 1e-3, 30.0
    n = 400
    cmd = np.column_stack((v * T * np.arange(1, n + 1), np.zeros(n), np.zeros(n)))
    servo = ServoModel.lag(tau, T, (0, 0, 0))
    actual, contour = servo.follow(cmd[:150])
    actual2, contour2 = servo.follow(cmd[150:])
    actual = np.vstack((actual, actual2))
    # continuous first-order lag on a ramp from rest: e(t) = v·tau·(1 − exp(−t/tau))
    t = T * np.arange(1, n + 1)
    np.testing.assert_allclose(cmd[:, 0] - actual[:, 0], v * tau * (1 - np.exp(-t / tau)), atol=1e-12)
    assert np.max(np.concatenate((contour, contour2))) < 1e-12  # it lags along the line, not off it


def test_pd_servo_follows_the_pd_law_on_a_ramp():
    kp, kd, T, v = 40.0, 0.75, 1e-3, 20.0
    n = 1000
    t = T * np.arange(1, n + 1)
    cmd = np.column_stack((np.zeros(n), v * t, np.zeros(n)))
    actual, _ = ServoModel.pd(kp, kd, T, (0, 0, 0)).follow(cmd)
    # e' = v − kp·e − kd·e'  =>  e(t) = (v/kp)·(1 − exp(−kp·t/(1 + kd)))
    np.testing.assert_allclose(cmd[:, 1] - actual[:, 1], v / kp * (1 - np.exp(-kp * t / (1 + kd))), atol=1e-12)


def test_lag_servo_on_a_circle_has_the_analytic_contour_error():
    R, v, T, tau = 10.0, 100.0, 1e-3, 0.01
    pts, w, n = circle(R, v, T, turns=3)
    servo = ServoModel.lag(tau, T, (R, 0, 0))
    lim = limits(T, 1e-4, vmax=500, amax=1e5)
    drive = Drive(lim, start_mm=(R, 0, 0), servo=servo)
    mem = MemoryTrace({})
    drive.sinks.append(mem)
    for b in batches(pts, 1e-4, start_mm=(R, 0, 0)):
        drive.receive(b)
    tr = mem.close()
    settled = slice(n // 2, None)
    radius = np.linalg.norm(tr["actual_mm"][settled, :2], axis=1)
    expected = R / math.sqrt(1 + (w * tau) ** 2)  # steady-state gain of 1/(1 + s·tau) at w
    # the polyline command lies inside the circle by up to the sagitta; rounding adds 1e-4
    sag = R * (1 - math.cos(w * T / 2))
    assert radius.mean() == pytest.approx(expected, abs=sag + 1e-4)
    assert np.median(tr["contour_um"][settled]) * 1e-3 == pytest.approx(R - expected, abs=sag + 1e-4)


@pytest.mark.parametrize("suffix", [".npz", ".csv"])
def test_trace_files_round_trip(tmp_path, suffix):
    pts, _, n = circle(4.0, 40.0, 1e-3, turns=0.3)
    lim = limits(blu_mm=1e-3)
    path = tmp_path / f"trace{suffix}"
    writer = open_writer(path, lim.meta(), servo=True)
    mem = MemoryTrace(lim.meta())
    drive = Drive(lim, start_mm=(4, 0, 0), servo=ServoModel.lag(0.005, 1e-3, (4, 0, 0)), sinks=[writer, mem])
    for b in batches(pts, 1e-3, start_mm=(4, 0, 0), size=64):
        drive.receive(b)
    writer.close()
    ref = mem.close()
    got = load_trace(path)
    assert len(got) == n
    assert got.meta["blu_mm"] == 1e-3 and got.meta["max_velocity_mm_s"] == [200.0] * 3
    for name in ("inc_blu", "limit", "line"):
        assert np.array_equal(got[name], ref[name])
        assert got[name].dtype == ref[name].dtype
    for name in ("t_s", "pos_mm", "feed_mm_s", "actual_mm", "contour_um"):
        np.testing.assert_allclose(got[name], ref[name], rtol=1e-8, atol=1e-12)
    assert np.array_equal(np.cumsum(got["inc_blu"], axis=0)[-1] + [4000, 0, 0],
                          np.rint(pts[-1] / 1e-3).astype(int))


def test_unknown_trace_format_is_refused(tmp_path):
    with pytest.raises(ValueError, match="use .npz or .csv"):
        open_writer(tmp_path / "t.txt", {}, servo=False)


def test_creeping_chords_a_few_blu_long_report_no_chord_error():
    # a straight move at 3 µm per period, at an angle the BLU grid cannot follow exactly
    n = 400
    s = 3e-3 * np.arange(1, n + 1)
    pts = np.column_stack((s * math.cos(0.3), s * math.sin(0.3), np.zeros(n)))
    drive = Drive(limits(blu_mm=1e-3))
    for b in batches(pts, 1e-3):
        drive.receive(b)
    assert drive.stats.max_chord_error_mm == 0.0
