"""Fault injection against the grbl test double: after each fault the ledger shows no
line lost or sent twice, and resuming finishes the program with every motion run
exactly once, in order, ending at the program's end point."""
from __future__ import annotations

import math

import pytest

from grbl_emulator import Faults, GrblDouble, PtyServer, SocketServer
from ipo.config import default_config
from ipr.entities import Arc, Coolant, Dwell, Line, ProgramEnd, Rapid, Spindle
from machine.grbl.ledger import Ledger, LedgerError
from machine.grbl.link import GrblLink, LinkError
from machine.grbl.program import StreamLine, stream_lines
from machine.grbl.words import Format

CFG = default_config()
# Short poll and settle times keep the tests quick; the timeouts stay generous for a loaded machine.
FAST = dict(poll_interval_s=0.02, settle_s=0.03, stall_timeout_s=3.0, reset_timeout_s=5.0, idle_timeout_s=20.0)


def _program():
    """A zigzag of 60 feed lines with a spindle, coolant, a dwell and two arcs."""
    ents = [Spindle(1, 12000.0, "cw"), Coolant(2, False, True), Rapid(3, (0.0, 0.0, 0.0), (0.0, 0.0, 2.0)),
            Line(4, (0.0, 0.0, 2.0), (0.0, 0.0, -1.0), 5.0), Dwell(5, 0.25)]
    p = (0.0, 0.0, -1.0)
    for i in range(60):
        q = (float(i + 1), 3.0 * (i % 2), -1.0)
        ents.append(Line(6 + i, p, q, 20.0))
        p = q
    # a half circle of radius 5, then a full circle of radius 2
    q = (p[0] + 10.0, p[1], -1.0)
    ents.append(Arc(66, p, q, (p[0] + 5.0, p[1], -1.0), "XY", True, 15.0))
    ents.append(Arc(67, q, (q[0], q[1], -1.0), (q[0] - 2.0, q[1], -1.0), "XY", False, 15.0))  # full circle
    ents += [Rapid(68, q, (q[0], q[1], 5.0)), ProgramEnd(69)]
    return ents


WCO = (5.0, -3.0, 1.0)  # the double's G54 offset: lines are written in that work frame
FMT = Format(WCO, CFG.blu_mm / 10)
LINES = list(stream_lines(_program(), CFG, fmt_=FMT))
MOTION_ENDS = [l.end_mm for l in LINES if l.motion]


def _session(port, lines, *, resume_from=None, unlock=False, **kw):
    link = GrblLink(port, **{**FAST, **kw})
    try:
        link.connect(CFG, unlock=unlock)
        if resume_from is None:
            ledger = Ledger(1)
            return link.stream(lines, ledger), None
        point, _ = link.resume_point(l for l in lines if l.seq >= resume_from)
        ledger = Ledger(point.seq)
        return link.stream([l for l in lines if l.seq >= point.seq], ledger, resume=point), point
    finally:
        link.close()


def _assert_ran_once(double: GrblDouble, lines=None):
    ends = MOTION_ENDS if lines is None else [l.end_mm for l in lines if l.motion]
    ran = [t for _, t in double.executed if t is not None]
    assert len(ran) == len(ends)
    for got, want in zip(ran, ends):
        assert got == pytest.approx(want, abs=1e-4)
    assert double.pos == pytest.approx(list(ends[-1]), abs=1e-4)
    assert double.rx_overflow == 0 and double.max_rx_fill <= 127


def _semicircles(n=30):
    """n half circles of radius 2 along X, turning alternately (G2, G3)."""
    ents, p = [Rapid(1, (0.0, 0.0, 0.0), (0.0, 0.0, -1.0))], (0.0, 0.0, -1.0)
    for i in range(n):
        q = (p[0] + 4.0, 0.0, -1.0)
        ents.append(Arc(2 + i, p, q, (p[0] + 2.0, 0.0, -1.0), "XY", bool(i % 2), 20.0))
        p = q
    return list(stream_lines(ents, CFG, fmt_=FMT))


def _assert_covers(first, second, total):
    """The two sessions' ledgers cover 1..total back to back, each line once."""
    first.check()
    second.check()
    assert first.first == 1 and first.resume_from == second.first
    assert second.resume_from == total + 1


def test_clean_stream_over_pty_fills_the_rx_buffer_and_runs_every_line():
    d = GrblDouble(drain_s_per_block=0.0005)
    with PtyServer(d).start() as srv:
        res, _ = _session(srv.port, LINES)
    assert res.completed and res.fault is None
    res.ledger.check()
    assert res.ledger.resume_from == len(LINES) + 1
    assert all(res.ledger.state(l.seq) == "ok" and res.ledger.sends(l.seq) == 1 for l in LINES)
    _assert_ran_once(d)
    assert max(res.rx_fill) <= 127 and max(res.rx_fill) > 90  # counting keeps the buffer nearly full
    assert res.status.state == "Idle" and res.status.mpos == pytest.approx(MOTION_ENDS[-1], abs=1e-3)
    assert res.status.wpos == pytest.approx([a - b for a, b in zip(MOTION_ENDS[-1], WCO)], abs=1e-3)


def test_error_on_a_line_stops_reports_and_resume_finishes():
    bad = next(l for l in LINES if l.source_line == 40)
    # a planner that takes 150 ms to run dry: the hold stops the machine before the lines
    # grbl still has after the rejected one
    d = GrblDouble(drain_s_per_block=0.01, faults=Faults(error_on={bad.text: 20}))
    with PtyServer(d).start() as srv:
        res, _ = _session(srv.port, LINES)
        assert not res.completed and res.fault.kind == "error"
        assert res.fault.seq == bad.seq and res.fault.source_line == 40
        assert "error:20" in res.fault.message and "Unsupported or invalid g-code" in res.fault.message
        assert res.ledger.state(bad.seq) == "error"
        assert res.resume.seq <= bad.seq  # the rejected line and everything after it are still to do
        res2, point = _session(srv.port, LINES, resume_from=res.resume.seq)
    assert res2.completed
    assert point.seq == res.resume.seq
    _assert_covers(res.ledger, res2.ledger, len(LINES))
    _assert_ran_once(d)


@pytest.mark.parametrize("arcs,early_discard", [(False, False), (True, False), (False, True), (True, True)])
@pytest.mark.slow
def test_hold_inside_a_block_resumes_from_the_machine_position(arcs, early_discard):
    """A hold stops inside the running block (a line, or an arc): the resumed stream sends
    that line from where the machine stands (an arc with its IJK from there). Blocks take
    80 ms so that grbl still has blocks queued when the hold arrives on a loaded machine;
    with holds landing just past the joint of two semicircles this found that resume took
    the earlier arc (its circle passes within the tolerance there) and re-sent nearly all of it.
    With `early_discard` the running block has left grbl's planner (as on the real grbl
    1.1h simulator): Bf counts one block less, and the resume still finds it."""
    lines = _semicircles() if arcs else LINES
    bad = next(l for l in lines if l.source_line == (25 if arcs else 46))
    d = GrblDouble(drain_s_per_block=0.08, partial_blocks=True, faults=Faults(error_on={bad.text: 20}),
                   early_discard=early_discard)
    with PtyServer(d).start() as srv:
        res, _ = _session(srv.port, lines)
        assert res.fault.kind == "error" and res.resume.partial  # stopped inside a block, not at its end
        cut, where = d.partials[-1]
        assert ("G2" in cut or "G3" in cut) == arcs
        assert res.resume.at_mm == pytest.approx(where, abs=1e-3)
        res2, point = _session(srv.port, lines, resume_from=res.resume.seq)
    assert point.partial and point.seq == res.resume.seq
    _assert_covers(res.ledger, res2.ledger, len(lines))
    _assert_ran_once(d, lines)


def test_lines_grbl_ran_past_a_rejected_line_are_reported_and_fail_the_ledger():
    """grbl runs the lines it still has after an error before the hold takes effect (its
    RX buffer runs empty, so it starts the cycle; the hold acts 0.1 s late): the report
    says so and the ledger refuses to call the session complete."""
    bad = next(l for l in LINES if l.source_line == 40)
    d = GrblDouble(drain_s_per_block=0.0, faults=Faults(error_on={bad.text: 20}, realtime_delay_s=0.1))
    with PtyServer(d).start() as srv:
        res, _ = _session(srv.port, LINES)
    ran = [t for _, t in d.executed if t is not None]
    assert res.resume.seq > bad.seq
    assert f"grbl ran stream lines {bad.seq + 1}..{res.resume.seq - 1} after rejecting line {bad.seq}" \
        in res.fault.message
    with pytest.raises(LedgerError, match=f"line {bad.seq} .* error"):
        res.ledger.check()
    assert bad.end_mm not in [tuple(r) for r in ran]


def test_a_closed_path_is_not_run_twice_when_grbl_stood_idle():
    """The full circle (line 67) ends where it starts; grbl had run it and stood idle when
    line 68 was rejected, so the resume point is 68, not the circle again."""
    bad = next(l for l in LINES if l.source_line == 68)
    d = GrblDouble(drain_s_per_block=0.0, faults=Faults(error_on={bad.text: 20}))
    with PtyServer(d).start() as srv:
        res, _ = _session(srv.port, LINES)
        assert res.resume.seq == bad.seq and not res.resume.partial
        res2, _ = _session(srv.port, LINES, resume_from=res.resume.seq)
    _assert_covers(res.ledger, res2.ledger, len(LINES))
    _assert_ran_once(d)


def test_alarm_stops_requires_unlock_and_resume_finishes():
    bad = next(l for l in LINES if l.source_line == 30)
    d = GrblDouble(drain_s_per_block=0.003, faults=Faults(alarm_on={bad.text: 2}))
    with PtyServer(d).start() as srv:
        res, _ = _session(srv.port, LINES)
        assert res.fault.kind == "alarm" and "ALARM:2" in res.fault.message and "$X" in res.fault.message
        with pytest.raises(LinkError, match="alarm"):
            _session(srv.port, LINES, resume_from=res.resume.seq)
        res2, _ = _session(srv.port, LINES, resume_from=res.resume.seq, unlock=True)
    assert res2.completed
    _assert_covers(res.ledger, res2.ledger, len(LINES))
    _assert_ran_once(d)


def test_dropped_connection_reports_last_ack_and_resume_checks_position():
    d = GrblDouble(drain_s_per_block=0.003, faults=Faults(drop_after_lines=45))
    with SocketServer(d, banner_on_connect=False).start() as srv:
        res, _ = _session(srv.port, LINES)
        assert res.fault.kind == "disconnected" and res.resume is None
        last = res.ledger.last_acknowledged
        src = next(l.source_line for l in LINES if l.seq == last)
        assert f"last acknowledged stream line {last} (program line {src})" in res.fault.message
        assert res.ledger.last_sent > last  # lines in flight when the port closed
        res2, point = _session(srv.port, LINES, resume_from=last + 1)
    assert point.seq >= last + 1  # grbl ran lines whose answers were lost: not sent again
    res.ledger.resume_from = point.seq
    assert res2.completed
    _assert_covers(res.ledger, res2.ledger, len(LINES))
    _assert_ran_once(d)
    assert srv.connections == 2


def test_garbage_bytes_are_not_taken_for_answers():
    d = GrblDouble(drain_s_per_block=0.0005, faults=Faults(garbage_every=7))
    with PtyServer(d).start() as srv:
        link = GrblLink(srv.port, **FAST)
        link.connect(CFG)
        res = link.stream(LINES, Ledger(1))
        link.close()
    assert res.completed
    res.ledger.check()
    assert len(link.garbage) >= 2 * (len(LINES) // 7)
    _assert_ran_once(d)


def test_slow_acknowledgements_do_not_trip_the_stall_guard():
    d = GrblDouble(drain_s_per_block=0.0, faults=Faults(ack_delay_s=0.01))
    with PtyServer(d).start() as srv:
        res, _ = _session(srv.port, LINES)
    assert res.completed
    res.ledger.check()
    _assert_ran_once(d)


def test_a_board_that_stops_answering_is_reported_with_the_last_ack():
    d = GrblDouble(drain_s_per_block=0.0, faults=Faults(hang_after_lines=32))
    with PtyServer(d).start() as srv:
        res, _ = _session(srv.port, LINES, stall_timeout_s=0.5)
    assert res.fault.kind == "stalled"
    last = res.ledger.last_acknowledged
    assert last == 28  # $$, $I, $G and $# were lines 1 to 4 the double counted
    assert f"--resume-from {last + 1}" in res.fault.message


def _big_arc_lines():
    """A helical YZ arc far out: more than 79 characters with its modal words, fewer without."""
    big, r = 1234567890123.0, 123456.5
    s = (big + 0.125, big + 0.375, -big - 0.625)
    c, e = (s[0], s[1] + 0.6 * r, s[2] + 0.8 * r), (s[0] + 1.5, s[1] + 1.4 * r, s[2] + 0.2 * r)
    return list(stream_lines([Rapid(1, (0.0, 0.0, 0.0), s), Arc(2, s, e, c, "YZ", True, 10.0)], CFG, fmt_=FMT))


def test_a_line_too_long_for_grbl_is_split_and_runs():
    lines = _big_arc_lines()
    assert all(len(l.text) <= 79 for l in lines)
    assert [l.source_line for l in lines].count(2) == 2  # modal words and motion on two lines
    d = GrblDouble()
    with PtyServer(d).start() as srv:
        link = GrblLink(srv.port, **FAST)
        link.connect(CFG)
        res = link.stream(lines, Ledger(1))
        link.close()
    assert res.completed and d.pos == pytest.approx(list(lines[-1].end_mm), abs=1e-4)


def test_a_line_that_cannot_be_split_is_refused_not_truncated():
    huge = 1e30
    from machine.grbl.program import StreamProgramError
    with pytest.raises(StreamProgramError, match=r"line 7: .* characters; grbl takes at most 79"):
        list(stream_lines([Rapid(7, (0.0, 0.0, 0.0), (huge, huge, huge))], CFG))
    d = GrblDouble()
    with PtyServer(d).start() as srv:
        link = GrblLink(srv.port, **FAST)
        link.connect(CFG)
        long = StreamLine(1, 9, "G1X1.0000" + "Y1.0000" * 11, (0.0,) * 3, (1.0, 1.0, 0.0), True, ())
        with pytest.raises(LinkError, match="80|79"):
            link.stream([long], Ledger(1))
        with pytest.raises(LinkError, match="longer than"):
            link.command("G4P" + "0" * 80)
        link.close()
    assert d.lines_received == 4  # only $$, $I, $G and $# reached the board


def test_ledger_refuses_duplicates_and_orphan_answers():
    led = Ledger(1)
    led.sent(1, 10)
    with pytest.raises(LedgerError, match="second time"):
        led.sent(1, 10)
    with pytest.raises(LedgerError, match="before line 2"):
        led.sent(3, 10)
    assert led.answered(True) == (1, 10)
    with pytest.raises(LedgerError, match="no line waiting"):
        led.answered(True)
    led.resume_from = 3
    with pytest.raises(LedgerError, match="line 2 .* unsent"):
        led.check()


def test_connect_warns_where_grbl_rates_disagree_with_the_machine_file():
    settings = dict(GrblDouble().settings)
    settings[110], settings[121], settings[10] = 3000.0, 500.0, 1
    d = GrblDouble(settings=settings)
    with PtyServer(d).start() as srv:
        link = GrblLink(srv.port, **FAST)
        info = link.connect(CFG)
        link.close()
    assert len(info.warnings) == 3
    assert "set $10=3 to see planner blocks free" in info.warnings[2]
    assert "$110=3000 mm/min (X max rate) is lower than the machine file's 6000" in info.warnings[0]
    assert "$121=500" in info.warnings[1] and "1000" in info.warnings[1]
    assert info.build.rx_buffer_bytes == 128 and info.build.planner_blocks == 15
    assert math.isclose(CFG.axes[0].max_velocity_mm_s * 60, 6000.0)


def test_realtime_hold_resume_and_feed_override_reach_grbl():
    from machine.grbl import protocol as P

    d = GrblDouble(drain_s_per_block=0.002)
    seen = []

    def progress(link, ledger):
        st = link.status
        if not seen and ledger.last_acknowledged > 20:
            link.realtime(P.FEED_HOLD)
            link.realtime(P.FEED_OV_PLUS_10)
            link.realtime(P.FEED_OV_PLUS_1)
            seen.append("held")
        elif seen == ["held"] and st is not None and st.state == "Hold":
            link.realtime(P.CYCLE_RESUME)
            seen.append("resumed")
        if st is not None and st.overrides == (111, 100, 100) and "ov" not in seen:
            seen.append("ov")

    with PtyServer(d).start() as srv:
        link = GrblLink(srv.port, **FAST)
        link.connect(CFG)
        res = link.stream(LINES, Ledger(1), on_progress=progress, progress_interval_s=0.0)
        link.close()
    assert res.completed and seen[:2] == ["held", "resumed"] and "ov" in seen
    assert d.ov[0] == 111
    _assert_ran_once(d)
    with pytest.raises(ValueError, match="not a grbl realtime command"):
        link.realtime(b"G")


def test_loop_url_without_grbl_is_a_clear_error():
    link = GrblLink("loop://", reset_timeout_s=0.2, settle_s=0.01)
    with pytest.raises(LinkError, match="no answer"):
        link.connect(CFG)
    link.close()
