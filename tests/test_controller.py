"""Virtual controller: path extents for the travel check, real-time playback, and whole runs."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from ipo.period import PeriodBatch
from ipr.entities import Arc, Line, Nurbs, Rapid
from machine.drive import Drive, DriveLimits
from machine.extents import arc_extent, nurbs_extent, travel_violations
from machine.realtime import Player
from machine.trace import MemoryTrace

ROOT = Path(__file__).resolve().parents[1]


def arc_samples(arc: Arc, n=200001):
    """Brute-force reference: the arc sampled densely from its own definition."""
    from ipr.entities import PLANE_AXES

    a, b, nn = PLANE_AXES[arc.plane]
    r = arc.radius_mm
    a0 = math.atan2(arc.start[b] - arc.center[b], arc.start[a] - arc.center[a])
    t = np.linspace(0, 1, n)
    ang = a0 + arc.sweep_rad * t
    p = np.zeros((n, 3))
    p[:, a] = arc.center[a] + r * np.cos(ang)
    p[:, b] = arc.center[b] + r * np.sin(ang)
    p[:, nn] = arc.start[nn] + (arc.end[nn] - arc.start[nn]) * t
    return p


@pytest.mark.parametrize("arc", [
    Arc(1, (10, 0, 0), (0, 10, 0), (0, 0, 0), "XY", True, 10.0),  # quarter, no interior extreme
    Arc(2, (10, 0, 0), (0, -10, 0), (0, 0, 0), "XY", True, 10.0),  # three quarters ccw: passes +Y, -X
    Arc(3, (0, 10, 0), (10, 0, 0), (0, 0, 0), "XY", False, 10.0),  # cw quarter
    Arc(4, (3, 1, 2), (3, 6, 2), (0, 1, 2), "ZX", True, 10.0, turns=1),  # helix with a full extra turn
    Arc(5, (5, 2, 5), (5, 7, 0), (5, 2, 0), "YZ", False, 10.0),  # G19 cw
    Arc(6, (-1, 1, 0), (1, 1, 0), (0, 0, 0), "XY", False, 10.0),  # cw across the top
])
def test_arc_extent_is_exact(arc):
    lo, hi = arc_extent(arc)
    p = arc_samples(arc)
    np.testing.assert_allclose(lo, p.min(axis=0), atol=1e-8)
    np.testing.assert_allclose(hi, p.max(axis=0), atol=1e-8)


def test_nurbs_extent_uses_the_curve_when_the_hull_leaves_the_travel():
    # quarter circle of radius 10 as a rational quadratic: the hull corner (10, 10) lies beyond the curve
    w = math.sqrt(0.5)
    curve = Nurbs(9, 2, np.array([0, 0, 0, 1, 1, 1.0]), np.array([1, w, 1.0]),
                  np.array([[10, 0, 0], [10, 10, 0], [0, 10, 0.0]]), 10.0)
    lo, hi = nurbs_extent(curve, np.full(3, -100.0), np.full(3, 100.0))
    assert hi.tolist() == [10, 10, 0]  # hull inside the travel: the hull is enough
    lo, hi = nurbs_extent(curve, np.full(3, -100.0), np.full(3, 9.99))
    np.testing.assert_allclose(hi[:2], [10, 10], atol=1e-9)  # the circle reaches 10 at its ends
    curve_mid = Nurbs(9, 2, np.array([0, 0, 0, 1, 1, 1.0]), np.array([1, w, 1.0]),
                      np.array([[-7.0710678, 7.0710678, 0], [0, 14.1421356, 0], [7.0710678, 7.0710678, 0]]), 10.0)
    lo, hi = nurbs_extent(curve_mid, np.full(3, -100.0), np.full(3, 12.0))
    assert hi[1] == pytest.approx(10.0, abs=1e-6)  # top of the circle, not the hull's 14.14
    assert not travel_violations([curve_mid], np.full(3, -100.0), np.full(3, 12.0))


def test_travel_violations_name_every_line_axis_and_side():
    moves = [Rapid(3, (0, 0, 0), (0, 0, 5)), Line(4, (0, 0, 5), (120, 0, -60), 10.0),
             Arc(5, (0, 0, 0), (0, 0, 0), (-50, 0, 0), "XY", True, 10.0)]
    got = travel_violations(moves, np.array([-90.0, -100, -50]), np.array([100.0, 100, 100]))
    assert got == [(4, "X reaches 120.0000 mm, above the travel limit 100.0000 mm"),
                   (4, "Z reaches -60.0000 mm, below the travel limit -50.0000 mm"),
                   (5, "X reaches -100.0000 mm, below the travel limit -90.0000 mm")]


def limits(blu=1e-3, amax=1000.0):
    return DriveLimits(1e-3, blu, np.full(3, 100.0), np.full(3, amax), np.full(3, 1e5),
                       np.full(3, -500.0), np.full(3, 500.0))


def line_stream(length_mm=30.0, speed=50.0, blu=1e-3, size=500):
    """A move along X at constant speed, quantised, in batches."""
    n = int(round(length_mm / (speed * 1e-3)))
    x = speed * 1e-3 * np.arange(1, n + 1)
    blu_pos = np.rint(np.column_stack((x, 0.5 * x, np.zeros(n))) / blu).astype(np.int64)
    inc = np.diff(np.vstack((np.zeros((1, 3), np.int64), blu_pos)), axis=0)
    feed = math.hypot(speed, speed / 2)
    return [PeriodBatch(blu_pos[i:i + size] * blu, inc[i:i + size], np.full(len(inc[i:i + size]), feed),
                        np.zeros(len(inc[i:i + size]), np.int8), np.full(len(inc[i:i + size]), 11, np.int32))
            for i in range(0, n, size)]


class FakeClock:
    """Time moves only when the player sleeps (or by `per_call` on every reading)."""

    def __init__(self, per_call=0.0):
        self.now, self.per_call, self.slept = 0.0, per_call, 0.0

    def __call__(self):
        self.now += self.per_call
        return self.now

    def sleep(self, s):
        self.now += s
        self.slept += s


def play(stream, keys=lambda: "", clock=None):
    clock = clock or FakeClock()
    mem = MemoryTrace({})
    drive = Drive(limits(), sinks=[mem])
    player = Player(keys=keys, clock=clock, sleep=clock.sleep)
    player.attach(drive)
    for b in stream:
        player.play(b)
        if player.stopped:
            break
    else:
        player.flush()
    return player, drive, mem.close(), clock


def test_realtime_playback_at_full_scale_is_the_planned_stream():
    stream = line_stream()
    player, drive, trace, clock = play(stream)
    planned = np.vstack([b.inc_blu for b in stream])
    assert np.array_equal(trace["inc_blu"], planned)
    assert player.deadline_misses == 0
    # paced: the drive starts after the 0.1 s lead, then takes one period per millisecond
    player.detach()
    assert clock.slept == pytest.approx(len(planned) * 1e-3 + 0.1, abs=1e-9)


def test_feed_hold_ramps_down_stands_and_resumes_to_the_same_end():
    presses = iter(["", "", "", " "] + [""] * 30 + [" "])
    player, drive, trace, _ = play(line_stream(), keys=lambda: next(presses, ""))
    planned_end = np.rint(np.array([30.0, 15.0, 0.0]) / 1e-3)
    assert np.array_equal(drive.position_blu, planned_end)
    speed = np.linalg.norm(trace["inc_blu"], axis=1) * 1e-3 / 1e-3
    still = np.nonzero(speed == 0)[0]
    assert len(still) > 100  # stood for a while
    # the hold ramp takes the path speed v to 0 at 0.5·a_min: v / 500 mm/s² periods
    first_still = still[0]
    ramp = np.nonzero(speed[:first_still] < 0.999 * math.hypot(50, 25))[0]
    assert len(ramp) == pytest.approx(math.hypot(50, 25) / 500 / 1e-3, abs=3)
    assert drive.stats.accel_violations == 0
    assert len(trace) > len(np.vstack([b.inc_blu for b in line_stream()]))


def test_stop_key_ends_the_run_at_standstill_before_the_end():
    presses = iter(["", "", "s"])
    player, drive, trace, _ = play(line_stream(), keys=lambda: next(presses, ""))
    assert player.stopped
    assert 0 < drive.position_mm[0] < 30.0
    assert np.all(trace["inc_blu"][-1] == 0)


def test_late_production_counts_deadline_misses():
    # every clock reading costs 20 ms: producing a 20 ms chunk takes 40 ms
    player, drive, _, _ = play(line_stream(length_mm=10.0), clock=FakeClock(per_call=0.02))
    assert 0 < player.deadline_misses <= drive.stats.periods
