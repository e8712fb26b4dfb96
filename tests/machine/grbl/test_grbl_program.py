"""grbl protocol parsing, the streamed program and the resume search, against hand-made values."""
from __future__ import annotations

import math

import numpy as np
import pytest

from ipo.config import default_config
from ipo.nurbs.kernel import curve_points
from ipo.contracts import PeriodBatch
from ipr.entities import Arc, Coolant, Line, Nurbs, ProgramEnd, Rapid, Spindle, ToolChange
from machine.grbl import protocol as P
from machine.grbl.program import StreamLine, StreamProgramError, merge_polyline, resume_text, stream_lines
from machine.grbl.words import Format, fmt
from machine.grbl.resume import ResumeError, find_resume

CFG = default_config()


def test_status_report_with_wco_fills_work_position():
    st = P.parse_status("<Run|MPos:10.000,-2.500,3.000|Bf:12,96|FS:1200,8000|WCO:5.000,-3.000,1.000>")
    assert st.state == "Run" and st.substate is None
    assert st.wpos == pytest.approx((5.0, 0.5, 2.0))
    assert (st.planner_free, st.rx_free, st.feed_mm_min, st.spindle_rpm) == (12, 96, 1200.0, 8000.0)
    later = P.parse_status("<Hold:0|MPos:11.000,0.000,1.000|Ov:120,100,100|Pn:XZ|Ln:42|F:500>", st.wco)
    assert later.state == "Hold" and later.substate == 0 and later.wpos == pytest.approx((6.0, 3.0, 0.0))
    assert later.overrides == (120, 100, 100) and later.pins == "XZ" and later.line == 42
    assert later.feed_mm_min == 500.0 and later.spindle_rpm is None
    wpos_only = P.parse_status("<Idle|WPos:1.000,2.000,3.000>", (1.0, 1.0, 1.0))
    assert wpos_only.mpos == pytest.approx((2.0, 3.0, 4.0))
    with pytest.raises(P.StatusError):
        P.parse_status("<Flying|MPos:0,0,0>")
    with pytest.raises(P.StatusError):
        P.parse_status("<Idle|FS:0,0>")


def test_classify_and_meanings():
    kinds = [P.classify(b).kind for b in (b"ok", b"error:22", b"ALARM:1", b"<Idle|MPos:0,0,0>",
                                         b"Grbl 1.1h ['$' for help]", b"$110=500.000", b"[MSG:Pgm End]",
                                         b">G54G20:ok", b"\xffok", b"okay")]
    assert kinds == ["ok", "error", "alarm", "status", "banner", "setting", "feedback", "startup",
                     "garbage", "garbage"]
    assert P.classify(b"error:22").code == 22
    assert P.error_meaning(22) == "Feed rate has not yet been set or is undefined."
    assert "soft limit" in P.alarm_meaning(2)
    assert P.error_meaning(99) == "unknown grbl error code 99"


def test_settings_and_build_info():
    s = P.parse_settings(["$0=10", "$110=500.000", "$N0=G54", "junk", "$120=10.5"])
    assert s == {0: 10.0, 110: 500.0, 120: 10.5}
    b = P.parse_build_info(["[VER:1.1h.20190825:my mill]", "[OPT:VNM,35,254]"])
    assert (b.version, b.options, b.planner_blocks, b.rx_buffer_bytes) == ("1.1h.20190825", "VNM", 35, 254)
    old = P.parse_build_info(["[VER:1.1d.20161014:]", "[OPT:VL]"])
    assert old.rx_buffer_bytes is None


def test_passthrough_lines_are_compact_and_exact():
    """Modal words where they change, axis words where the axis moves, numbers as short as
    a tenth of the 1 um BLU allows; written by hand from the G-code semantics."""
    ents = [Spindle(1, 1000.0, "ccw"), Coolant(2, True, True), Rapid(3, (0, 0, 0), (1, 2, 3)),
            Line(4, (1, 2, 3), (-0.00001, 2, 3), 10.0), Line(5, (0, 2, 3), (0.5, -2.25, 3), 10.0),
            Arc(6, (0.5, -2.25, 3), (0.5, -2.25, 3), (0.5, -2.25, 0), "ZX", True, 5.0, turns=1),
            ToolChange(7, 3), ProgramEnd(8)]
    notes = []
    lines = list(stream_lines(ents, CFG, notices=notes))
    texts = [l.text for l in lines]
    # grbl's parser after a reset is in mm, absolute, units/min: no preamble is needed
    assert texts[:7] == ["M4S1000", "M9", "M7", "M8", "G0X1Y2Z3", "G1F600X0", "X.5Y-2.25"]
    # a full circle plus one extra turn: two full circles of radius 3 in ZX, K = centre - start;
    # the end equals the start, so one in-plane axis word is written (grbl's error:32 otherwise)
    arcs = [l for l in lines if l.arc]
    assert [a.text for a in arcs] == ["G18G3F300Z3K-3", "Z3K-3"]
    assert arcs[0].end_mm == pytest.approx((0.5, -2.25, 3))
    assert texts[-2:] == ["M0", "M2"] and "T3" in notes[0]
    assert [l.seq for l in lines] == list(range(1, len(lines) + 1))
    # restoring after a reset sets every mode the line runs in
    assert arcs[1].restore == ("G21G90G94G18G3F300", "M4S1000", "M7", "M8")


def test_work_frame_g53_preamble_and_line_numbers():
    """Lines are written in the WCO's work frame; a G53 move goes out as G53 in machine
    coordinates; grbl in G20/G91 gets G21G90 first; numbered lines carry N<seq>."""
    fmt_ = Format((10.0, 20.0, -30.0), 1e-4, numbered=True)
    ents = [Rapid(1, (50, 50, -5), (50, 50, -2)), Line(2, (50, 50, -2), (60, 50, -2), 5.0)]
    lines = list(stream_lines(ents, CFG, start_mm=(50, 50, -5), fmt_=fmt_, g53_lines=frozenset({(None, 1)}),
                              modal=("G0", "G54", "G17", "G20", "G91", "G94")))
    assert [l.text for l in lines] == ["N1G21G90", "N2G53G0Z-2", "N3G1F300X50"]
    assert lines[2].start_mm == (50, 50, -2) and lines[2].end_mm == (60, 50, -2)


def test_numbers_have_the_fewest_decimals_within_a_tenth_of_the_blu():
    tol = 1e-4
    assert [fmt(v, tol) for v in (0.5, -0.5, 10.0, -0.00004, 12.3456789, 100.00004, 1.23449)] == \
        [".5", "-.5", "10", "0", "12.3457", "100", "1.2345"]
    assert all(abs(float(fmt(v, tol)) - v) <= tol for v in np.linspace(-7, 7, 1001) * math.pi)


def test_helical_turns_split_into_equal_arcs_on_the_helix():
    arc = Arc(1, (10.0, 0.0, 0.0), (0.0, 10.0, 6.0), (0.0, 0.0, 0.0), "XY", True, 10.0, turns=2)
    lines = [l for l in stream_lines([arc], CFG, start_mm=(10.0, 0.0, 0.0)) if l.arc]
    assert len(lines) == 3
    sweep = 2 * math.pi * 2 + math.pi / 2
    for k, l in enumerate(lines, 1):  # each piece ends on the circle at k/3 of the sweep and the rise
        th = sweep * k / 3
        assert l.end_mm == pytest.approx((10 * math.cos(th), 10 * math.sin(th), 6.0 * k / 3), abs=1e-9)


def test_merge_keeps_every_period_point_within_tolerance():
    th = np.linspace(0, np.pi / 2, 2001)
    pts = np.c_[50 * np.cos(th), 50 * np.sin(th), np.zeros_like(th)]
    tol = 0.001
    keep = merge_polyline(pts, tol)
    assert keep[0] == 0 and keep[-1] == len(pts) - 1
    # the sagitta of a chord c on radius R is c^2/(8R): segments may not exceed 2*sqrt(2*R*tol)
    worst = 0.0
    for a, b in zip(keep[:-1], keep[1:]):
        seg = pts[b] - pts[a]
        for p in pts[a + 1:b]:
            t = np.clip(np.dot(p - pts[a], seg) / np.dot(seg, seg), 0, 1)
            worst = max(worst, np.linalg.norm(pts[a] + t * seg - p))
    assert worst <= tol
    longest = 2 * math.sqrt(2 * 50 * tol)
    assert np.max(np.linalg.norm(np.diff(pts[keep], axis=0), axis=1)) <= longest + 1e-9
    assert len(keep) - 1 >= math.ceil(50 * np.pi / 2 / longest)  # no fewer segments than geometry allows


def _quarter_circle():
    w = math.sqrt(0.5)
    return Nurbs(9, 2, np.array([0, 0, 0, 1, 1, 1.0]), np.array([1, w, 1.0]),
                 np.array([[30, 20, 0], [30, 30, 0], [20, 30, 0.0]]), 50.0)


def _fake_plan(speed_mm_s, period_s):
    """Tests only: periods along the exact curve at constant arc-length speed (a stand-in IPO)."""
    def plan(ents, start_mm):
        for e in ents:
            if isinstance(e, Nurbs):
                u = np.linspace(0, 1, 20001)
                c = curve_points(e.degree, e.knots, e.weights, e.points, u)
                s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))]
                n = int(s[-1] / (speed_mm_s * period_s))
                targets = np.interp(np.arange(1, n + 1) * speed_mm_s * period_s, s, u)
                pos = curve_points(e.degree, e.knots, e.weights, e.points, targets)
                yield PeriodBatch(pos, np.zeros((n, 3), np.int64), np.full(n, speed_mm_s), np.zeros(n, np.int8),
                                  np.full(n, e.line, np.int32))
    return plan


def test_nurbs_goes_out_as_g1_segments_at_the_planned_feed_within_tolerance():
    nurbs = _quarter_circle()
    lines = list(stream_lines([nurbs], CFG, start_mm=(30, 20, 0), merge_tol_mm=0.001,
                              plan=_fake_plan(40.0, CFG.period_s)))
    segs = lines
    assert segs[0].text.startswith("G1F2400") and all(l.source_line == 9 for l in segs)
    assert segs[-1].end_mm == pytest.approx((20, 30, 0))
    feeds = [l.feed_mm_min for l in segs[:-1]]
    assert feeds == pytest.approx([40.0 * 60] * len(feeds), rel=1e-3)  # the planned 40 mm/s
    # every vertex lies on the radius-10 circle about (20, 20), every chord's sagitta <= tolerance
    ends = np.array([l.end_mm for l in segs])
    r = np.hypot(ends[:, 0] - 20, ends[:, 1] - 20)
    assert np.max(np.abs(r - 10)) < 1e-4
    chords = np.linalg.norm(np.diff(np.vstack(([30, 20, 0], ends)), axis=0), axis=1)
    assert np.max(chords[:-1] ** 2 / (8 * 10)) <= 0.001 + 2 * 40 * CFG.period_s * 1e-3


def _line(seq, s, e, motion=True, arc=None):
    return StreamLine(seq, seq, "x", tuple(map(float, s)), tuple(map(float, e)), motion, (), arc)


def test_find_resume_inside_at_start_and_after_idempotent_lines():
    w = [_line(5, (0, 0, 0), (10, 0, 0)), _line(6, (10, 0, 0), (10, 0, 0), motion=False),
         _line(7, (10, 0, 0), (10, 5, 0))]
    assert find_resume(w, (4.0, 0, 0)).seq == 5 and find_resume(w, (4.0, 0, 0)).partial
    assert find_resume(w, (0, 0, 0)).seq == 5 and not find_resume(w, (0, 0, 0)).partial
    assert find_resume(w, (10.0, 0.0005, 0)).seq == 6  # the spindle line is sent again
    assert find_resume(w, (10, 5, 0)).seq == 8
    with pytest.raises(ResumeError, match="on none of stream lines 5..7"):
        find_resume(w, (3, 3, 0))


def test_resume_inside_an_arc_recomputes_ijk_from_the_machine_position():
    center = (0.0, 0.0, 0.0)
    arc = StreamLine(3, 3, "G3X0Y10I-10", (10.0, 0, 0), (0, 10.0, 0), True, (), (center, "XY", True, 600.0),
                     Format((1.0, 2.0, 3.0)), 600.0)
    p = (10 * math.cos(0.3), 10 * math.sin(0.3), 0.0)
    point = find_resume([arc], p)
    assert point.partial and point.seq == 3
    # written in the work frame (machine - (1, 2, 3)); IJK = centre - the machine position
    assert resume_text(arc, p) == f"G3X-1Y8I{-p[0]:.4f}J{-p[1]:.4f}"


def test_resume_near_the_joint_of_two_tangent_arcs_picks_the_arc_the_machine_is_on():
    # G2 from (32,0) to (36,0) about (34,0), then G3 to (40,0) about (38,0): a point 0.05 mm into the
    # second arc is also within the tolerance of the first arc's circle (2.0012 mm from its centre)
    first = StreamLine(8, 8, "G2...", (32.0, 0, -1), (36.0, 0, -1), True, (), ((34.0, 0, -1), "XY", False, 1200.0))
    second = StreamLine(9, 9, "G3...", (36.0, 0, -1), (40.0, 0, -1), True, (), ((38.0, 0, -1), "XY", True, 1200.0))
    phi = 0.025  # on the second circle, 0.05 mm past the joint
    p = (38.0 - 2.0 * math.cos(phi), -2.0 * math.sin(phi), -1.0)
    assert abs(math.hypot(p[0] - 34, p[1]) - 2) < 0.002 and abs(math.hypot(p[0] - 38, p[1]) - 2) < 0.002
    point = find_resume([first, second], p)
    assert point.seq == 9 and point.partial
    # a point on the first arc's circle but outside its swept half is not on it
    with pytest.raises(ResumeError):
        find_resume([first], (34.0, -2.0, -1.0))
    assert find_resume([first], (34.0, 2.0, -1.0)).seq == 8  # clockwise from (32,0) passes above the centre


def test_stream_demand_by_hand():
    from machine.grbl.budget import stream_demand

    # 100 moves of 0.1 mm at 6000 mm/min (100 mm/s): 1000 lines/s of "X10.1" .. "X19.9", 5 characters
    # + newline (the first line carries G1F6000, the tenths that end in 0 are shorter: "X11", "X20")
    ents, p = [], (10.0, 0.0, 0.0)
    for i in range(100):
        q = (round(10.0 + 0.1 * (i + 1), 4), 0.0, 0.0)
        ents.append(Line(i + 1, p, q, 100.0))
        p = q
    lines = list(stream_lines(ents, CFG, start_mm=(10.0, 0.0, 0.0)))
    assert lines[0].text == "G1F6000X10.1" and lines[9].text == "X11"
    assert {len(l.text) for l in lines[1:] if l.seq % 10} == {5}
    d = stream_demand(lines, baud=115200, planner_blocks=15, accel_mm_s2=1000.0)
    assert d.peak_bytes_s == pytest.approx(6 * 1000.0, rel=0.15)
    assert d.capacity_bytes_s == 11520.0
    # 15 blocks span 1.5 mm: stopping within them allows sqrt(2 * 1000 * 1.5) = 54.77 mm/s
    assert d.slowest_ratio == pytest.approx(math.sqrt(3000.0) / 100.0)
    assert len(d.warnings) == 1 and "3286 mm/min" in d.warnings[0]
    slow = stream_demand(lines, baud=1_000_000, planner_blocks=15, accel_mm_s2=1e6)
    assert slow.warnings == []


def test_nurbs_sent_through_the_ipo_stays_within_the_merge_tolerance_of_the_exact_circle():
    from pathlib import Path

    from ipr import parse_file

    # programs/circle_nurbs.nc: a rational quadratic full circle of radius 10 about the origin.
    # The vertices are the IPO's period points on the curve (not BLU-rounded) written with 4
    # decimals, merged within the tolerance less that rounding: the polyline sent stays within it.
    prog = parse_file(Path(__file__).resolve().parents[3] / "programs" / "circle_nurbs.nc")
    nurbs = next(e for e in prog.entities if isinstance(e, Nurbs))
    lines = list(stream_lines(prog.entities, CFG, ipo_from_start=True, merge_tol_mm=0.001))
    ends = [l.end_mm for l in lines if l.motion and l.source_line == nurbs.line]
    poly = np.array([nurbs.start] + ends)
    assert len(poly) > 50 and np.allclose(poly[-1], nurbs.end)
    seg = poly[:-1, None] + np.linspace(0, 1, 101)[None, :, None] * np.diff(poly, axis=0)[:, None]
    assert np.abs(np.hypot(seg[..., 0], seg[..., 1]) - 10.0).max() <= 0.001
    with pytest.raises(StreamProgramError, match="merge tolerance 5e-05 mm must exceed"):
        list(stream_lines(prog.entities, CFG, merge_tol_mm=5e-5))
