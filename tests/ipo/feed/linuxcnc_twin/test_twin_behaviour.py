"""The LinuxCNC twin's own behaviour, against hand computation: a trapezoid, the feed
override, the events and task's waits, the moves it refuses."""
from __future__ import annotations

import numpy as np
import pytest

import ipr
from ipo.config import default_config
from ipo.contracts import LIMIT_DWELL, LIMIT_SEGMENT, PeriodBatch
from ipo.errors import IpoError
from ipo.feed.linuxcnc_twin.planner import plan_periods
from ipo.linuxcnc_ini import LinuxcncSettings
from ipr.entities import Coolant, Message, Nurbs, ProgramEnd, Spindle

S = LinuxcncSettings(servo_period_s=1e-3, axis_velocity_mm_s=(100.0, 100.0, 100.0),
                     axis_accel_mm_s2=(1000.0, 1000.0, 1000.0), max_linear_velocity_mm_s=100.0, task_cycle_s=1e-3)


def _run(text: str, **kw):
    out = list(plan_periods(ipr.parse_text(text).entities, default_config(), settings=S, **kw))
    batches = [b for b in out if isinstance(b, PeriodBatch)]
    return out, np.concatenate([b.feed_mm_s for b in batches]), np.concatenate([b.limit for b in batches])


@pytest.mark.parametrize("override", [1.0, 0.5])
def test_an_exact_stop_line_is_a_trapezoid_at_the_full_acceleration(override):
    """G61.1 G1 X100 F3000: LinuxCNC's discrete trapezoid takes L / v + v / a (100 / 50 + 50 /
    1000 = 2.05 s; at 50 % override 4.025 s), to within a period either side."""
    _, feed, limit = _run("G21 G61.1\nG1 X100 F3000\nM2\n", feed_override=override)
    v = 50.0 * override
    assert abs(len(feed) * 1e-3 - (100.0 / v + v / 1000.0)) <= 1e-3
    assert feed.max() == pytest.approx(v, abs=1e-9)
    assert np.max(np.diff(feed)) == pytest.approx(1.0, abs=1e-9)  # 1000 mm/s^2 * 1 ms


def test_short_segments_run_at_one_segment_per_period():
    """0.01 mm chords at F3000 under G64: at most one segment per period and the optimizer's
    1.02 margin: 0.01 / (0.001 * 1.02) = 9.80 mm/s, limited by the segment rate."""
    text = "G21 G64\nF3000\n" + "".join(f"G1 X{0.01 * k:.2f}\n" for k in range(1, 401)) + "M2\n"
    _, feed, limit = _run(text)
    cruise = feed[len(feed) // 2]
    assert cruise == pytest.approx(0.01 / (0.001 * 1.02), rel=1e-9) and limit[len(feed) // 2] == LIMIT_SEGMENT


def test_events_come_in_order_after_the_machine_stops_and_it_stands_for_task():
    text = ("G21 G64\nG1 X10 F3000\nM3 S1000\nG1 X20\nM8\nG1 X30\n(MSG, here)\nG1 X40\nG4 P0.25\nG1 X50\nM2\n")
    out, feed, limit = _run(text)
    events = [type(e) for e in out if not isinstance(e, PeriodBatch)]
    assert events == [Spindle, Coolant, Message, ProgramEnd]
    standing = np.r_[0, (limit == LIMIT_DWELL).astype(int), 0]
    runs = np.nonzero(np.diff(standing) == -1)[0] - np.nonzero(np.diff(standing) == 1)[0]
    # task's 7 ms after M3 and the message, iocontrol's 80 ms for M8, 250 ms + 7 ms of dwell
    assert sorted(runs.tolist())[:4] == [7, 7, 80, 257]
    assert all(feed[k] == 0.0 for k in np.nonzero(limit == LIMIT_DWELL)[0])


def test_a_curve_in_no_plane_and_a_move_from_elsewhere_are_refused():
    curve = Nurbs(3, 2, np.array([0, 0, 0, 1, 1, 1.0]), np.ones(3), np.array([[0, 0, 0], [5, 5, 5], [10, 0, 2.0]]),
                  50.0)
    with pytest.raises(IpoError) as err:
        list(plan_periods([curve], default_config(), settings=S))
    assert err.value.code == "E-TWIN-UNSUPPORTED" and err.value.line == 3
    with pytest.raises(IpoError, match="motion starts at"):
        list(plan_periods(ipr.parse_text("G21\nG1 X5 F600\n").entities, default_config(), settings=S,
                          start_mm=(1.0, 0.0, 0.0)))
