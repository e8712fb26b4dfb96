"""Virtual controller: path extents for the travel check, real-time playback, and whole runs."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ipo.contracts import PeriodBatch
from ipr.entities import Arc, Line, Nurbs, Rapid
from machine.drive import Drive, DriveLimits
from machine.extents import arc_boxes, nurbs_extent
from machine.realtime import Player
from machine.trace import MemoryTrace
from tests.machine.travel_check import travel_violations


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
    (lo,), (hi,) = arc_boxes([arc])
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


# --- whole runs against a synthetic planner (the contract of ipo.feed.planner.plan_periods) ---

def fake_planner(items):
    def planner(entities, config, *, method, feed_override, start_mm):
        for item in items:
            if isinstance(item, Exception) or (isinstance(item, type) and issubclass(item, BaseException)):
                raise item
            yield item
    return planner


def shifted(stream, line):
    return [PeriodBatch(b.pos_mm, b.inc_blu, b.feed_mm_s, b.limit, np.full(len(b), line, np.int32))
            for b in stream]


def program_of(*entities):
    from ipr.entities import Program
    from machine.check import CheckedProgram
    return CheckedProgram.of(Program("t.nc", list(entities)))


def controller(items, **kw):
    from ipo.config import default_config
    from machine.controller import Controller
    return Controller(default_config(), planner=fake_planner(items), **kw)


def test_run_handles_messages_stops_and_program_end():
    from ipr.entities import Message, ProgramEnd, Stop
    first, second = line_stream(10.0, size=100), line_stream(10.0, size=100)
    rest = [PeriodBatch(b.pos_mm + [10, 5, 0], b.inc_blu, b.feed_mm_s, b.limit, b.line) for b in second]
    items = (first + [Message(12, "check tool"), Stop(13, optional=True), Stop(14, optional=False)]
             + rest + [ProgramEnd(20)] + line_stream(5.0))
    asked, events = [], []
    c = controller(items, on_program_stop=lambda s: asked.append(s.line) or True, on_event=events.append)
    result = c.run(program_of(Line(11, (0, 0, 0), (20, 10, 0), 50.0)))
    assert result.state == "completed" and result.line == 20
    assert asked == [14] and result.program_stops == [14]  # M1 is skipped with the optional stop off
    assert result.messages == ["line 12: check tool"] and len(events) == 1
    assert result.periods == 400 and result.position_mm == pytest.approx([20, 10, 0])
    assert result.cycle_time_s == pytest.approx(0.4)
    assert result.path_length_mm == pytest.approx(math.hypot(20, 10), abs=1e-3)
    assert result.deadline_misses is None and result.max_contour_error_um is None
    assert result.summary()["motions"] == 1


def test_answering_stop_at_m0_ends_the_run_there():
    from ipr.entities import Stop
    items = line_stream(10.0, size=100) + [Stop(13, optional=False)] + line_stream(10.0)
    result = controller(items, on_program_stop=lambda s: False).run(program_of(Line(11, (0, 0, 0), (1, 0, 0), 9)))
    assert result.state == "stopped" and result.line == 13 and result.periods == 200


def test_ctrl_c_stops_cleanly_and_says_where():
    items = shifted(line_stream(10.0, size=50), 33)[:3] + [KeyboardInterrupt]
    result = controller(items).run(program_of(Line(33, (0, 0, 0), (1, 0, 0), 9)))
    assert result.state == "interrupted" and result.line == 33 and result.periods == 150
    assert result.position_mm == pytest.approx([7.5, 3.75, 0.0])


def test_a_travel_fault_during_the_run_is_reported_not_raised():
    import dataclasses
    from ipo.config import default_config
    from machine.controller import Controller
    cfg = default_config()
    x = dataclasses.replace(cfg.axes[0], max_mm=5.0)
    c = Controller(dataclasses.replace(cfg, axes=(x, cfg.axes[1], cfg.axes[2])),
                   planner=fake_planner(shifted(line_stream(10.0), 8)))
    result = c.run(program_of(Line(8, (0, 0, 0), (1, 0, 0), 9)))
    assert result.state == "fault" and "line 8: X 5.0500 mm is above the travel limit 5.0000 mm" in result.fault
    assert result.position_mm[0] == pytest.approx(5.0)


def test_a_planner_refusal_during_the_run_is_a_fault_not_a_crash():
    from ipo.errors import NURBS_PATH, IpoError
    items = shifted(line_stream(10.0, size=50), 21)[:2] + [IpoError(NURBS_PATH, "something the checks missed", 23)]
    result = controller(items).run(program_of(Line(21, (0, 0, 0), (1, 0, 0), 9)))
    assert result.state == "fault" and result.periods == 100
    assert result.fault == "the planner stopped at line 23: error[E-NURBS-PATH]: something the checks missed"


def test_a_bug_in_the_planner_is_not_taken_for_a_refusal():
    items = shifted(line_stream(10.0, size=50), 21)[:2] + [ValueError("an index out of range")]
    with pytest.raises(ValueError, match="an index out of range"):
        controller(items).run(program_of(Line(21, (0, 0, 0), (1, 0, 0), 9)))


def test_the_collector_is_held_while_the_run_streams_and_restored_after_a_failure():
    import gc
    seen = []

    def planner(entities, config, *, method, feed_override, start_mm):
        seen.append(gc.isenabled())
        yield from line_stream(10.0, size=10)
        raise ValueError("a bug")

    from ipo.config import default_config
    from machine.controller import Controller
    assert gc.isenabled()
    with pytest.raises(ValueError, match="a bug"):
        Controller(default_config(), planner=planner).run(program_of(Line(21, (0, 0, 0), (1, 0, 0), 9)))
    assert seen == [False] and gc.isenabled()


def test_a_nurbs_the_planner_cannot_walk_is_rejected_before_anything_moves(tmp_path):
    from ipo.config import default_config
    from machine.controller import Controller, ProgramRejected
    # three coincident control points inside a cubic: C'(u) = 0 where the curve passes them (a cusp)
    path = tmp_path / "cusp.nc"
    path.write_text("G21 G90 G17 G64\nG0 X0 Y0 Z0\nG1 X10 F600\nG06.2 P4 K0 X10 Y0 R1 F600\nK0 X15 Y0\n"
                    "K0 X20 Y5\nK0 X20 Y5\nK1 X20 Y5\nK2 X25 Y10\nK3 X30 Y10\nK4\nK4\nK4\nK4\nG1 X40 Y10\nM2\n")
    with pytest.raises(ProgramRejected) as info:
        Controller(default_config()).check(path)
    assert any(":4:1: error[E-NURBS-PATH]: NURBS has a vanishing derivative" in r for r in info.value.reasons)


def test_servo_model_from_the_machine_file_reports_contour_error():
    import dataclasses
    from ipo.config import Servo, default_config
    from machine.controller import Controller
    cfg = dataclasses.replace(default_config(), servo=Servo("lag", time_constant_s=0.01))
    result = Controller(cfg, planner=fake_planner(line_stream(10.0))).run(program_of(Line(1, (0, 0, 0), (1, 0, 0), 9)))
    # a straight line: the axes lag along it, never off it (up to the BLU rounding of the command)
    assert result.max_contour_error_um is not None and result.max_contour_error_um < 1.0


def test_the_machine_file_reaches_the_interpreter(tmp_path):
    import dataclasses
    from ipo.config import Tool, default_config
    from ipr import Setup, parse_text
    from machine.controller import Controller
    text = "G21 G90\nG55 G0 X1 Y2 Z3\nG43 H2 G1 Z0 F600\nM2\n"
    path = tmp_path / "offsets.nc"
    path.write_text(text)
    cfg = dataclasses.replace(default_config(), work_offsets_mm={"G55": (10.0, 20.0, -4.0)},
                              tools={2: Tool(length_mm=5.0)})
    program = Controller(cfg).check(path)
    rapid, line = program.motions()
    assert rapid.end == pytest.approx((11, 22, -1))
    reference = parse_text(text, str(path), setup=Setup(work_offsets_mm={"G55": (10.0, 20.0, -4.0)},
                                                        tool_lengths_mm={2: 5.0}))
    assert line.end == reference.motions()[1].end
    assert line.end[2] != pytest.approx(-4.0)  # the tool length moved Z


def test_prefetch_keeps_order_and_reraises_the_planners_error():
    from machine.realtime import prefetch

    def planner():
        yield from range(100)
        raise ValueError("E-PLAN at line 7")

    got = []
    with pytest.raises(ValueError, match="line 7"):
        for item in prefetch(planner(), depth=3):
            got.append(item)
    assert got == list(range(100))
